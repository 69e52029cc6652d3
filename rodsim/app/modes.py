"""``rodsim.modes``: natural frequencies and mode shapes of a scene about its equilibrium.

    >>> import rodsim
    >>> modes = rodsim.modes("tdcr-two-segment", count=6)
    >>> modes.frequencies          # Hz, lowest first
    >>> modes.shapes[0]            # the first mode's displacement of every node (nodes, 3)

The equilibrium is solved first (``static`` by default), or taken from a solved
``rodsim.solvers.result.Result``; then K φ = ω² M φ is solved about it with the
physical masses (rodsim/core/inertia.py, rodsim/core/vibration.py; docs/dynamics.md).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from rodsim.app.api import SceneLike, load_scene, solve
from rodsim.core.damped_vibration import DampedVibration, damped_modes
from rodsim.core.damping import Damping
from rodsim.core.inertia import mass_factor, total_mass
from rodsim.core.model import Model
from rodsim.core.stability import MAX_BAND
from rodsim.core.stability_band import BandStiffness
from rodsim.core.vibration import ModesError, Vibration, natural_modes
from rodsim.solvers.physical.coordinates import physical_state
from rodsim.solvers.result import Result
from rodsim.solvers.summary import millimetres, summary_html, summary_text

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["Modes", "modes", "ModesError", "DEFAULT_COUNT"]

#: Modes computed when no count is given.
DEFAULT_COUNT = 6


@dataclass
class Modes:
    """The lowest natural modes of a scene about its equilibrium. ``repr`` is a summary of
    at most ten lines, and Jupyter shows it as a table (``_repr_html_``).

    Attributes
    ----------
    result
        The equilibrium (a solved run).
    success, message
        Whether the modes were computed; what happened (the equilibrium's failure, or a
        warning such as an unstable equilibrium's ω² < 0).
    frequencies
        f = Re(ω) / 2π of each mode [Hz], lowest first (NaN where ω² ≤ 0: no oscillation).
    eigenvalues
        ω² [rad²/s²]: real for a conservative scene, complex when a non-conservative
        coupling makes K non-symmetric (``growth`` is then the imaginary part).
    shapes
        Displacement of every control point in each mode [m], shape (modes, nodes, 3), the
        rods concatenated as in a run archive (``result``'s order), scaled so that the modal
        mass φᵀ M φ is the scene's whole mass times 1 m² (a mass-weighted RMS motion of
        1 m: the rotation's kinetic energy counted too).
    rotations
        The quaternion part of each mode, shape (modes, segments, 4), scaled likewise.
    growth
        Im(ω) / 2π [Hz] of each mode: 0 for a conservative scene; an oscillation grows as
        e^{−2π growth t} (negative growth: growing).
    rotational_share
        Fraction of each mode's kinetic energy in the segments' rotation (0 to 1): about 1
        for a torsion mode, small for bending and axial modes (0 without rotary inertia).
    rotary_inertia
        Whether the segments' rotary inertia (ρI, ρJ) was included.
    damped_eigenvalues
        With the scene's damping (``[rods.<rod>.damping]``: Kelvin–Voigt and drag), the
        roots λ [1/s] of (λ² M + λ D + K) φ = 0 of lowest |λ|, one of each conjugate pair
        (rodsim/core/damped_vibration.py); without damping, i ω. For light damping the
        k-th is the k-th mode's.
    damped_frequencies
        Im λ / 2π [Hz]: the frequency a damped mode rings at (0: a root that does not
        oscillate, an overdamped mode or a relaxation).
    damping_ratios
        ζ = −Re λ / |λ| of each root (0 without damping; 1 for a real root).
    """

    result: Result
    success: bool
    message: str
    frequencies: np.ndarray = field(default_factory=lambda: np.zeros(0))
    eigenvalues: np.ndarray = field(default_factory=lambda: np.zeros(0))
    shapes: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3)))
    rotations: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 4)))
    growth: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rotational_share: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rotary_inertia: bool = True
    symmetric: bool = True
    damped_eigenvalues: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=complex))
    damped_frequencies: np.ndarray = field(default_factory=lambda: np.zeros(0))
    damping_ratios: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: The modes on the free coordinates (count, n), unit modal mass (φᴴ M φ = 1), for
    #: checks (K φ = ω² M φ).
    vectors: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)), repr=False)

    def summary_rows(self) -> list[tuple[str, str]]:
        """The summary's rows: outcome, the frequencies, the damping ratios and the growth
        when there are any, the equilibrium (its integrator, the first rod's tip, its
        stability), the inertia."""
        rows = [("outcome", self.message if self.success else f"FAILED: {self.message}")]
        if len(self.frequencies):
            rows.append(("frequencies", ", ".join(
                "none" if np.isnan(f) else f"{f:.4g}" for f in self.frequencies) + " Hz"))
        if np.any(self.damping_ratios[np.isfinite(self.damping_ratios)] > 0.0):
            rows.append(("damping ratios", ", ".join(f"{z:.3g}" for z in self.damping_ratios)))
        if np.any(self.growth != 0.0):
            rows.append(("largest |growth|", f"{float(np.max(np.abs(self.growth))):.3g} Hz "
                                             "(a non-conservative coupling)"))
        result = self.result
        rows.append(("equilibrium", f"{result.integrator}, residual {result.residual:.3g}"))
        if result.rods:
            rows.append((f"tip of {next(iter(result.rods))}", millimetres(result.tip())))
        if result.stability is not None:
            rows.append(("stability", "stable" if result.stability.stable else "not stable"))
        if self.success:
            rows.append(("inertia", "translation and rotation of the segments"
                         if self.rotary_inertia else "translation only (no rotary inertia)"))
        return rows

    def _title(self) -> str:
        count = f"{len(self.frequencies)} lowest modes" if self.success else "no modes"
        return f"rodsim Modes: scene {self.result.scene.name!r}, {count}"

    def __repr__(self) -> str:
        return summary_text(self._title(), self.summary_rows())

    def _repr_html_(self) -> str:
        return summary_html(self._title(), self.summary_rows())

    def to_xarray(self) -> xr.Dataset:
        """The modes archive: the run archive of the equilibrium with a ``mode`` dimension
        (docs/archive.md, "Modes archives")."""
        from rodsim.io.modes_dataset import modes_dataset

        return modes_dataset(self.result, frequencies=self.frequencies,
                             eigenvalues=self.eigenvalues, shapes=self.shapes,
                             rotations=self.rotations,
                             rotational_share=self.rotational_share,
                             rotary_inertia=self.rotary_inertia, message=self.message,
                             damped_eigenvalues=self.damped_eigenvalues,
                             damped_frequencies=self.damped_frequencies,
                             damping_ratios=self.damping_ratios)


def modes(scene: SceneLike | Result | None = None, count: int = DEFAULT_COUNT, *,
          overrides: Iterable[str] = (), integrator: str = "static",
          rotary_inertia: bool = True) -> Modes:
    """The ``count`` lowest natural modes of ``scene`` about its equilibrium.

    ``scene``: a scene, path, shipped scene name or dict (its equilibrium is solved with
    ``integrator``, ``overrides`` applied first), or a solved
    ``rodsim.solvers.result.Result`` (its state is the equilibrium). ``rotary_inertia``
    False leaves the segments' rotary inertia out (the Euler–Bernoulli beam's inertia).
    A failed equilibrium gives ``success`` False; a bad ``count`` raises
    ``rodsim.core.vibration.ModesError`` (a ValueError), a bad scene
    ``rodsim.core.schema.SceneError``.
    """
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
        raise ModesError(f"count = {count!r}: allowed a whole number >= 1")
    if isinstance(scene, Result):
        if list(overrides):
            raise ModesError("overrides apply to a scene, not to a solved Result: solve the "
                             "changed scene first, or pass the scene")
        result = scene
    else:
        result = solve(load_scene(scene, overrides), integrator)
    if not result.success:
        return Modes(result, False, f"no equilibrium to vibrate about: {result.message}",
                     rotary_inertia=rotary_inertia)
    model = Model(result.scene)
    x = result.state
    registered = model.reregistered(x, exact=True)
    model = (model if registered is None else registered).anchored(x)
    vibration = _solve(model, x, count, rotary_inertia)
    translational = mass_factor(model, x, rotary=False).T @ vibration.vectors.T
    share = 1.0 - np.sum(np.abs(translational) ** 2, axis=0)
    damper = Damping(model)
    damped = _damped(model, x, count, rotary_inertia, damper) if damper.active else None
    return _modes_of(result, model, vibration, rotary_inertia, np.clip(share, 0.0, 1.0),
                     damped)


def _problem(model: Model, x: np.ndarray
             ) -> tuple[sp.spmatrix, BandStiffness | None, np.ndarray]:
    """K = −∂F/∂x of ``model`` at ``x``, its band storage when the band is narrow enough,
    and the Jacobian's data."""
    data = model.jacobian_data(x)
    band = model.band
    banded = (BandStiffness(model.pattern_rows, model.pattern_cols, model.n, band.lower,
                            band.upper) if band.lower + band.upper + 1 <= MAX_BAND else None)
    return -model.pattern_matrix(data), banded, data


def _solve(model: Model, x: np.ndarray, count: int, rotary: bool) -> Vibration:
    """The eigenproblem of ``model`` at ``x`` (band LU when the band is narrow enough)."""
    stiffness, banded, data = _problem(model, x)
    return natural_modes(stiffness, mass_factor(model, x, rotary), count, band=banded,
                         jacobian=data)


def _damped(model: Model, x: np.ndarray, count: int, rotary: bool, damper: Damping
            ) -> DampedVibration:
    """The damped roots of ``model`` at ``x`` with its damping D, each quaternion's norm
    direction taken out of D (as in physical time, where |q| = 1 is kept exactly and the
    damping acts through Gᵀ D G, rodsim/solvers/physical/midpoint.py)."""
    stiffness, banded, data = _problem(model, x)
    free_of = np.full(model.full_size, -1)
    free_of[model.free] = np.arange(model.n)
    physical = physical_state(model, x)
    rows, cols, values = [], [], []
    for rod in model.rods.values():
        for block in free_of[rod.layout.quaternion_index]:
            index = block[block >= 0]
            q = physical[index]
            norm = float(np.linalg.norm(q))
            if norm > 0.0:
                q = q / norm
                rows.append(np.repeat(index, len(index)))
                cols.append(np.tile(index, len(index)))
                values.append(-np.outer(q, q).ravel())
    projector = sp.identity(model.n, format="csr")
    if rows:
        projector = projector + sp.csr_matrix(
            (np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))),
            shape=(model.n, model.n))
    damping = projector @ damper.matrix(physical) @ projector
    return damped_modes(stiffness, mass_factor(model, x, rotary), damping, count,
                        band=banded, jacobian=data)


def _modes_of(result: Result, model: Model, vibration: Vibration, rotary: bool,
              rotational_share: np.ndarray, damped: DampedVibration | None) -> Modes:
    """The user's view of ``vibration`` (and of ``damped``, the damped roots; None: no
    damping): frequencies in Hz, node displacements per rod."""
    omega = vibration.angular_frequencies
    frequencies = np.where(vibration.eigenvalues.real > 0.0, omega.real, np.nan) / (2 * np.pi)
    full = np.zeros((len(vibration.vectors), model.full_size), dtype=vibration.vectors.dtype)
    full[:, model.free] = vibration.vectors * np.sqrt(total_mass(model))
    shapes = np.concatenate([full[:, model.rods[name].layout.position_index]
                             for name in result.rods], axis=1)
    rotations = np.concatenate([full[:, model.rods[name].layout.quaternion_index]
                                for name in result.rods], axis=1)
    messages = []
    if np.any(vibration.eigenvalues.real <= 0.0):
        messages.append("unstable equilibrium: ω² ≤ 0 for a mode (no oscillation; a small "
                        "perturbation grows)")
    if not vibration.symmetric:
        messages.append("K is not symmetric (a non-conservative term: the paper's tendon "
                        "coupling, friction): ω² may be complex; shapes are the real parts")
    if damped is None:
        roots = 1j * omega
        damped_frequencies = frequencies.copy()
        ratios = np.where(np.isnan(frequencies), np.nan, 0.0)
    else:
        roots = damped.eigenvalues
        damped_frequencies = damped.damped_frequencies
        ratios = damped.damping_ratios
        still = int(np.sum(np.isfinite(roots) & (roots.imag == 0.0)))
        if still:
            messages.append(f"{still} of the damped roots do not oscillate (overdamped "
                            "modes or relaxations: damped frequency 0, damping ratio 1)")
        if np.any(np.isnan(roots)):
            messages.append("fewer damped roots converged than modes asked for (NaN; "
                            "Kelvin-Voigt's overdamped modes gather near lambda = -1/tau)")
    return Modes(result, True, "; ".join(messages) or "ok",
                 frequencies=frequencies, eigenvalues=vibration.eigenvalues,
                 shapes=shapes.real, rotations=rotations.real,
                 growth=omega.imag / (2 * np.pi), rotational_share=rotational_share,
                 rotary_inertia=rotary,
                 symmetric=vibration.symmetric, damped_eigenvalues=roots,
                 damped_frequencies=damped_frequencies, damping_ratios=ratios,
                 vectors=vibration.vectors)


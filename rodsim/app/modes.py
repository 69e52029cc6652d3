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
from rodsim.solvers import DEFAULT_INTEGRATOR
from rodsim.solvers.physical.coordinates import physical_state
from rodsim.solvers.result import Result
from rodsim.solvers.summary import millimetres, sketch_svg, summary_html, summary_text

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["Modes", "modes", "match_shapes", "ModesError", "DEFAULT_COUNT"]

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
        (rodsim/core/damped_vibration.py); without damping, i ω. Ordered by |λ|, not by
        mode (heavy damping puts real roots between them): ``matched_eigenvalues`` gives
        each mode its own.
    damped_frequencies
        Im λ / 2π [Hz]: the frequency a damped mode rings at (0: a root that does not
        oscillate, an overdamped mode or a relaxation).
    damping_ratios
        ζ = −Re λ / |λ| of each root (0 without damping; 1 for a real root).
    matched_eigenvalues
        For each undamped mode (the order of ``frequencies``), the damped root λ whose
        complex shape is nearest its shape (the largest mass-weighted MAC, each root given
        to one mode, the best pairs first; NaN where none is left): what that mode becomes
        with the damping, whatever the order of the roots by |λ|. Without damping i ω.
    matched_damping_ratios
        ζ = −Re λ / |λ| of each of ``matched_eigenvalues``.
    shape_mac
        The MAC |φᴴ M φ_d|² / ((φᴴ M φ)(φ_dᴴ M φ_d)) of each mode and its damped shape
        (1: the same shape; 1 without damping).
    damped_shapes, damped_rotations
        The complex shapes φ_d of ``matched_eigenvalues`` [m], laid out and scaled as
        ``shapes`` and ``rotations`` (modal mass φ_dᴴ M φ_d the scene's mass times 1 m²),
        turned in phase so that φ_dᴴ M φ is real and positive: equal to the undamped shape
        for a damping proportional to K or M; an imaginary part is the motion a quarter
        period out of phase (a travelling, non-proportionally damped mode). The motion is
        Re(φ_d e^{λt}).
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
    matched_eigenvalues: np.ndarray = field(
        default_factory=lambda: np.zeros(0, dtype=complex))
    matched_damping_ratios: np.ndarray = field(default_factory=lambda: np.zeros(0))
    shape_mac: np.ndarray = field(default_factory=lambda: np.zeros(0))
    damped_shapes: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3), dtype=complex))
    damped_rotations: np.ndarray = field(
        default_factory=lambda: np.zeros((0, 0, 4), dtype=complex))
    #: The modes on the free coordinates (count, n), unit modal mass (φᴴ M φ = 1), for
    #: checks (K φ = ω² M φ).
    vectors: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)), repr=False)

    def summary_rows(self) -> list[tuple[str, str]]:
        """The summary's rows: outcome, the frequencies, the damping ratios (of each mode's
        matched damped root) and the growth when there are any, the equilibrium (its
        integrator, the first rod's tip, its stability), the inertia."""
        rows = [("outcome", self.message if self.success else f"FAILED: {self.message}")]
        if len(self.frequencies):
            rows.append(("frequencies", ", ".join(
                "none" if np.isnan(f) else f"{f:.4g}" for f in self.frequencies) + " Hz"))
        ratios = self.matched_damping_ratios  # each mode's own root, as the frequencies
        if np.any(ratios[np.isfinite(ratios)] > 0.0):
            rows.append(("damping ratios", ", ".join(f"{z:.3g}" for z in ratios)))
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
        return summary_html(self._title(), self.summary_rows(), sketch_svg(
            [rod.positions for rod in self.result.rods.values()] if self.success else []))

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
                             damping_ratios=self.damping_ratios,
                             matched_eigenvalues=self.matched_eigenvalues,
                             shape_mac=self.shape_mac, damped_shapes=self.damped_shapes,
                             damped_rotations=self.damped_rotations)


def modes(scene: SceneLike | Result | None = None, count: int = DEFAULT_COUNT, *,
          overrides: Iterable[str] = (), integrator: str = DEFAULT_INTEGRATOR,
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
    mass = mass_factor(model, x, rotary_inertia)
    matched = None if damped is None else match_shapes(vibration.vectors, damped, mass)
    return _modes_of(result, model, vibration, rotary_inertia, np.clip(share, 0.0, 1.0),
                     damped, matched)


#: Damped roots within this relative distance of each other are one repeated root (a round
#: rod's bending pair in y and z): any combination of their shapes is a shape of it.
DEGENERATE = 1e-5


def match_shapes(undamped: np.ndarray, damped: DampedVibration, factor: sp.spmatrix
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The damped root of each undamped mode (rows of ``undamped``, (count, n)) and its
    shape, by the mass-weighted MAC (M = L Lᵀ, ``factor`` L) against every root ``damped``
    found. A repeated root (within ``DEGENERATE``) is one candidate whose shapes span a
    space: the mode's damped shape is the M-orthogonal projection of the mode on it (an
    eigenvector of the same root), and its MAC the mode's share in it, ‖Pφ‖²_M / ‖φ‖²_M —
    for a single root the MAC |φ_dᴴ M φ|² / ((φ_dᴴ M φ_d)(φᴴ M φ)). The best
    (mode, root) pair is taken first, then the best of the rest, each root for as many
    modes as it repeats. Returns the roots' indices in ``damped.roots`` (−1: none left),
    the MACs (NaN: none), and the shapes (count, n), unit modal mass, in phase with the
    mode (φ_dᴴ M φ > 0; zero where none)."""
    factor = sp.csr_matrix(factor)
    count = len(undamped)
    roots, vectors = damped.roots, damped.vectors
    modes = np.asarray(factor.T @ undamped.T)  # Lᵀ φ, (m, count)
    shapes = np.asarray(factor.T @ vectors.T)  # Lᵀ φ_d, (m, roots)
    own = np.sum(np.abs(modes) ** 2, axis=0)
    clusters: list[list[int]] = []
    for j, root in enumerate(roots):
        if clusters and abs(root - roots[clusters[-1][-1]]) <= DEGENERATE * abs(root):
            clusters[-1].append(j)
        else:
            clusters.append([j])
    # the coefficients of each mode's projection on each cluster's shapes
    coefficients = [np.linalg.lstsq(shapes[:, c], modes.astype(complex), rcond=None)[0]
                    for c in clusters]
    mac = np.array([np.sum(np.abs(shapes[:, c] @ a) ** 2, axis=0) / own
                    for c, a in zip(clusters, coefficients, strict=True)]).reshape(
                        len(clusters), count)
    mac = np.where(np.isfinite(mac), mac, -1.0)
    index = np.full(count, -1)
    best = np.full(count, np.nan)
    out = np.zeros((count, vectors.shape[1]), dtype=complex)
    room = [len(c) for c in clusters]
    free = mac.copy()
    for _ in range(min(count, len(roots))):
        cluster, mode = np.unravel_index(int(np.argmax(free)), free.shape)
        if free[cluster, mode] < 0.0:
            break
        members = clusters[cluster]
        a = coefficients[cluster][:, mode]
        norm = float(np.linalg.norm(shapes[:, members] @ a))
        index[mode], best[mode] = members[0], mac[cluster, mode]
        out[mode] = vectors[members].T @ a / (norm if norm > 0.0 else 1.0)
        room[cluster] -= 1
        if room[cluster] == 0:
            free[cluster, :] = -1.0
        free[:, mode] = -1.0
    return index, best, out


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


def _laid_out(result: Result, model: Model, vectors: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """Modes on the free coordinates (count, n), unit modal mass, as node displacements and
    quaternion changes per rod (the archive's order), scaled to the scene's mass × 1 m²."""
    full = np.zeros((len(vectors), model.full_size), dtype=vectors.dtype)
    full[:, model.free] = vectors * np.sqrt(total_mass(model))
    shapes = np.concatenate([full[:, model.rods[name].layout.position_index]
                             for name in result.rods], axis=1)
    rotations = np.concatenate([full[:, model.rods[name].layout.quaternion_index]
                                for name in result.rods], axis=1)
    return shapes, rotations


def _modes_of(result: Result, model: Model, vibration: Vibration, rotary: bool,
              rotational_share: np.ndarray, damped: DampedVibration | None,
              matched: tuple[np.ndarray, np.ndarray, np.ndarray] | None) -> Modes:
    """The user's view of ``vibration`` (and of ``damped``, the damped roots, ``matched``
    their match to the modes, ``match_shapes``; None: no damping): frequencies in Hz,
    node displacements per rod."""
    omega = vibration.angular_frequencies
    frequencies = np.where(vibration.eigenvalues.real > 0.0, omega.real, np.nan) / (2 * np.pi)
    shapes, rotations = _laid_out(result, model, vibration.vectors)
    messages = []
    if np.any(vibration.eigenvalues.real <= 0.0):
        messages.append("unstable equilibrium: ω² ≤ 0 for a mode (no oscillation; a small "
                        "perturbation grows)")
    if not vibration.symmetric:
        messages.append("K is not symmetric (a non-conservative term: the paper's tendon "
                        "coupling, friction): ω² may be complex; shapes are the real parts")
    if damped is None or matched is None:
        roots = 1j * omega
        damped_frequencies = frequencies.copy()
        ratios = np.where(np.isnan(frequencies), np.nan, 0.0)
        mine, mac = roots, np.ones(len(roots))
        damped_shapes, damped_rotations = (shapes.astype(complex),
                                           rotations.astype(complex))
    else:
        index, mac, vectors = matched
        mine = np.where(index >= 0, damped.roots[np.maximum(index, 0)], np.nan + 0j)
        damped_shapes, damped_rotations = _laid_out(result, model, vectors)
        if np.any(index < 0):
            messages.append("fewer damped roots were found than modes: some modes have no "
                            "damped root (NaN)")
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
                 matched_eigenvalues=mine,
                 matched_damping_ratios=np.asarray(-mine.real / np.abs(mine) + 0.0),
                 shape_mac=mac, damped_shapes=damped_shapes,
                 damped_rotations=damped_rotations, vectors=vibration.vectors)


"""``rodsim.modes``: natural frequencies and mode shapes of a scene about its equilibrium.

    >>> import rodsim
    >>> modes = rodsim.modes("tdcr-two-segment", count=6)
    >>> modes.frequencies          # Hz, lowest first
    >>> modes.shapes[0]            # the first mode's displacement of every node (nodes, 3)

The equilibrium is solved first (``static`` by default), or taken from a solved
:class:`~rodsim.solvers.result.Result`; then K φ = ω² M φ is solved about it with the
physical masses (rodsim/core/inertia.py, rodsim/core/vibration.py; docs/dynamics.md).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from rodsim.app.api import SceneLike, load_scene, solve
from rodsim.core.inertia import mass_factor, total_mass
from rodsim.core.model import Model
from rodsim.core.stability import MAX_BAND
from rodsim.core.stability_band import BandStiffness
from rodsim.core.vibration import ModesError, Vibration, natural_modes
from rodsim.solvers.result import Result

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["Modes", "modes", "ModesError", "DEFAULT_COUNT"]

#: Modes computed when no count is given.
DEFAULT_COUNT = 6


@dataclass
class Modes:
    """The lowest natural modes of a scene about its equilibrium.

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
    #: The modes on the free coordinates (count, n), unit modal mass (φᴴ M φ = 1), for
    #: checks (K φ = ω² M φ).
    vectors: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)), repr=False)

    def to_xarray(self) -> xr.Dataset:
        """The modes archive: the run archive of the equilibrium with a ``mode`` dimension
        (docs/archive.md, "Modes archives")."""
        from rodsim.io.modes_dataset import modes_dataset

        return modes_dataset(self.result, frequencies=self.frequencies,
                             eigenvalues=self.eigenvalues, shapes=self.shapes,
                             rotations=self.rotations,
                             rotational_share=self.rotational_share,
                             rotary_inertia=self.rotary_inertia, message=self.message)


def modes(scene: SceneLike | Result | None = None, count: int = DEFAULT_COUNT, *,
          overrides: Iterable[str] = (), integrator: str = "static",
          rotary_inertia: bool = True) -> Modes:
    """The ``count`` lowest natural modes of ``scene`` about its equilibrium.

    ``scene``: a scene, path, shipped scene name or dict (its equilibrium is solved with
    ``integrator``, ``overrides`` applied first), or a solved
    :class:`~rodsim.solvers.result.Result` (its state is the equilibrium). ``rotary_inertia``
    False leaves the segments' rotary inertia out (the Euler–Bernoulli beam's inertia).
    A failed equilibrium gives ``success`` False; a bad ``count`` raises
    :class:`~rodsim.core.vibration.ModesError` (a ValueError), a bad scene
    :class:`~rodsim.core.schema.SceneError`.
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
    return _modes_of(result, model, vibration, rotary_inertia, np.clip(share, 0.0, 1.0))


def _solve(model: Model, x: np.ndarray, count: int, rotary: bool) -> Vibration:
    """The eigenproblem of ``model`` at ``x`` (band LU when the band is narrow enough)."""
    data = model.jacobian_data(x)
    band = model.band
    banded = (BandStiffness(model.pattern_rows, model.pattern_cols, model.n, band.lower,
                            band.upper) if band.lower + band.upper + 1 <= MAX_BAND else None)
    return natural_modes(-model.pattern_matrix(data), mass_factor(model, x, rotary), count,
                         band=banded, jacobian=data)


def _modes_of(result: Result, model: Model, vibration: Vibration, rotary: bool,
              rotational_share: np.ndarray) -> Modes:
    """The user's view of ``vibration``: frequencies in Hz, node displacements per rod."""
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
    return Modes(result, True, "; ".join(messages) or "ok",
                 frequencies=frequencies, eigenvalues=vibration.eigenvalues,
                 shapes=shapes.real, rotations=rotations.real,
                 growth=omega.imag / (2 * np.pi), rotational_share=rotational_share,
                 rotary_inertia=rotary,
                 symmetric=vibration.symmetric, vectors=vibration.vectors)


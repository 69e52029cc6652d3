"""The pseudo-dynamics CVODE and IDA integrate to equilibrium, as an explicit ODE y′ = f(y).

Only the equilibrium matters, so the dynamics are free to choose (docs/design.md §3); two are
offered and must reach the same equilibrium:

- ``inertial``: the damped second-order system of Eqs. (10)–(11),
  ẋ = v,  M v̇ = F(x) − c M v, with the state interleaved per coordinate, y = (x₀, v₀, x₁,
  v₁, …), so the Jacobian keeps the model's band structure (bandwidth 2b + 1).
- ``overdamped``: the first-order gradient flow c M ẋ = F(x) (no velocities, half the size).

The damping rate c [1/s] is 2 ζ ω₁, with ω₁ = 1.875² √(EI / (ρ A L⁴)) the first
Euler–Bernoulli bending frequency of the scene's first rod and ζ the ``damping_ratio``
option: ζ = 1 damps that mode critically.

The external loads are ramped in smoothly over ``load_ramp`` periods 2π/ω₁ (a smoothstep,
C¹). A load switched on at once excites the stiff stretch and penalty modes, and the
adaptive steps then stay tiny for hundreds of steps while those transients decay; with the
ramp the stiff components stay near their quasi-static values and the steps are limited by
the slow bending dynamics only (measured in docs/model.md, "Pseudo-dynamics").
"""

from __future__ import annotations

import numpy as np

from rodsim.core.model import Model
from rodsim.core.sparsity import csc_pattern

__all__ = ["FORMULATIONS", "first_mode_frequency", "damping_rate", "pseudo_masses",
           "LoadRamp", "FirstOrderSystem"]

FORMULATIONS = ("inertial", "overdamped")


def first_mode_frequency(model: Model) -> float:
    """ω₁ = 1.875² √(EI / (ρ A L⁴)) [rad/s] of the model's first rod."""
    rod = next(iter(model.rods.values()))
    return 1.875**2 * float(np.sqrt(rod.bending_stiffness
                                    / (rod.density * rod.area * rod.length**4)))


def damping_rate(model: Model, ratio: float) -> float:
    """c = 2 ζ ω₁ [1/s] (see the module docstring)."""
    return 2.0 * ratio * first_mode_frequency(model)


def pseudo_masses(model: Model, cap: float) -> np.ndarray:
    """Masses of the pseudo-dynamics: the physical ones, raised where needed so that no
    coordinate's own frequency √(K_ii / m_i) exceeds ``cap`` × ω₁ (mass scaling).

    Only the equilibrium matters, so the masses are free to choose. A tendon's points weigh
    ~1e-3 of the catheter's yet hang on the stiffest springs (K_C, K_L): with physical masses
    the coupled system spans 12 decades of frequency and BDF's Newton matrices lose every
    digit (docs/tendon.md). ``cap = 0`` keeps the physical masses.
    """
    masses = model.masses()
    if cap <= 0.0:
        return masses
    return np.maximum(masses, model.rest_stiffness / (cap * first_mode_frequency(model)) ** 2)


class LoadRamp:
    """Load factor λ(t) rising from 0 to 1 as a smoothstep over ``duration`` seconds."""

    def __init__(self, duration: float) -> None:
        self.duration = duration

    def __call__(self, t: float) -> float:
        if t >= self.duration:
            return 1.0
        u = max(t, 0.0) / self.duration
        return u * u * (3.0 - 2.0 * u)


class FirstOrderSystem:
    """y′ = f(y) for one formulation, with its analytic Jacobian in a fixed CSC pattern.

    Attributes
    ----------
    size
        Length of y.
    pattern
        CSC sparsity of ∂f/∂y (diagonal included).
    band
        (lower, upper) bandwidth of ``pattern``.
    """

    def __init__(self, model: Model, formulation: str, damping: float,
                 masses: np.ndarray) -> None:
        if formulation not in FORMULATIONS:
            raise ValueError(f"unknown formulation {formulation!r}")
        self.model = model
        self.formulation = formulation
        self.damping = damping
        self.inverse_mass = 1.0 / masses
        n = model.n
        rows, cols = model.pattern_rows, model.pattern_cols
        if formulation == "overdamped":
            self.size = n
            self._scale = self.inverse_mass / damping
            pattern = model.pattern.copy()
            self._data_from_model = np.arange(model.nnz)
            self._row_of_model = rows
            self.pattern = pattern
            self._constant = np.zeros(0, dtype=int), np.zeros(0)
        else:
            self.size = 2 * n
            # K block: rows 2i + 1, cols 2j; dẋ/dv = I: (2i, 2i + 1); dv̇/dv = −c: (2i+1, 2i+1);
            # the (zero) diagonal of the x rows keeps the diagonal in the pattern.
            i = np.arange(n)
            all_rows = np.concatenate([2 * rows + 1, 2 * i, 2 * i + 1, 2 * i])
            all_cols = np.concatenate([2 * cols, 2 * i + 1, 2 * i + 1, 2 * i])
            pattern = csc_pattern(all_rows, all_cols, self.size)
            self.pattern = pattern.matrix
            inverse = pattern.target
            nnz = model.nnz
            self._data_from_model = inverse[:nnz]
            self._row_of_model = rows
            self._scale = self.inverse_mass
            const_index = inverse[nnz:nnz + 2 * n]
            const_value = np.concatenate([np.ones(n), np.full(n, -damping)])
            self._constant = const_index, const_value
        coo = self.pattern.tocoo()
        offsets = coo.row - coo.col
        self.band = (int(max(offsets.max(), 0)), int(max(-offsets.min(), 0)))
        self.pattern_rows, self.pattern_cols = coo.row, coo.col  # CSC order (canonical)

    def initial_state(self, x0: np.ndarray | None = None) -> np.ndarray:
        """The state ``x0`` (default: the rest state; or a warm start), at rest."""
        x0 = self.model.x0 if x0 is None else x0
        if self.formulation == "overdamped":
            return x0
        y = np.zeros(self.size)
        y[0::2] = x0
        return y

    def positions_of(self, y: np.ndarray) -> np.ndarray:
        """The model coordinates x inside y."""
        return y if self.formulation == "overdamped" else y[0::2]

    def rhs(self, y: np.ndarray, force: np.ndarray, out: np.ndarray) -> None:
        """Write f(y) into ``out`` given F(x) for the x inside y."""
        if self.formulation == "overdamped":
            out[:] = self._scale * force
        else:
            v = y[1::2]
            out[0::2] = v
            out[1::2] = self._scale * force - self.damping * v

    def jacobian_data(self, model_jacobian: np.ndarray) -> np.ndarray:
        """∂f/∂y in the CSC order of :attr:`pattern`, from ∂F/∂x in the model's order."""
        data = np.zeros(self.pattern.nnz)
        index, value = self._constant
        data[index] = value
        data[self._data_from_model] = model_jacobian * self._scale[self._row_of_model]
        return data

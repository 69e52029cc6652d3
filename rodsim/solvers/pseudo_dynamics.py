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

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.core.model import Model
from rodsim.core.schema import Options, Parameter, declared_parameters, option
from rodsim.core.sparsity import csc_pattern

__all__ = ["FORMULATIONS", "first_mode_frequency", "damping_rate", "pseudo_masses",
           "LoadRamp", "FirstOrderSystem", "ConstrainedSystem", "PseudoDynamics",
           "PSEUDO_DYNAMICS_PARAMETERS", "PseudoDynamicsOptions", "BAND_LIMIT", "LINEAR_SOLVERS",
           "LARGE_FINISH_ITERATIONS"]

FORMULATIONS = ("inertial", "overdamped")

#: Above this many unknowns the band solver's dense (n × n) Jacobian template costs too much
#: memory (scikit-sundae hands band Jacobians to Python as a full array); ``linear_solver =
#: "auto"`` then switches to ``band_gmres``: SUNDIALS' GMRES preconditioned by rodsim's own
#: band LU of the same Newton matrix (:class:`BandPreconditioner`), which holds only the band.
BAND_LIMIT = 4000
#: Newton iterations a finish may take on a large model (above ``LARGE_MODEL_SIZE`` free
#: coordinates, rodsim/solvers/base.py) whatever ``newton_iterations`` says. There the
#: max-norm residual falls below ``newton_switch`` while the rod is still near rest (an
#: imbalance spread over N nodes reads 1/N of itself): the finish is then Newton from near rest,
#: which converges (the energy line search) but may need more than 20 iterations, and a failed
#: finish sends the run back to integrating, where a step costs several Newton iterations.
#: Measured on table1-50g at N = 100 000: the first finish, after 7 steps, converged in 34
#: iterations (CVODE 27 s in all); with 20 it failed, and CVODE took 244 steps, a tightening
#: and a second finish (547 s).
LARGE_FINISH_ITERATIONS = 60
#: The linear solvers of CVODE and IDA (``linear_solver``; "auto" picks one by size).
LINEAR_SOLVERS = ("auto", "band", "band_gmres", "sparse")

@dataclass(frozen=True, kw_only=True)
class PseudoDynamicsOptions(Options):
    """The options CVODE and IDA share: pseudo-dynamics, tolerances, linear solver and the
    Newton finish (rodsim/solvers/sundials.py), each declared once by its field
    (``rodsim.core.schema.option``: ``PSEUDO_DYNAMICS_PARAMETERS`` is made from them)."""

    formulation: str = option(
        "overdamped", "-",
        "'inertial' (damped second order, Eqs. 10–11) or 'overdamped' (gradient flow)",
        choices=FORMULATIONS)
    damping_ratio: float = option(
        1.0, "-", "ζ: damping rate c = 2 ζ ω₁ of the first bending mode", 0.0, 1e6,
        exclusive_minimum=True)
    mass_scaling: float = option(
        1e3, "-", "raise masses so no coordinate's own frequency exceeds this × ω₁ (0: "
        "physical masses)", 0.0, 1e12)
    load_ramp: float = option(
        1.0, "-", "ramp the loads in over this many first-mode periods 2π/ω₁ (0: step load)",
        0.0, 1e6)
    rtol: float = option(1e-4, "-", "relative tolerance of the time stepping", 1e-15, 1e-1)
    atol: float = option(
        1e-4, "-", "absolute tolerance, relative to each variable's scale (L for positions, 1 "
        "for quaternions, L ω₁ for velocities)", 1e-20, 1e-1)
    linear_solver: str = option(
        "auto", "-", "'band', 'band_gmres' (GMRES with the exact band LU as preconditioner: "
        "band storage only), 'sparse' (SuperLU_MT) or 'auto' (band up to "
        f"{BAND_LIMIT} unknowns, band_gmres above)", choices=LINEAR_SOLVERS)
    max_steps: int = option(200_000, "-", "give up after this many steps", 1, 100_000_000)
    newton_switch: float = option(
        0.1, "-", "finish with Newton on F(x) = 0 once the scaled residual is below this (0: "
        "integrate all the way to the tolerance)", 0.0, 1.0)
    newton_iterations: int = option(
        20, "-", "Newton iterations of one finishing attempt (a failed attempt goes back to "
        f"integrating; at least {LARGE_FINISH_ITERATIONS} above 4000 unknowns)", 1, 10_000)


#: Options CVODE and IDA share (pseudo-dynamics and tolerances), made from
#: ``PseudoDynamicsOptions``.
PSEUDO_DYNAMICS_PARAMETERS: tuple[Parameter, ...] = declared_parameters(PseudoDynamicsOptions)


@dataclass(frozen=True)
class PseudoDynamics:
    """The pseudo-dynamics' constants of one run, from its model and options (shared by
    CVODE, IDA and scipy): ω₁, the first-mode period 2π/ω₁ (the pseudo-time unit of the
    ramp and the run's tests), the damping rate c, the pseudo-masses, the load ramp (none
    for a warm start: the loads in full at once) and the horizon (10⁹ periods) at which a
    run gives up."""

    omega: float
    period: float
    rate: float
    masses: np.ndarray
    ramp: LoadRamp
    horizon: float

    @classmethod
    def of(cls, model: Model, options: Any, warm: bool) -> PseudoDynamics:
        """From ``model`` and options carrying ``damping_ratio``, ``mass_scaling`` and
        ``load_ramp`` (``PSEUDO_DYNAMICS_PARAMETERS``)."""
        omega = first_mode_frequency(model)
        period = 2.0 * math.pi / omega
        return cls(omega=omega, period=period, rate=damping_rate(model, options.damping_ratio),
                   masses=pseudo_masses(model, options.mass_scaling),
                   ramp=LoadRamp(0.0 if warm else options.load_ramp * period),
                   horizon=1e9 * period)


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

    K_ii is the rest stiffness plus the stiffness a coordinate may meet later
    (``Model.latent_stiffness``: a contact's k on every node it may touch). At rest no
    node touches, so the rest stiffness alone left a touching node's frequency up to
    √(1 + k/K_ii) times the cap, and CVODE then crept through thousands of steps: measured
    (docs/contact.md, "Pseudo-dynamics on contact") tip-on-tissue 27 554 → 8 303 steps, the
    tests' inclined plane at N = 40 6 490 → 1 887, and a frictional drag that failed now
    converges.
    """
    masses = model.pseudo_time_masses()
    if cap <= 0.0:
        return masses
    stiffness = model.rest_stiffness + model.latent_stiffness()
    return np.maximum(masses, stiffness / (cap * first_mode_frequency(model)) ** 2)


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
        """∂f/∂y in the CSC order of ``pattern``, from ∂F/∂x in the model's order."""
        if self.formulation == "overdamped":  # the model's pattern and order, no constants
            return model_jacobian * self._scale[self._row_of_model]
        data = np.zeros(self.pattern.nnz)
        index, value = self._constant
        data[index] = value
        data[self._data_from_model] = model_jacobian * self._scale[self._row_of_model]
        return data


class ConstrainedSystem:
    """Index maps, residual and analytic Jacobian of IDA's constrained residual form."""

    def __init__(self, model: Model, formulation: str, damping: float, baumgarte: float,
                 masses: np.ndarray) -> None:
        self.model = model
        self.inertial = formulation == "inertial"
        self.c, self.beta = damping, baumgarte
        self.mass = masses
        n = model.n
        free_of = np.full(model.full_size, -1)
        free_of[model.free] = np.arange(n)
        groups: list[np.ndarray] = []
        for rod in model.rods.values():
            index = free_of[rod.layout.quaternion_index]
            groups.extend(row for row in index if np.all(row >= 0))
        self.quat = np.asarray(groups, dtype=np.int64).reshape(-1, 4)  # model coords of each q_j
        # The free coordinates are offsets from the rest state (Model.x0): q_j = q⁰_j + δ_j.
        self.rest_quat = model.reference[model.free][self.quat]
        self._rest_norm = np.sum(self.rest_quat * self.rest_quat, axis=1) - 1.0
        # Slot of every variable in y: per model coordinate 1 (or 2 with velocity) slots,
        # and one multiplier after the last coordinate of each quaternion.
        per = 2 if self.inertial else 1
        after = np.zeros(n, dtype=int)
        after[self.quat[:, 3]] = 1
        start = np.concatenate([[0], np.cumsum(per + after)[:-1]])
        self.x_slot = start
        self.v_slot: np.ndarray | None = start + 1 if self.inertial else None
        self.mu_slot = start[self.quat[:, 3]] + per
        self.size = n * per + len(self.quat)
        self.algebraic = self.mu_slot
        self._build_pattern()

    def _build_pattern(self) -> None:
        model, q = self.model, self.quat.ravel()
        force_row = self.force_rows()
        mu = np.repeat(self.mu_slot, 4)
        slots = np.arange(self.size)
        blocks = {
            "K": (force_row[model.pattern_rows], self.x_slot[model.pattern_cols]),
            "diag": (slots, slots),
            "mu_col": (force_row[q], mu),
            "mu_row_x": (mu, self.x_slot[q]),
        }
        if self.v_slot is not None:
            blocks["mu_row_v"] = (mu, self.v_slot[q])
            blocks["xv"] = (self.x_slot, self.v_slot)
        pattern = csc_pattern(np.concatenate([r for r, _ in blocks.values()]),
                              np.concatenate([c for _, c in blocks.values()]), self.size)
        self.pattern, self.rows, self.cols = pattern.matrix, pattern.rows, pattern.cols
        bounds = np.cumsum([0, *(len(r) for r, _ in blocks.values())])
        #: For each block, where its entries land in the CSC data (unique within a block).
        self._target = {name: pattern.target[bounds[k]:bounds[k + 1]]
                        for k, name in enumerate(blocks)}
        diagonal = np.flatnonzero(model.pattern_rows == model.pattern_cols)
        self._quat_diagonal = diagonal[np.isin(model.pattern_rows[diagonal], q)]
        self._quat_order = np.argsort(q)  # _quat_diagonal runs over ascending coordinates
        self.band = pattern.band

    def force_rows(self) -> np.ndarray:
        """The slots of the force rows: the velocities' (inertial) or the positions'."""
        return self.v_slot if self.v_slot is not None else self.x_slot

    def quaternions(self, x: np.ndarray) -> np.ndarray:
        """The free quaternions q_j (j, 4) of the model state ``x`` (offsets δ_j from the
        rest quaternions q⁰_j)."""
        return self.rest_quat + x[self.quat]

    def norm_error(self, x: np.ndarray) -> np.ndarray:
        """|q_j|² − 1 of the model state ``x``, formed from the offsets without
        cancellation: δ·(2q⁰ + δ) + (|q⁰|² − 1)."""
        delta = x[self.quat]
        return (np.sum(delta * (2.0 * self.rest_quat + delta), axis=1)
                + self._rest_norm)

    def constrained_force(self, y: np.ndarray, force: np.ndarray) -> np.ndarray:
        """F(x) + Gᵀμ: the force whose vanishing is IDA's (constrained) equilibrium."""
        total = force.copy()
        total[self.quat] += 2.0 * y[self.mu_slot][:, None] * self.quaternions(y[self.x_slot])
        return total

    def initial_state(self, x0: np.ndarray | None = None) -> np.ndarray:
        """The state ``x0`` (default: the rest state; or a warm start), at rest, μ = 0."""
        y = np.zeros(self.size)
        y[self.x_slot] = self.model.x0 if x0 is None else x0
        return y

    def positions_of(self, y: np.ndarray) -> np.ndarray:
        return y[self.x_slot]

    def dae_residual(self, y: np.ndarray, yp: np.ndarray, force: np.ndarray,
                     out: np.ndarray) -> None:
        """The DAE residual R(t, y, y′) (IDA's) into ``out`` given F(x)."""
        q = self.quat
        qv = self.quaternions(y[self.x_slot])
        total = self.constrained_force(y, force)
        g = self.norm_error(y[self.x_slot])
        if self.inertial:
            v, vdot = y[self.v_slot], yp[self.v_slot]
            vq = v[q]
            out[self.x_slot] = yp[self.x_slot] - v
            out[self.v_slot] = self.mass * (vdot + self.c * v) - total
            out[self.mu_slot] = (2.0 * np.sum(qv * vdot[q], axis=1)
                                 + 2.0 * np.sum(vq * vq, axis=1)
                                 + 4.0 * self.beta * np.sum(qv * vq, axis=1)
                                 + self.beta**2 * g)
        else:
            xdot = yp[self.x_slot]
            out[self.x_slot] = self.c * self.mass * xdot - total
            out[self.mu_slot] = 2.0 * np.sum(qv * xdot[q], axis=1) + self.beta * g

    def jacobian_data(self, y: np.ndarray, yp: np.ndarray, cj: float,
                      model_jacobian: np.ndarray) -> np.ndarray:
        """dR/dy + cj dR/dy′ in the CSC order of ``pattern``."""
        q, t = self.quat, self._target
        x, mu = y[self.x_slot], y[self.mu_slot]
        qv = self.quaternions(x)
        stiffness = model_jacobian.copy()  # ∂(F + 2μq)/∂x = K + 2μ I on quaternion coords
        stiffness[self._quat_diagonal] += np.repeat(2.0 * mu, 4)[self._quat_order]
        data = np.zeros(self.pattern.nnz)
        data[t["K"]] -= stiffness
        diag = np.zeros(self.size)
        if self.inertial:
            v, vdot = y[self.v_slot], yp[self.v_slot]
            vq = v[q]
            diag[self.x_slot] = cj
            diag[self.v_slot] = self.mass * (self.c + cj)
            data[t["xv"]] -= 1.0
            data[t["mu_row_x"]] += (2.0 * vdot[q] + 4.0 * self.beta * vq
                                    + 2.0 * self.beta**2 * qv).ravel()
            data[t["mu_row_v"]] += (4.0 * vq + (4.0 * self.beta + 2.0 * cj) * qv).ravel()
        else:
            diag[self.x_slot] = self.c * self.mass * cj
            data[t["mu_row_x"]] += (2.0 * yp[self.x_slot][q]
                                    + (2.0 * self.beta + 2.0 * cj) * qv).ravel()
        data[t["diag"]] += diag
        data[t["mu_col"]] -= 2.0 * qv.ravel()
        return data

"""What a fixed step of physical time is, for the integrators that take one (the implicit
midpoint rule, rodsim/solvers/physical/midpoint.py; the paper's semi-implicit Euler,
rodsim/solvers/physical/semi_implicit_euler.py): the motion it starts from and reaches,
its outcome, its failure, and the Newton iteration both solve on the node positions at
the step's end r₁ and a body rate per segment (docs/dynamics.md).

The Newton iteration: the Newton matrix is factored (SuperLU) at the first iterate and kept
while each iteration shrinks the change tenfold (a simplified Newton; a fresh matrix
otherwise), to the tolerance ``NEWTON_TOLERANCE`` on the change — of any node over the
longest rod's length, of any segment's angle over the step. A stepper that passes a
``KeptMatrix`` (the midpoint rule) also keeps the last factored matrix across steps of the
same length: the next step starts from it instead of a fresh one at its first iterate
(modified Newton; the same refresh rule, no clock), and a step whose Newton fails with it
starts again with a fresh one. On tdcr-two-segment under a tension ramp (N = 61, 2 ms
steps) that took 5.9 instead of 7.0 iterations a step and 0.81 of the CPU, the tip within
1.7e-14 L of the fresh-matrix run (the Newton tolerance's level).

Two rules read the iteration's contraction θ (a change over the one before): it also stops
when the rest of a linear contraction at the slowest θ seen in the step, θ/(1 − θ) times
the change, is below the tolerance (after two contractions: the first, from the predictor,
is the fast modes' and far quicker than the rest); and a slow matrix (θ above ``REFRESH``)
is kept when at its θ that stop is at most ``KEEP_ITERATIONS`` iterations away, about what
a fresh matrix costs. On tdcr-two-segment (0.1 s of step-cost's ramp at 1/3 ms steps):
1 689 → 1 592 iterations and 147 → 111 factorisations, the positions within 1.4e-12 L of
the run before. With ``KEEP_ITERATIONS`` 8 instead of 4 (round 18: a fresh matrix now costs
about nine iterations, not three), 0.2 s of that run: 3 051 → 3 482 iterations and
213 → 127 factorisations.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import scipy.sparse as sp

from rodsim.core.damping import Damping
from rodsim.core.model import Model
from rodsim.solvers.physical.band_lu import factor as factor_matrix
from rodsim.solvers.physical.coordinates import (
    PhysicalCoordinates,
    gyroscopic_jacobian,
    placed_arrays,
)
from rodsim.solvers.physical.sparse_kernels import (
    INDEX,
    Csr,
    arrays,
    csr_of,
    minus,
    plus,
    product,
)

__all__ = ["Motion", "StepOutcome", "StepFailure", "FixedStep", "solve_step",
           "newton_matrix", "KeptMatrix",
           "NEWTON_TOLERANCE", "MAX_ITERATIONS"]

#: Newton stops when its step moves no node by more than this times the longest rod and no
#: segment by more than this angle [rad] over the time step.
NEWTON_TOLERANCE = 1e-12
#: A change this small that is no longer half the smallest so far is the round-off floor
#: of the forces (the stiff terms' internal forces cancel): converged.
ROUNDOFF = 1e-9
#: A Newton iteration that shrinks the change by less than this factor takes a fresh
#: Jacobian for the next, unless the matrix in use is due to converge within
#: ``KEEP_ITERATIONS`` more.
REFRESH = 0.1
#: A slow Newton matrix (contraction θ above ``REFRESH``, below 1) is kept when, at θ, the
#: stop below is this many iterations away or fewer: a fresh matrix costs about as much (on
#: tdcr-two-segment, N = 61, since the midpoint step's compiled kernels and stiffness plan:
#: the Jacobian at both Gauss points, its map to the step's unknowns and the
#: factorisation, 1.6 ms with SuperLU's and about 1.3 ms with the band LU's
#: (rodsim/solvers/physical/band_lu.py) against 0.17 ms for an iteration with a kept
#: matrix, eight or nine; three before them, when this was 4). A nominal count: no clock.
KEEP_ITERATIONS = 8.0
#: A Newton change this large (a tenth of the rod's length, or of a radian) is divergence.
DIVERGED = 0.1
#: Newton iterations allowed per time step.
MAX_ITERATIONS = 25
#: A kept Newton matrix serves a step whose length is within this (relative) of its own.
KEPT_STEP = 1e-9


class StepFailure(RuntimeError):
    """A time step could not be taken (Newton did not converge, or a value is not finite)."""


@dataclass(frozen=True)
class Motion:
    """A state of motion: free coordinates ``x``, node velocities ``v`` (p,) [m/s] and body
    rates ``w`` (s, 3) [rad/s]; ``middle``: the midpoint velocities (v_m, ω_m) of the
    midpoint step that reached it (None at the start and after other steps), the next
    midpoint step's predictor.

    The predictor: a mode the step cannot resolve (ωh ≫ 1: stretch, shear, twist, and
    the overdamped modes of Kelvin–Voigt damping) reverses its velocity every step under
    the midpoint rule, which is not L-stable, so v₁ ≈ −v₀ there and v_m ≈ 0; the last
    step's v_m predicts that and the resolved modes alike (to O(h)). Predicting v₀ instead
    put Newton's start a whole reversal away and made it diverge on a damped steel rod.
    """

    x: np.ndarray
    v: np.ndarray
    w: np.ndarray
    middle: tuple[np.ndarray, np.ndarray] | None = None


@dataclass(frozen=True)
class StepOutcome:
    """The motion a step reached, the energy its damping dissipated [J], its Newton
    iterations and the work a moving support did through the damping [J]
    (rodsim/solvers/physical/moving_supports.py; 0 where no support moves)."""

    motion: Motion
    dissipated: float
    iterations: int
    support_work: float = 0.0


class FixedStep(Protocol):
    """A fixed step of one model's motion (the run, rodsim/solvers/physical/trajectory.py,
    takes any)."""

    coordinates: PhysicalCoordinates
    damping: Damping

    def step(self, model: Model, start: Motion, h: float, t: float = 0.0) -> StepOutcome:
        """One step of length ``h`` [s] from ``start`` with ``model``'s forces, ``t`` the
        step's midpoint time [s] (where a support moves); StepFailure when it cannot be
        taken."""
        ...


#: ``evaluate(r₁, w, fresh)``: the residual at the iterate and, when ``fresh``, the
#: Newton matrix there (None otherwise).
Evaluate = Callable[[np.ndarray, np.ndarray, bool], tuple[np.ndarray, "sp.spmatrix | None"]]


@dataclass
class KeptMatrix:
    """The last factored Newton matrix of a run's steps, for the next step (a modified
    Newton across steps): the step length it was built for [s] and its solve."""

    h: float = float("nan")
    solve: Callable[[np.ndarray], np.ndarray] | None = None

    def fits(self, h: float) -> bool:
        """Whether it was built for a step of length ``h`` (to 1e-9 relative: a run's equal
        steps differ in their last bits)."""
        return self.solve is not None and abs(self.h - h) <= KEPT_STEP * h


def solve_step(evaluate: Evaluate, r1: np.ndarray, w: np.ndarray, h: float,
               length_scale: float, tolerance: float, kept: KeptMatrix | None = None,
               order: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Newton from (``r1``, ``w``) — node positions (p,) and body rates (s, 3) — on
    ``evaluate``'s residual (module docstring): (r₁, w, iterations); StepFailure when it
    diverges, does not converge or meets a value that is not finite. With ``kept``: the
    Newton matrix of an earlier step of the same length starts the iteration (refreshed by
    the same rule as within a step); if the iteration fails with it, the step's Newton
    starts again from (``r1``, ``w``) with a fresh matrix (its iterations counted too).
    Every fresh matrix factored is kept for the next step. ``order``: the unknowns' band
    order, in which a narrow-banded matrix is factored as a band
    (rodsim/solvers/physical/band_lu.py; None: SuperLU)."""
    counted = [0]
    if kept is not None and kept.fits(h):
        try:
            r, v = _newton(evaluate, r1, w, h, length_scale, tolerance, kept, kept.solve,
                           counted, order)
            return r, v, counted[0]
        except StepFailure:
            pass
    r, v = _newton(evaluate, r1, w, h, length_scale, tolerance, kept, None, counted, order)
    return r, v, counted[0]


def _newton(evaluate: Evaluate, r1: np.ndarray, w: np.ndarray, h: float,
            length_scale: float, tolerance: float, kept: KeptMatrix | None,
            solve: Callable[[np.ndarray], np.ndarray] | None, counted: list[int],
            order: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``solve_step``'s iteration from the factored matrix ``solve`` (None: a fresh one at
    the first iterate); ``counted[0]`` counts its iterations."""
    p = len(r1)
    previous = moved = best = np.inf
    fresh = solve is None  # whether the matrix in use was factored in this step
    slowest = 0.0  # the largest contraction θ = change / previous change after the first
    contractions = 0
    for _ in range(MAX_ITERATIONS):
        counted[0] += 1
        residual, matrix = evaluate(r1, w, solve is None)
        if matrix is not None:  # a fresh Newton matrix, kept while it converges fast
            try:
                solve = factor_matrix(matrix, order)
            except RuntimeError as exc:
                raise StepFailure(f"the Newton matrix is singular ({exc})") from None
            if kept is not None:
                kept.h, kept.solve = h, solve
            fresh = True
        assert solve is not None
        delta = solve(-residual)
        if not np.isfinite(delta).all():
            raise StepFailure("the Newton step is not finite (a singular Newton matrix)")
        r1 = r1 + delta[:p]
        w = w + delta[p:].reshape(-1, 3)
        moved = max(float(np.abs(delta[:p]).max(initial=0.0)) / length_scale,
                    h * float(np.abs(delta[p:]).max(initial=0.0)))
        if moved > DIVERGED:
            raise StepFailure(f"Newton diverges (a change of {moved:.1e})")
        if moved <= tolerance or (fresh and moved <= ROUNDOFF and moved > 0.5 * best):
            break  # converged, or at the round-off floor of the forces (slow progress
            # with an earlier step's matrix is that matrix's staleness: refreshed below)
        if previous < np.inf:
            contractions += 1
            slowest = max(slowest, moved / previous)
            if contractions >= 2 and slowest < 1.0 and _tail(slowest, moved) <= tolerance:
                break  # what is left of a linear contraction is below the tolerance
        best = min(best, moved)
        if moved > REFRESH * previous and not _keep(moved / previous, moved, tolerance):
            solve = None  # slow: a fresh Jacobian at the next iterate
        previous = moved
    else:
        raise StepFailure(f"Newton did not converge in {MAX_ITERATIONS} iterations "
                          f"(last change {moved:.1e})")
    return r1, w


def _tail(theta: float, moved: float) -> float:
    """The distance left to the solution after a change ``moved`` of an iteration that
    contracts by ``theta`` < 1 each step: the geometric series θ/(1 − θ) × moved."""
    return theta / (1.0 - theta) * moved


def _keep(theta: float, moved: float, tolerance: float) -> bool:
    """Whether a matrix contracting by ``theta`` (above ``REFRESH``) is kept: below 1, with
    the stop (``_tail`` ≤ ``tolerance``) at most ``KEEP_ITERATIONS`` iterations away."""
    if theta >= 1.0:
        return False
    return math.log(tolerance / _tail(theta, moved)) / math.log(theta) <= KEEP_ITERATIONS


def newton_matrix(coordinates: PhysicalCoordinates, factor: float,
                  stiffness: Csr | sp.csr_matrix,
                  damping: sp.csr_matrix | None, w: np.ndarray, h: float) -> sp.csr_matrix:
    """∂(residual)/∂(r₁, w) of a step whose residual is ``factor`` (2 for the midpoint rule,
    1 for Euler) times (M_r (v − v₀)/h, I (w − ω₀)/h) plus w × I w, minus the force, plus
    the damping: the masses (factor/h²) M_r and (factor/h) I, the gyroscopic term at
    ``w``, minus the force's derivative ``stiffness`` with respect to (r₁, w), plus the
    (held) damping D_t times ∂u/∂(r₁, w) (1/h on the positions: u = (r₁ − r₀)/h)."""
    c = coordinates
    p = len(c.positions)
    inertia = c.inertia
    gyro = gyroscopic_jacobian(inertia, w)
    rotation = (factor / h) * np.eye(3)[None] * inertia[:, :, None] + gyro
    # sp.block_diag([(factor/h²) M_r, the rotation blocks]) as one placement
    rows, cols = c.mass_entries
    m = c.size
    masses = placed_arrays(np.concatenate([(factor / h**2) * c.mass.data, rotation.ravel()]),
                           rows, cols, (m, m))
    # masses − stiffness (+ damping @ sp.diags(scale)): scipy's own operators' arrays, by
    # its kernels (sparse_kernels; the diagonal's CSR is its scale, no entry of it zero)
    matrix = minus(m, m, arrays(masses), arrays(stiffness))
    if damping is not None:
        scale = np.concatenate([np.full(p, 1.0 / h), np.ones(3 * len(c.quaternions))])
        diagonal = Csr(np.arange(m + 1, dtype=INDEX), np.arange(m, dtype=INDEX), scale)
        matrix = plus(m, m, matrix, product(m, m, arrays(damping), diagonal))
    return csr_of(matrix, (m, m))

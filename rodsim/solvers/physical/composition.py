"""A fourth-order step of physical time composed of implicit midpoint steps (integrator
``"midpoint4"``, docs/dynamics.md, "Fourth order by composition").

The implicit midpoint step (rodsim/solvers/physical/midpoint.py) is symmetric: a step of −h
undoes a step of h. A symmetric second-order step Φ_h composed as

    Ψ_h = Φ_{γ₅h} ∘ Φ_{γ₄h} ∘ Φ_{γ₃h} ∘ Φ_{γ₂h} ∘ Φ_{γ₁h},
    γ₁ = γ₂ = γ₄ = γ₅ = 1/(4 − 4^{1/3}) ≈ 0.4145,   γ₃ = 1 − 4γ₁ ≈ −0.6580,

is symmetric and of order four (Suzuki 1990; Hairer, Lubich & Wanner, Geometric Numerical
Integration, 2nd ed., Sect. II.4, Eq. (4.5)): Σγ = 1 and Σγ³ = 0 cancel the h³ term of the
local error, and symmetry the h⁴ term. Each part is a whole midpoint step — its
force averaged along the path, its Cayley rotation, its damping at its own midpoint, the
programs' values at its own midpoint time (γ₃'s step runs backwards in time, inside the
step's interval) — so the composed step keeps what the midpoint step keeps exactly: |q| = 1
and, undamped, no drift of the energy error. Its five parts are of two lengths; each length
keeps its own factored Newton matrix across steps (``KeptMatrix``). The backward part's is
never reused (``KeptMatrix.fits`` compares with a positive length): tried, it failed its
first iterations about as often as not on tdcr-two-segment (0.3 s of the real-time ramp at
2.5 ms steps: 133 fresh matrices in 120 backward parts, and 3 815 iterations against 3 515
without the attempt). The forward parts refresh theirs about every other part there (246
fresh matrices in 480 parts, against the midpoint rule's 0.2 a step at 1/3 ms steps): a
part is 1 ms long, and the Newton matrix's stiffness changes more over it.

Suzuki's five-part composition, not the three-part "triple jump" (γ = 1.351, −1.702, 1.351):
its error constant is far smaller. On tdcr-two-segment (docs/benchmarks.md, the real-time
run, 1 s) at the same number of midpoint solves a second the triple jump's tip error was 3
to 4 times Suzuki's (3.8e-4 L at 1 800 solves against 1.5e-4 L at 1 500).
"""

from __future__ import annotations

from collections.abc import Callable

from rodsim.core.damping import Damping
from rodsim.core.model import Model
from rodsim.solvers.physical.coordinates import PhysicalCoordinates
from rodsim.solvers.physical.fixed_step import KeptMatrix, Motion, StepOutcome
from rodsim.solvers.physical.midpoint import MidpointStep

__all__ = ["ComposedStep", "SUZUKI"]

_OUTER = 1.0 / (4.0 - 4.0 ** (1.0 / 3.0))
#: Suzuki's fractions of the step (module docstring): symmetric, summing to 1.
SUZUKI = (_OUTER, _OUTER, 1.0 - 4.0 * _OUTER, _OUTER, _OUTER)


class ComposedStep:
    """A step of ``inner`` midpoint steps of the fractions ``fractions`` of its length
    (module docstring), each with the model of its own midpoint time (``model_at``)."""

    def __init__(self, inner: MidpointStep, model_at: Callable[[float], Model],
                 fractions: tuple[float, ...] = SUZUKI) -> None:
        self.inner = inner
        self.model_at = model_at
        self.fractions = fractions
        self.coordinates: PhysicalCoordinates = inner.coordinates
        self.damping: Damping = inner.damping
        #: One kept Newton matrix per part length (the fraction's value).
        self._kept: dict[float, KeptMatrix] = {}

    @property
    def parts(self) -> int:
        """Midpoint steps per step."""
        return len(self.fractions)

    def step(self, model: Model, start: Motion, h: float, t: float = 0.0) -> StepOutcome:
        """One step of length ``h`` [s] whose midpoint time is ``t`` [s] (``model``, the
        model of that time, is not used: each part takes its own); StepFailure when a
        part's Newton does not converge."""
        del model
        begin = t - 0.5 * h
        done = dissipated = work = 0.0
        iterations = 0
        motion = start
        for fraction in self.fractions:
            self.inner.kept = self._kept.setdefault(fraction, KeptMatrix())
            middle = begin + (done + 0.5 * fraction) * h
            outcome = self.inner.step(self.model_at(middle), motion, fraction * h, middle)
            motion = outcome.motion
            dissipated += outcome.dissipated
            work += outcome.support_work
            iterations += outcome.iterations
            done += fraction
        return StepOutcome(motion, dissipated, iterations, work)

"""The tolerance rules every integrator and every warm solve share, in one place.

- The effective tolerance: the requested ``solver.tolerance`` raised to the model's round-off
  floor (``Model.residual_floor``): no solver can resolve a residual below it.
- The floor refusal: a model whose floor exceeds ``MAX_RESIDUAL_FLOOR`` cannot tell any
  equilibrium from its rest state in double precision, and is refused with a diagnostic
  rather than accepted as "converged".
- The correction tolerance of the result check (``CORRECTION_TOLERANCE``).
"""

from __future__ import annotations

from rodsim.core.model import Model
from rodsim.solvers.failure import SolverFailure

__all__ = ["MAX_RESIDUAL_FLOOR", "CORRECTION_TOLERANCE", "FLOOR_ADVICE", "correction_limit",
           "effective_tolerance", "refuse_unresolvable", "unresolvable_message"]

#: A model whose residual floor (round-off of the internal forces relative to the loads)
#: exceeds this cannot resolve its equilibrium: every integrator refuses it with a diagnostic
#: rather than accept the rest state as "converged".
MAX_RESIDUAL_FLOOR = 1e-3

#: Largest correction residual (:func:`rodsim.solvers.base.correction_residual`: the distance
#: to the equilibrium over the load's displacement) a result may have, unless the tolerance is
#: looser. Measured on the suite's honest runs (tests/test_integrators.py,
#: test_tendon_integrators.py): at most 3.1e-6 (paper at N = 1000), Newton-finished runs ~1e-9
#: and below; IDA's wrong success on table1-50g at N = 40 000 (1.4 % L from static's, force
#: residual 4.7e-6 under its tolerance 1.2e-5): 0.048.
CORRECTION_TOLERANCE = 1e-5


#: What to change when the floor exceeds ``MAX_RESIDUAL_FLOOR``.
FLOOR_ADVICE = "lower K_P, N or the stretch stiffness, or raise the load"


def correction_limit(model: Model, tolerance: float) -> float:
    """The largest correction residual a result on ``model`` may have, at the effective
    ``tolerance``: the tolerance, or ``CORRECTION_TOLERANCE`` if larger; but
    ``CORRECTION_TOLERANCE`` alone above ``MAX_RESIDUAL_FLOOR``, where the force residual
    cannot be read (the tolerance is the floor) and the correction residual, the distance
    to the equilibrium over the load's displacement, is what holds the state
    (``Integrator.resolves_below_floor``)."""
    if model.residual_floor > MAX_RESIDUAL_FLOOR:
        return CORRECTION_TOLERANCE
    return max(tolerance, CORRECTION_TOLERANCE)


def effective_tolerance(model: Model, tolerance: float) -> float:
    """``tolerance`` raised to the round-off floor of ``model``'s residual."""
    return max(tolerance, model.residual_floor)


def unresolvable_message(model: Model) -> str | None:
    """Why ``model``'s equilibrium cannot be resolved (its residual floor above
    ``MAX_RESIDUAL_FLOOR``), or None when it can."""
    floor = model.residual_floor
    if floor <= MAX_RESIDUAL_FLOOR:
        return None
    return (f"the loads are below the round-off of the internal forces (residual floor "
            f"{floor:.3g} > {MAX_RESIDUAL_FLOOR:g}): no equilibrium can be told apart from "
            "the rest state in double precision")


def refuse_unresolvable(model: Model) -> None:
    """Raise ``SolverFailure`` (with advice) when ``unresolvable_message`` says
    ``model``'s equilibrium cannot be resolved."""
    message = unresolvable_message(model)
    if message is not None:
        raise SolverFailure(message, FLOOR_ADVICE)

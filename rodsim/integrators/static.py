"""Direct equilibrium solve: Newton on F(x) = 0 with load continuation.

No pseudo-dynamics at all: this is the exact discrete equilibrium of the model, against
which the other integrators are scored (DESIGN §3–4). Each Newton step solves
J(x) Δx = −F(x) with the analytic sparse Jacobian (SuperLU) and a backtracking line search
on the scaled residual. If Newton does not converge at full load, the external loads are
applied in increments λ ∈ (0, 1] (load continuation), halving the increment on failure and
growing it after easy steps.

Quaternion norm: held by the centerline penalty Eq. (9) (|d3| = |q|²), as in the model.
"""

from __future__ import annotations

import numpy as np

from rodsim.integrators.base import Integrator, Outcome
from rodsim.integrators.newton import NewtonProblem, newton
from rodsim.model import Model
from rodsim.schema import Parameter


class Static(Integrator):
    """Newton–Raphson with load continuation on F(x) = 0."""

    name = "static"
    summary = "Newton on F(x) = 0 with the analytic Jacobian and load continuation"
    quaternion_norm = "penalty Eq. (9) only (|d3| = |q|² is pulled to 1)"
    parameters = (
        Parameter("max_newton", "int", 30, "-", "Newton iterations per load step", 1, 10_000),
        Parameter("first_load_step", "float", 1.0, "-",
                  "first load increment (fraction of the full load)", 0.0, 1.0,
                  exclusive_minimum=True),
        Parameter("min_load_step", "float", 1e-4, "-",
                  "smallest load increment before giving up", 0.0, 1.0, exclusive_minimum=True),
    )

    def __init__(self, model: Model, *args, **kwargs) -> None:
        super().__init__(model, *args, **kwargs)
        self._conservative = all(term.conservative for term in model.terms)

    def advice(self) -> str:
        return ("try a smaller solver.static.first_load_step or min_load_step, or a "
                "pseudo-dynamic integrator (--integrator cvode)")

    def advance(self) -> Outcome:
        model, counts = self.model, self.counts
        x = model.x0
        load, step = 0.0, self.options["first_load_step"]
        while load < 1.0:
            target = min(1.0, load + step)
            self.check_budget(f"load fraction {target:.4g}")
            converged, x_new, iterations = self._newton(x, target)
            counts["newton_iters"] += iterations
            if not converged:
                step *= 0.25
                if step < self.options["min_load_step"]:
                    return Outcome(x, False, "Newton did not converge and the load step fell "
                                   "below min_load_step")
                continue
            if model.update_registration(x_new):
                x = x_new  # a tendon point changed parent: solve again at this load
                continue
            x, load = x_new, target
            counts["steps"] += 1
            self.checkpoint(x, f"load fraction {load:.4g}")
            self.history.record(load, x, self.residual(x))
            self.report(load, f"static: load {load:.3f}, {counts['newton_iters']} Newton "
                        "iterations")
            if iterations <= 6:
                step = min(1.0, 2.0 * step)
        return Outcome(x, True, "converged")

    def _newton(self, x: np.ndarray, load: float) -> tuple[bool, np.ndarray, int]:
        """Newton iterations at a fixed load; returns (converged, x, iterations)."""
        model = self.model
        problem = NewtonProblem(
            force=lambda y: self.force(y, load),
            jacobian=lambda y: self.jacobian(y, load),
            residual=model.residual,
            weight=model.residual_weight,
            potential=(lambda y: model.energy(y, load)) if self._conservative else None,
        )
        outcome = newton(problem, x, self.tolerance, self.options["max_newton"])
        self.counts["linear_solves"] += outcome.iterations
        return outcome.converged, outcome.x, outcome.iterations

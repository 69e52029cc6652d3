"""Each integrator's ``[solver.<name>]`` options as a hand-declared dataclass a type checker
sees (issue 21 item 3).

An integrator's ``parameters`` (its ``Parameter`` declarations, in its own file) stay the
one source of validation, defaults, help and docs; the classes here only type them, and
tests/test_types.py checks each one against its integrator's declarations
(``rodsim.core.schema.options_mismatch``: names, order, annotations, defaults), so the
two cannot drift. An integrator class uses its class by declaring it
(``Options = StaticOptions`` in ``Static``), which ``rodsim.core.schema.register_with_options``
checks again when the class is defined; ``self.options`` is then typed
(``options: StaticOptions``).
"""

from __future__ import annotations

from dataclasses import dataclass

from rodsim.core.schema import Options

__all__ = ["CvodeOptions", "DECLARED", "IdaOptions", "PaperOptions", "PseudoDynamicsOptions",
           "ScipyOptions", "StaticOptions"]


@dataclass(frozen=True, kw_only=True)
class StaticOptions(Options):
    """``[solver.static]``: Newton with load and penalty continuation
    (rodsim/solvers/static.py)."""

    max_newton: int = 30
    first_load_step: float = 1.0
    min_load_step: float = 0.0001
    penalty_ratio: float = 1000.0
    retraction: str = "auto"


@dataclass(frozen=True, kw_only=True)
class PaperOptions(Options):
    """``[solver.paper]``: the paper's damped semi-implicit Euler, Eqs. (14)–(19)
    (rodsim/solvers/paper_euler.py)."""

    h: float = 0.3
    xi: float = 0.9
    jacobian: str = "analytic"
    max_steps: int = 100000
    max_newton: int = 50
    ramp_steps: int = 0
    h2_omega2: float = 0.0


@dataclass(frozen=True, kw_only=True)
class PseudoDynamicsOptions(Options):
    """The options CVODE and IDA share: pseudo-dynamics, tolerances, linear solver and the
    Newton finish (rodsim/solvers/sundials.py)."""

    formulation: str = "overdamped"
    damping_ratio: float = 1.0
    mass_scaling: float = 1000.0
    load_ramp: float = 1.0
    rtol: float = 0.0001
    atol: float = 0.0001
    linear_solver: str = "auto"
    max_steps: int = 200000
    newton_switch: float = 0.1
    newton_iterations: int = 20


@dataclass(frozen=True, kw_only=True)
class CvodeOptions(PseudoDynamicsOptions):
    """``[solver.cvode]`` (rodsim/solvers/cvode.py)."""


@dataclass(frozen=True, kw_only=True)
class IdaOptions(PseudoDynamicsOptions):
    """``[solver.ida]`` (rodsim/solvers/ida.py): the Newton finish switches in later."""

    newton_switch: float = 0.03


@dataclass(frozen=True, kw_only=True)
class ScipyOptions(Options):
    """``[solver.scipy]``: scipy's ``solve_ivp`` on the pseudo-dynamics
    (rodsim/solvers/scipy_ivp.py)."""

    method: str = "BDF"
    damping_ratio: float = 1.0
    mass_scaling: float = 1000.0
    load_ramp: float = 1.0
    rtol: float = 1e-06
    atol: float = 1e-06


#: The declared options class of every registered integrator, by its name.
DECLARED: dict[str, type[Options]] = {
    "static": StaticOptions, "paper": PaperOptions, "cvode": CvodeOptions,
    "ida": IdaOptions, "scipy": ScipyOptions,
}

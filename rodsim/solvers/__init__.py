"""Integrators, one file each, and the registry that finds them.

- ``paper``:  the paper's damped semi-implicit Euler, Eqs. (17)/(19)
- ``cvode``:  SUNDIALS CVODE (adaptive BDF) on the inertial or overdamped pseudo-dynamics
- ``ida``:    SUNDIALS IDA on the residual form, quaternion norms as algebraic equations
- ``static``: Newton on F(x) = 0 with load continuation (the exact discrete equilibrium)
- ``scipy``:  scipy's ``solve_ivp`` (BDF or LSODA) on the overdamped pseudo-dynamics, an
  outside baseline for the benchmarks

Every module of this package that defines an ``rodsim.solvers.base.Integrator``
subclass with a ``name`` registers it; ``registered_integrators`` imports them all on
first use. Each integrator declares and validates its own ``[solver.<name>]`` options.
"""

from __future__ import annotations

import functools
import importlib
import pkgutil
from typing import TYPE_CHECKING

# The integrator a scene that names none runs, and that a track, a fit, a reach or a warm
# re-solve uses unless told otherwise: the direct Newton solve, the exact discrete
# equilibrium. The one integrator name app code uses (rodsim/core/integrator_default.py).
from rodsim.core.integrator_default import DEFAULT_INTEGRATOR

if TYPE_CHECKING:
    from rodsim.core.scene import Scene
    from rodsim.solvers.base import Integrator

__all__ = ["registered_integrators", "integrator_named", "check_solver_options",
           "integrator_option_keys", "DEFAULT_INTEGRATOR"]


def registered_integrators() -> dict[str, type[Integrator]]:
    """Every registered integrator class by name, in the names' order (imports this
    package's modules; the order does not depend on which of them was imported first)."""
    from rodsim.solvers.base import INTEGRATORS

    _import_every_module()
    return dict(sorted(INTEGRATORS.items()))


def integrator_named(name: object) -> type[Integrator]:
    """The registered integrator class called ``name``; SceneError (one line, naming the
    allowed ones) for any other value."""
    from rodsim.core.schema import SceneError

    integrators = registered_integrators()
    if not isinstance(name, str) or name not in integrators:
        raise SceneError(f"integrator {str(name)[:40]!r}: unknown; allowed: "
                         + ", ".join(integrators))
    return integrators[name]


def check_solver_options(scene: Scene) -> None:
    """Raise ``rodsim.core.schema.SceneError`` unless ``solver.integrator`` and every
    ``[solver.<name>]`` table of ``scene`` name a registered integrator with valid options."""
    from rodsim.core.scene import SOLVER_PARAMETERS
    from rodsim.core.schema import SceneError, shown

    integrators = registered_integrators()
    if scene.solver.integrator not in integrators:
        raise SceneError(f"solver.integrator = {shown(scene.solver.integrator)}: unknown "
                         "integrator; allowed: " + ", ".join(integrators))
    # The [solver.<name>] tables are the JSON scene's own (keyed by integrator name).
    for name, table in scene.data["solver"].items():
        if isinstance(table, dict):
            if name not in integrators:
                known = sorted(p.name for p in SOLVER_PARAMETERS) + list(integrators)
                raise SceneError(f"solver.{shown(name, bare=True)}: unknown key; known keys: "
                                 + ", ".join(known))
            integrators[name].options_of(scene)


def integrator_option_keys() -> tuple[str, ...]:
    """Full keys ``solver.<integrator>.<option>`` of every registered integrator's options."""
    return tuple(f"solver.{name}.{p.name}" for name, cls in registered_integrators().items()
                 for p in cls.parameters)


@functools.cache
def _import_every_module() -> None:
    """Import each module of this package once (defining a class registers it)."""
    for module in pkgutil.iter_modules(__path__):
        if not module.name.startswith("_"):
            importlib.import_module(f"{__name__}.{module.name}")

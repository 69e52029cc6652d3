"""Integrators, one file each; importing this package registers all of them.

- ``paper``:  the paper's damped semi-implicit Euler, Eqs. (17)/(19)
- ``cvode``:  SUNDIALS CVODE (adaptive BDF) on the inertial or overdamped pseudo-dynamics
- ``ida``:    SUNDIALS IDA on the residual form, quaternion norms as algebraic equations
- ``static``: Newton on F(x) = 0 with load continuation (the exact discrete equilibrium)
- ``scipy``:  scipy's ``solve_ivp`` (BDF or LSODA) on the overdamped pseudo-dynamics, an
  outside baseline for the benchmarks
"""

import importlib
import pkgutil

from rodsim.solvers.base import INTEGRATORS, Integrator, registered_integrators

for _module in pkgutil.iter_modules(__path__):
    if not _module.name.startswith("_") and _module.name != "base":
        importlib.import_module(f"{__name__}.{_module.name}")

__all__ = ["INTEGRATORS", "Integrator", "registered_integrators"]

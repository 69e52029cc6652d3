"""The SUNDIALS solver a CVODE or IDA run steps, with the run's time across restarts.

A run replaces its solver when it restarts (a tendon re-registration changes the Jacobian's
pattern; a tightening changes the tolerances). ``Clock`` holds the solver in use, the
last accepted (t, y, y′) and the time the replaced solvers spent:

- a run to equilibrium restarts a solver's clock at the end of the load ramp, where the
  pseudo-dynamics are autonomous, so its first step is not lost against a huge t; the
  pseudo-time already elapsed is kept apart (``shift``);
- a run to a time (``rodsim.solvers.stops.Until``) restarts at the same t.

Each step is one internal step of SUNDIALS (its one-step mode), with SUNDIALS' failure text
captured into one buffer so it lands in rodsim's diagnostic, not in the middle of ``rodsim
run``'s summary. ``Clock.interpolate`` is the dense output of the last step (SUNDIALS'
normal mode at a time inside it: no step is taken).
"""

from __future__ import annotations

import io
import sys
from typing import Any, Protocol

import numpy as np

from rodsim.solvers.failure import SolverFailure
from rodsim.solvers.sundials_setup import StartFailure

__all__ = ["Clock"]


class Starter(Protocol):
    """What the clock asks of the integrator: a solver started at (t, y[, y′])."""

    @property
    def name(self) -> str: ...

    def start(self, run: Any, t: float, y: np.ndarray, yp: np.ndarray | None) -> Any: ...


class Clock:
    """The solver a run steps and its time (module docstring)."""

    def __init__(self, integrator: Starter, run: Any, y: np.ndarray, shift: bool) -> None:
        self.integrator, self.run, self.shift = integrator, run, shift
        self.t, self.y, self.yp = 0.0, y, None
        #: Pseudo-time spent in solvers that were replaced (``shift`` only).
        self.elapsed = 0.0
        #: SUNDIALS' printed failure text of every step.
        self.printed = io.StringIO()
        self._interpolated = False
        self.solver = integrator.start(run, self.t, self.y, self.yp)

    @property
    def time(self) -> float:
        """The run's time at the last accepted step."""
        return self.t + self.elapsed

    def restart(self) -> None:
        """A new solver from the last accepted state, at rest (y′ from the residual)."""
        at = self.time
        t = self.t
        if self.shift and t > self.run.dynamics.ramp.duration:
            self.elapsed += t - self.run.dynamics.ramp.duration
            t = self.run.dynamics.ramp.duration
        try:
            self.solver = self.integrator.start(self.run, t, self.y, None)
        except StartFailure as exc:  # say where the run was, not the new solver's clock
            counts = self.run.counts
            reinits, tightenings = int(counts["reinits"]), int(counts.get("tightenings", 0))
            raise SolverFailure(
                f"{self.integrator.name.upper()} could not restart at t = {at:.4g} s (after "
                f"{reinits} re-initialisation{'' if reinits == 1 else 's'} and "
                f"{tightenings} tightening{'' if tightenings == 1 else 's'}): "
                f"{exc.detail}") from None
        self.t = t
        self._interpolated = False

    def step(self, toward: float, tstop: float | None = None) -> Any:
        """One internal step toward ``toward`` (not past ``tstop``, if given): SUNDIALS'
        result, unaccepted (``accept``). After ``interpolate``, SUNDIALS' one-step
        mode first returns the last step's end again (no work): that return is skipped."""
        out = self._quiet_step(toward, tstop)
        if self._interpolated and out.success and float(out.t) == self.t:
            out = self._quiet_step(toward, tstop)
        self._interpolated = False
        return out

    def _quiet_step(self, toward: float, tstop: float | None) -> Any:
        saved, sys.stdout = sys.stdout, self.printed
        try:
            if tstop is None:
                return self.solver.step(toward, method="onestep")
            return self.solver.step(toward, method="onestep", tstop=tstop)
        finally:
            sys.stdout = saved

    def accept(self, out: Any) -> None:
        """Take SUNDIALS' step result ``out`` as the last accepted state."""
        self.t, self.y, self.yp = float(out.t), out.y.copy(), getattr(out, "yp", None)

    def failure_text(self) -> str:
        """What SUNDIALS printed, on one line."""
        return " ".join(self.printed.getvalue().split())

    def interpolate(self, t: float) -> np.ndarray:
        """y at ``t`` inside the last step, from SUNDIALS' interpolating polynomial (its
        dense output; no step is taken)."""
        saved, sys.stdout = sys.stdout, self.printed
        try:
            out = self.solver.step(t, method="normal")
            for _ in range(8):  # with root finding, normal mode stops at a root on the way
                if out.status != 2 or float(out.t) == t:  # (one the step already reported)
                    break
                out = self.solver.step(t, method="normal")
        finally:
            sys.stdout = saved
        if not out.success:
            raise SolverFailure(f"{self.integrator.name.upper()} could not interpolate at "
                                f"t = {t:.4g} s: {out.message}")
        self._interpolated = True
        return np.array(out.y)

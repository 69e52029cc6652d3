"""Where a run's ``rodsim.solvers.base.Integrator.advance`` ended: the value the
integrator returns and the run's stop judges (``rodsim.solvers.stops.Stop.verdict``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Outcome"]


@dataclass
class Outcome:
    """What ``Integrator.advance`` returns: the final state (free coordinates), whether
    it met the method's own test (an equilibrium; the end time of a run to a time), and a
    short message. Where the method stopped, its counters and its history live on the run's
    state (``rodsim.solvers.run_state.RunState``), so they survive a
    ``rodsim.solvers.failure.SolverFailure`` raised mid-run; the template turns such a
    failure into an Outcome at the last checkpoint carrying the failure's ``advice``."""

    x: np.ndarray
    success: bool
    message: str
    #: What to try, when a failure named a specific remedy (None: the integrator's own advice).
    advice: str | None = None

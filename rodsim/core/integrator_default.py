"""The integrator a scene runs when it names none, and that every command uses unless told
otherwise: one name for `rodsim run`, `track`, `fit`, `reach`, the Python API and the
re-solves behind the error estimates (re-exported as ``rodsim.solvers.DEFAULT_INTEGRATOR``).

``static`` is Newton on F(x) = 0 with load continuation: the exact discrete equilibrium.
On the user scenes and user-like robots of benchmarks/results/default-integrator.md it
solved every scene that ``cvode`` solved, to the same tip, at a fraction of its CPU
(docs/scenes.md, "Which integrator runs"). A scene that names its integrator
(``[solver] integrator``) keeps it, and so does an archive: it stores the integrator it
was solved with, and its resolved scene holds ``solver.integrator`` explicitly.
"""

from __future__ import annotations

__all__ = ["DEFAULT_INTEGRATOR"]

#: The registry's default integrator (module docstring).
DEFAULT_INTEGRATOR = "static"

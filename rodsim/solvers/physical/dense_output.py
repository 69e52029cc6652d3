"""Outputs between step ends: the states at requested times inside a step of physical time,
read off the step's cubic Hermite interpolant, so that outputs force no step (docs/dynamics.md,
"Outputs between steps").

Both midpoint loops use it: the error-controlled one (rodsim/solvers/physical/error_control.py)
always, the fixed-step one (rodsim/solvers/physical/trajectory.py) where the output spacing
is not a whole number of steps. The state at t in (t₀, t₁): positions and quaternions on the
interpolant of rodsim/solvers/physical/step_events.py (positions on (r₀, v₀, r₁, v₁),
quaternions on (q₀, q̇₀, q₁, q̇₁), normalised), the node velocities its derivative, the body
rates linear in t. Its error is the interpolant's, O(h⁴) in the positions over a resolved
motion, local: it does not feed back into the run, which goes on from the step's end. The
energies there are those of the interpolated state; the dissipated energy and the
programs' work are interpolated linearly across the step, so an interpolated output's
energy balance includes the interpolant's error. An output at or past the step's end is
the step's end state itself, with its energies as reached.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from rodsim.core.model import Model
from rodsim.solvers.physical.coordinates import PhysicalCoordinates
from rodsim.solvers.physical.fixed_step import Motion
from rodsim.solvers.physical.step_events import hermite
from rodsim.solvers.physical.trajectory_record import Record, potential

__all__ = ["record_outputs"]


def record_outputs(record: Record, coordinates: PhysicalCoordinates,
                   model_at: Callable[[float], Model],
                   span: tuple[float, Motion, float, Motion], times: Sequence[float],
                   energy: tuple[float, float, float, float]) -> None:
    """Record the output ``times`` in (t0, t1] of the step ``span`` = (t0, start, t1, end)
    (module docstring); ``energy`` = (dissipated at t0, at t1, work at t0, at t1)."""
    t0, start, t1, end = span
    c = coordinates
    x = hermite(c, t0, start, t1, end) if any(t < t1 for t in times) else None
    for t in times:
        if t >= t1 or x is None:
            motion, s = end, 1.0
        else:
            s = (t - t0) / (t1 - t0)
            state, v = x(t)
            motion = Motion(state, v, (1.0 - s) * start.w + s * end.w)
        record.add(t, motion, c.kinetic_energy(motion.v, motion.w),
                   potential(model_at(t), motion.x),
                   (1.0 - s) * energy[0] + s * energy[1], (1.0 - s) * energy[2] + s * energy[3])

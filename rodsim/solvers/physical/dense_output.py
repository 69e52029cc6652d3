"""Outputs between step ends: the states at requested times inside a step of physical time,
read off the step's cubic Hermite interpolant, so that outputs force no step (docs/dynamics.md,
"Outputs between steps").

Both midpoint loops use it: the error-controlled one (rodsim/solvers/physical/error_control.py)
always, the fixed-step one (rodsim/solvers/physical/trajectory.py) where the output spacing
is not a whole number of steps. The state at t in (t₀, t₁): positions and quaternions on the
interpolant of rodsim/solvers/physical/step_events.py (positions on (r₀, v₀, r₁, v₁),
quaternions on (q₀, q̇₀, q₁, q̇₁), normalised), the node velocities its derivative, the body
rates linear in t. Its error is the interpolant's, O(h⁴) in the positions over a resolved
motion, local: it does not feed back into the run, which goes on from the step's end.

The energies there — kinetic, potential, dissipated and the programs' work — are the step
ends' interpolated linearly in t, so that an output's energy balance is the step ends'
balances interpolated: the integrator's own error, nothing added. The energy of the
interpolated state itself is not used: a mode the step does not resolve (stretch, shear,
twist at ωh ≫ 1, whose velocity the midpoint rule reverses every step) puts h v/4 into the
interpolated positions at mid-step, and the stiff mode's energy grows by (ωh)²/16 there
(measured on the steel rod released from 0.1 N, N = 11, 25 steps a period: a balance off by
0.92 of the vibration's energy, 38 times it under the fourth-order composition, against
3e-6 and 9e-7 at the step ends). An output at or past the step's end, or within
``SAME_TIME`` of the step's length before it, is the step's end state itself, with its
energies as reached; one within that of the step's start is the start state.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from rodsim.core.model import Model
from rodsim.solvers.physical.coordinates import PhysicalCoordinates
from rodsim.solvers.physical.fixed_step import Motion
from rodsim.solvers.physical.step_events import hermite
from rodsim.solvers.physical.trajectory_record import Record, potential

__all__ = ["record_outputs", "SAME_TIME"]

#: An output this close to a step's end (start), as a fraction of the step, is the step's
#: end (start) state: output times and step ends that meet (every fourth output at 25
#: steps and 20 outputs a period) are computed by different sums and differ in their last
#: bits.
SAME_TIME = 1e-9


def record_outputs(record: Record, coordinates: PhysicalCoordinates,
                   model_at: Callable[[float], Model],
                   span: tuple[float, Motion, float, Motion], times: Sequence[float],
                   energy: tuple[float, float, float, float],
                   known: tuple[float, float] | None = None) -> tuple[float, float] | None:
    """Record the output ``times`` in (t0, t1] of the step ``span`` = (t0, start, t1, end)
    (module docstring); ``energy`` = (dissipated at t0, at t1, work at t0, at t1);
    ``known``: the (kinetic, potential) energy at the step's start where the caller has
    them (the last step's end: the same state and time). Returns those at the step's end
    where it computed them (an output between step ends), else None."""
    if not times:
        return None
    t0, start, t1, end = span
    c = coordinates
    kinetic = c.kinetic_energy(end.v, end.w)
    # an output within SAME_TIME of the step's length from its end (its start) is that end
    # (start): the times of a step plan and of an output grid meet there but are summed
    # differently
    inside = [t for t in times if t < t1 - SAME_TIME * (t1 - t0)]
    reached = None
    if inside:
        begun = known if known is not None else (c.kinetic_energy(start.v, start.w),
                                                 potential(model_at(t0), start.x))
        reached = (kinetic, potential(model_at(t1), end.x))
        ends = ((begun[0], reached[0]), (begun[1], reached[1]), energy[:2], energy[2:])
        x = None
        for t in inside:
            s = (t - t0) / (t1 - t0)
            if s <= SAME_TIME:
                record.add(t, start, begun[0], begun[1], energy[0], energy[2])
                continue
            if x is None:
                x = hermite(c, t0, start, t1, end)
            state, v = x(t)
            kinetic_t, potential_t, dissipated_t, work_t = ((1.0 - s) * a + s * b
                                                            for a, b in ends)
            record.add(t, Motion(state, v, (1.0 - s) * start.w + s * end.w), kinetic_t,
                       potential_t, dissipated_t, work_t, interpolated=True)
    for t in times[len(inside):]:
        record.add(t, end, kinetic, potential(model_at(t), end.x), energy[1], energy[3])
    return reached

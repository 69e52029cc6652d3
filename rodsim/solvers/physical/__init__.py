"""Physical time: the equations of motion with the rods' real inertia and damping
(paper Eqs. 10–13; docs/dynamics.md).

Kept apart from the integrators of this package's parent, which reach an equilibrium
through a pseudo-time (rodsim/solvers/pseudo_dynamics.py): nothing here is registered as an
``rodsim.solvers.base.Integrator``.

- ``rodsim.solvers.physical.coordinates``: the physical velocities (node velocities and
  each segment's body angular velocity), the mass, the quaternion kinematics (Eq. 13).
- ``rodsim.solvers.physical.fixed_step``: a fixed step's motion, outcome and failure, and
  the Newton iteration on the velocities the fixed-step integrators share.
- ``rodsim.solvers.physical.midpoint``: the implicit midpoint step, Newton on the
  model's analytic Jacobian.
- ``rodsim.solvers.physical.trajectory``: the run to ``t_end``, output times, the
  energy balance.
- ``rodsim.solvers.physical.dae``: the equations as a residual for SUNDIALS IDA, the
  unit quaternion an algebraic equation; ``rodsim.solvers.physical.ode``: the explicit
  form for CVODE, the quaternions projected.
- ``rodsim.solvers.physical.ida_run``: the adaptive run with IDA or CVODE (dense output,
  program breakpoints, the same energy balance).
- ``rodsim.solvers.physical.events``: the events (contact onset, a tendon going slack, a
  user's function) as event functions; ``rodsim.solvers.physical.step_events``: their
  roots under the midpoint rule (SUNDIALS' root finding under IDA and CVODE).
"""

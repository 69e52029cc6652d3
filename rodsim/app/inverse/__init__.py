"""Calibration, tracking and inverse kinematics on the analytic Jacobian (docs/inverse.md).

- ``rodsim.app.inverse.parameter_keys``: numeric scene values by key, with their bounds;
- ``rodsim.app.inverse.sensitivity``: d(shape)/d(parameter) at an equilibrium;
- ``rodsim.app.inverse.continuation``: equilibria warm-started from a nearby one;
- ``rodsim.app.inverse.track``: equilibria along an actuation path (``rodsim track``);
- ``rodsim.app.inverse.fit``: parameters fitted to measured points (``rodsim fit``);
- ``rodsim.app.inverse.reach``: actuation putting the tip at a target (``rodsim reach``).

``rodsim.sensitivity``, ``rodsim.track``, ``rodsim.fit`` and ``rodsim.reach`` are these
modules' functions.
"""

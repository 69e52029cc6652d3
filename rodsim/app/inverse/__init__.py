"""Calibration, tracking and inverse kinematics on the analytic Jacobian (docs/inverse.md).

- :mod:`~rodsim.app.inverse.parameter_keys`: numeric scene values by key, with their bounds;
- :mod:`~rodsim.app.inverse.sensitivity`: d(shape)/d(parameter) at an equilibrium;
- :mod:`~rodsim.app.inverse.continuation`: equilibria warm-started from a nearby one;
- :mod:`~rodsim.app.inverse.track`: equilibria along an actuation path (``rodsim track``);
- :mod:`~rodsim.app.inverse.fit`: parameters fitted to measured points (``rodsim fit``);
- :mod:`~rodsim.app.inverse.reach`: actuation putting the tip at a target (``rodsim reach``).

``rodsim.sensitivity``, ``rodsim.track``, ``rodsim.fit`` and ``rodsim.reach`` are these
modules' functions.
"""

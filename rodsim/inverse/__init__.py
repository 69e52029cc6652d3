"""Calibration, tracking and inverse kinematics on the analytic Jacobian (docs/inverse.md).

- :mod:`~rodsim.inverse.parameter_keys`: numeric scene values by key, with their bounds;
- :mod:`~rodsim.inverse.sensitivity`: d(shape)/d(parameter) at an equilibrium;
- :mod:`~rodsim.inverse.continuation`: equilibria warm-started from a nearby one;
- :mod:`~rodsim.inverse.track`: equilibria along an actuation path (``rodsim track``);
- :mod:`~rodsim.inverse.fit`: parameters fitted to measured points (``rodsim fit``);
- :mod:`~rodsim.inverse.reach`: actuation putting the tip at a target (``rodsim reach``).

``rodsim.sensitivity``, ``rodsim.track``, ``rodsim.fit`` and ``rodsim.reach`` are these
modules' functions.
"""

"""rodsim: tendon-driven robotic catheters as systems of Cosserat rods.

Implements Villard, Waite & Howe, *Cosserat rods for modeling tendon-driven robotic
catheter systems* (see docs/model.md for the equation -> code map).
"""

__version__ = "0.1.0"

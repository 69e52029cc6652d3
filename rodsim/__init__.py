"""rodsim: tendon-driven robotic catheters as systems of Cosserat rods.

Implements Villard, Waite & Howe, *Cosserat rods for modeling tendon-driven robotic
catheter systems* (see docs/model.md for the equation -> code map).
"""

__version__ = "0.1.0"

from rodsim.api import build_model, load_scene, solve  # noqa: E402

__all__ = ["__version__", "build_model", "load_scene", "solve"]

"""rodsim: tendon-driven robotic catheters as systems of Cosserat rods.

Implements Villard, Waite & Howe, *Cosserat rods for modeling tendon-driven robotic
catheter systems* (see docs/model.md for the equation -> code map).

Importing rodsim pins OpenMP and OpenBLAS to one thread unless ``OMP_NUM_THREADS`` /
``OPENBLAS_NUM_THREADS`` are already set: the solvers' callbacks hold the GIL and the linear
algebra is small, and threaded BLAS on a shared 2-core machine gave intermittent 10×
slow-downs (DESIGN §8). This takes effect only if numpy is not imported before rodsim.
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

__version__ = "0.1.0"

from rodsim.api import build_model, load_scene, solve  # noqa: E402

__all__ = ["__version__", "build_model", "load_scene", "solve"]

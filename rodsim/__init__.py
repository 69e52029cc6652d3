"""rodsim: tendon-driven robotic catheters as systems of Cosserat rods.

Implements Villard, Waite & Howe, *Cosserat rods for modeling tendon-driven robotic
catheter systems* (docs/architecture.md maps each equation to its file).

Importing rodsim has no side effects: the ``rodsim`` command pins BLAS threads and selects a
file-only matplotlib backend itself (``rodsim.app.threads``, ``rodsim.app.cli.main``).
The package is layered core → solvers → io → app (docs/architecture.md).

``rodsim.load_scene``, ``rodsim.solve``, ``rodsim.solve_many`` (many cases of one scene,
docs/batch.md), ``rodsim.build_model``, ``rodsim.run_dataset`` (a
run's archive Dataset), ``rodsim.penalty_error`` (how far a result depends on its
penalties, docs/model.md) and the inverse tools
``rodsim.sensitivity``, ``rodsim.track``, ``rodsim.Tracker``, ``rodsim.fit`` and
``rodsim.reach`` (docs/inverse.md), ``rodsim.modes`` (natural frequencies and mode shapes,
docs/dynamics.md), ``rodsim.compile_kernels`` (the compiled kernels into numba's disk cache
ahead of time, rodsim/app/precompile.py) and ``rodsim.simulate`` (motion in physical time, with
``rodsim.Sinusoid`` programs and the events ``rodsim.ContactOnset``,
``rodsim.TendonSlack`` and ``rodsim.Event``; docs/dynamics.md) are imported on first use.
"""

from rodsim.version import __version__

__all__ = ["ContactOnset", "Event", "Sinusoid", "TendonSlack", "Tracker", "__version__",
           "build_model", "compile_kernels", "fit", "load_scene", "modes",
           "penalty_error", "reach", "run_dataset", "sensitivity", "simulate", "solve",
           "solve_many", "track"]

#: The inverse tools: name -> module (each module defines a function of the same name).
_INVERSE = {"sensitivity": "rodsim.app.inverse.sensitivity",
            "track": "rodsim.app.inverse.track_estimates",
            "fit": "rodsim.app.inverse.fit", "reach": "rodsim.app.inverse.reach"}


def __dir__() -> list[str]:
    """The module's names and its entry points, which are imported on first use (so
    ``dir(rodsim)`` and a notebook's completion list them)."""
    return sorted(set(globals()) | set(__all__))


def __getattr__(name: str):
    """The Python entry points of ``rodsim.app.api`` and the inverse tools, imported on first
    use: ``import rodsim`` stays light (SUNDIALS, xarray and numba are loaded only when a
    solve needs them)."""
    if name in ("build_model", "load_scene", "solve"):
        from rodsim.app import api

        return getattr(api, name)
    if name == "run_dataset":
        from rodsim.io.run_dataset import run_dataset

        return run_dataset
    if name == "Tracker":
        from rodsim.app.inverse.tracker import Tracker

        return Tracker
    if name == "solve_many":
        from rodsim.app.batch import solve_many

        return solve_many
    if name == "modes":
        from rodsim.app.modes import modes

        return modes
    if name == "simulate":
        from rodsim.app.simulate import simulate

        return simulate
    if name in ("ContactOnset", "Event", "TendonSlack"):
        from rodsim.solvers.physical import events

        return getattr(events, name)
    if name == "Sinusoid":
        from rodsim.core.program import Sinusoid

        return Sinusoid
    if name == "compile_kernels":
        from rodsim.app.precompile import compile_kernels
        return compile_kernels
    if name == "penalty_error":
        from rodsim.app.trust import penalty_error

        return penalty_error
    if name in _INVERSE:
        import importlib

        return getattr(importlib.import_module(_INVERSE[name]), name)
    raise AttributeError(f"module 'rodsim' has no attribute {name!r}")

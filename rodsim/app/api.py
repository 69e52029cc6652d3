"""The Python entry points: load a scene, change values, solve with a named integrator.

    >>> import rodsim
    >>> scene = rodsim.load_scene("table1-50g").with_overrides(["nodes=80"])
    >>> result = rodsim.solve(scene, "static")
    >>> result.tip(), rodsim.run_dataset(result)

Everything the CLI does goes through these functions (README, "Python").
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rodsim.core.assembly_budget import AssemblyBudget, AssemblyBudgetExceeded
from rodsim.core.memory import check_memory
from rodsim.core.model import Model
from rodsim.core.scene import Scene, default_scene_path
from rodsim.solvers import (
    check_solver_options,
    integrator_named,
    integrator_option_keys,
    registered_integrators,
)
from rodsim.solvers.base import Progress
from rodsim.solvers.result import Result, use_archive_maker

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["load_scene", "solve", "build_model", "rerun"]

SceneLike = Scene | str | Path | Mapping[str, Any]


def _run_dataset(result: Result) -> xr.Dataset:
    """A run's archive Dataset (``Result.to_xarray``); xarray is imported on first use."""
    from rodsim.io.run_dataset import run_dataset

    return run_dataset(result)


use_archive_maker(_run_dataset)


def load_scene(scene: SceneLike | None = None, overrides: Iterable[str] = (),
               prefer: str = "") -> Scene:
    """A fully validated scene from a file path, a shipped scene name, a dict, or a Scene:
    the one call that gives one (and an archive's scene, ``rodsim.io.archive.scene_of``).

    ``Scene.load`` and ``Scene.from_dict`` check the scene against the model's declarations
    only: the core does not know the integrators, so the ``[solver.<name>]`` tables are
    left to them: here they are checked against the registered integrators
    (``rodsim.solvers.check_solver_options``), after any overrides.

    ``None`` gives the default scene (Table 1, 50 g). ``overrides`` are ``key=value`` strings
    as for the CLI's ``--set`` (``prefer`` as in ``Scene.with_overrides``); the
    integrators' options may be named by their short forms too.
    """
    if scene is None:
        loaded = Scene.load(default_scene_path())
    elif isinstance(scene, Scene):
        loaded = scene
    elif isinstance(scene, Mapping):
        loaded = Scene.from_dict(scene)
    else:
        loaded = Scene.load(scene)
    overrides = list(overrides)
    if overrides:
        loaded = loaded.with_overrides(overrides, prefer, integrator_option_keys())
    check_solver_options(loaded)
    return loaded


def build_model(scene: SceneLike | None = None) -> Model:
    """The assembled model (force, Jacobian, pattern) of a scene (SceneError when the scene
    is too large for this machine's memory, ``rodsim.core.memory``)."""
    loaded = load_scene(scene)
    check_memory(loaded)
    return Model(loaded)


def solve(scene: SceneLike | None = None, integrator: str | None = None, *,
          overrides: Iterable[str] = (), progress: Progress | None = None,
          model: Model | None = None, initial_state: np.ndarray | None = None) -> Result:
    """Run one integrator to equilibrium and return its ``rodsim.solvers.result.Result``.

    Parameters
    ----------
    scene
        Scene, path, shipped scene name, dict, or ``None`` for the default scene.
    integrator
        ``paper``, ``cvode``, ``ida`` or ``static``; default: the scene's
        ``solver.integrator``.
    overrides
        ``key=value`` changes applied to the scene first.
    progress
        Optional callback ``(fraction or None, status line)`` for long runs.
    model
        A model already built for this scene, to skip the assembly.
    initial_state
        Free coordinates to start from (a warm start from a nearby equilibrium, whose
        registration ``model`` should carry) instead of the rest state; the loads then act
        in full from the start. They are offsets from the rest state of the scene's model
        (a ``Result.state`` of the same scene; a stored shape, such as a track's
        ``states[k]``, through ``build_model(scene).state_of(shape)``: docs/model.md, "The
        offset state and the residual floor").

    Notes
    -----
    A solver failure does not raise: check ``result.success`` and ``result.message``.
    Invalid scenes raise ``rodsim.core.schema.SceneError``, and so does a scene too large
    for this machine's memory (``rodsim.core.memory``). The wall-time budget
    (``solver.max_wall_time``) starts here: it covers the model's assembly, which stops once
    it is spent (rodsim/core/assembly_budget.py) with a failed result that holds no shape
    (``rods`` empty, ``state`` of length 0: there is no model yet).
    """
    started = time.perf_counter()
    loaded = load_scene(scene, overrides, f"solver.{integrator}" if integrator else "")
    solver = loaded.solver
    name = integrator or solver.integrator
    kind = integrator_named(name)
    if model is None or model.scene is not loaded:
        check_memory(loaded)
        try:
            model = Model(loaded, budget=AssemblyBudget(
                started, float(solver.max_wall_time),
                sum(rod.nodes for rod in loaded.rods.values())))
        except AssemblyBudgetExceeded as exc:
            return _assembly_failure(loaded, name, exc)
    runner = kind.for_scene(loaded, progress)
    return runner.solve(model, initial_state, budget_start=started)


def _assembly_failure(scene: Scene, integrator: str, exc: AssemblyBudgetExceeded) -> Result:
    """The failed result of a run whose wall-time budget was spent assembling the model."""
    options = registered_integrators()[integrator].options_of(scene)
    return Result(scene=scene, integrator=integrator, options=dataclasses.asdict(options),
                  success=False, message=str(exc), residual=float("nan"),
                  stats={"steps": 0, "newton_iters": 0, "force_evals": 0,
                         "wall_time": exc.elapsed,
                         "effective_tolerance": float(scene.solver.tolerance)},
                  rods={}, state=np.zeros(0))


def rerun(dataset: xr.Dataset, solver: Callable[[Scene, str], Result] | None = None
          ) -> tuple[Result, float]:
    """Re-run a stored run from the archive alone, by ``solver`` (scene, integrator) →
    Result if given (a fit or reach archive's stored path: ``path_solver`` of
    rodsim/app/inverse/path_record.py), else a cold solve.

    Returns the new result and the largest distance [m] between stored and recomputed
    control points (infinite when either holds a NaN: see ``largest_distance``).
    """
    from rodsim.io.archive import ArchiveError, scene_of
    from rodsim.io.archive_schema import parse_json_object
    from rodsim.io.compare import largest_rod_distance
    from rodsim.io.run_dataset import run_dataset

    scene = scene_of(dataset)
    stored_options = parse_json_object(dataset.attrs["integrator_options"],
                                       "attribute 'integrator_options'")
    integrator = str(dataset.attrs["integrator"])
    if stored_options != dataclasses.asdict(registered_integrators()[integrator].options_of(scene)):
        raise ArchiveError("archive is inconsistent: integrator_options differ from the "
                           "scene's solver options")
    result = (solver or solve)(scene, integrator)
    new = run_dataset(result)
    return result, largest_rod_distance(dataset["position"].values, dataset["rod"].values,
                                        new["position"].values, new["rod"].values)

"""What a fit or a reach archive records of the friction history of its final state
(docs/archive.md, "Archives of the inverse tools"; docs/tendon.md, "Friction").

A fit's or a reach's equilibrium is the continuation's (rodsim/app/inverse/continuation.py):
a cold solve at the scene's values, then one equilibrium at each trial value of the
optimiser, each from the last. With tendon friction the chord tensions and the stick/slip
states at the end (``tension_profile``, ``slip_state``: the run archive's, of that final
state with its own history, ``rodsim.core.friction_record``) depend on that whole path, not
on the values found alone: a trial past the answer and back leaves points stuck that a
monotone approach leaves sliding. So the archive keeps the path — per parameter the values
of every equilibrium, ``<name>_path`` along the dimension ``evaluation`` — and says so in
its ``friction_history``: a track through those values (``rodsim.track``) ends on the same
tensions and states, and ``rodsim rerun`` replays it (``path_solver``, ``replayed``)
instead of a cold solve.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from rodsim.app.inverse.parameter_keys import NumericKey, numeric_keys, scene_with
from rodsim.core.scene import Scene
from rodsim.io.cf_layout import variable_name
from rodsim.io.run_dataset import FRICTION_HISTORY

if TYPE_CHECKING:
    import xarray as xr

    from rodsim.solvers.result import Result

__all__ = ["path_solver", "record_path", "replayed"]


def record_path(ds: xr.Dataset, keys: Sequence[NumericKey], path: np.ndarray,
                kind: str) -> None:
    """With tendon friction (the archive ``ds`` holds ``tension_profile``): the values
    ``path`` (evaluations, keys) of the ``kind`` ('fit' or 'reach') continuation's
    equilibria as ``<name>_path`` (evaluation) per key, and the ``friction_history``
    attribute saying the final state's history is that path (module docstring)."""
    if "tension_profile" not in ds.variables:
        return
    path = np.asarray(path, dtype=float)
    ds.coords["evaluation"] = (("evaluation",), np.arange(len(path), dtype=np.int64),
                               {"units": "1", "long_name": f"equilibrium of the {kind}'s "
                                "continuation (0: the cold solve at the scene's values)"})
    for column, key in enumerate(keys):
        ds[f"{variable_name(key.name)}_path"] = (
            ("evaluation",), path[:, column],
            {"units": key.unit, "scene_key": key.name,
             "long_name": f"{key.name} at each equilibrium of the {kind}'s continuation "
             "(the history of its tendon friction)"})
    ds.attrs["friction_history"] = (
        f"evaluation 0: {FRICTION_HISTORY}; then the {kind}'s continuation through the "
        f"values of the '*_path' variables, each equilibrium anchored at the last: "
        f"tension_profile and slip_state are those of its final state, which a track through "
        f"those values reproduces")


def replayed(dataset: xr.Dataset, scene: Scene, integrator: str) -> Result | None:
    """The final state of a fit or reach archive ``dataset`` with a stored path, solved
    again along that path (the continuation of rodsim/app/inverse/continuation.py from a
    cold solve at its first values, then through the rest) on ``scene`` (the archive's,
    at the values found); None for an archive without a path (a cold solve is then the
    same state). EquilibriumFailure if a value of the path has no equilibrium."""
    from rodsim.app.inverse.continuation import ScaledEquilibria

    kind = str(dataset.attrs.get("kind", ""))
    if "evaluation" not in dataset.dims or kind not in ("fit", "reach"):
        return None
    stored = [name for name, variable in dataset.data_vars.items()
              if str(name).endswith("_path") and variable.dims == ("evaluation",)]
    keys = numeric_keys(scene, [str(dataset[name].attrs["scene_key"]) for name in stored])
    path = np.stack([dataset[name].values.astype(float) for name in stored], axis=1)
    rod = str(dataset.attrs[f"{kind}_rod"])
    problem, _, _ = ScaledEquilibria.at_scene_values(scene_with(scene, keys, path[0]), keys,
                                                     rod, integrator)
    for values in path[1:]:
        problem.at(values / problem.scale)
    return problem.result(f"{kind} replayed along its stored path")


def path_solver(dataset: xr.Dataset) -> Callable[[Scene, str], Result] | None:
    """For ``rodsim.app.api.rerun``: the solver (scene, integrator) → Result that replays
    the stored path of the fit or reach archive ``dataset`` (``replayed``); None for an
    archive without one (a cold solve is then the same state)."""
    if "evaluation" not in dataset.dims or dataset.attrs.get("kind") not in ("fit", "reach"):
        return None

    def solver(scene: Scene, integrator: str) -> Result:
        result = replayed(dataset, scene, integrator)
        assert result is not None  # the archive has a path (checked above)
        return result

    return solver

"""A batch case's penalty estimate (``solve_many(..., penalty=True)``; docs/batch.md): the
estimate ``rodsim run`` prints (rodsim/app/trust.py, ``penalty_error``), made per case.

``rodsim run`` re-solves its result warm, by ``static``, with every constraint penalty ×10
(K_P, K_L, K_J, contact stiffness), and reports the largest control-point move times
10/9 in units of the longest rod's length L. A batch makes the same solve with the same
numbers, but the stiffer scene's model is assembled once per process (the stiffer base
scene, ``stiffer_model``) and each case only sets its values on it
(``rodsim.core.model.Model.with_values``, bit for bit a fresh model's), as the cases' own
solves do. When a case key is itself a penalty constant, the stiffer scene of each case is
built from the case (``penalty_error`` itself, a model per case).

Not computed: the dominant kind of penalty that ``rodsim run`` names above the warning
(one more solve per kind). The stiffer solve's wall-time budget is the scene's, at most
``rodsim.app.discretisation.BUDGET_FLOOR`` (``rodsim run``'s too, for a run under half
of it).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from rodsim.app.batch_job import BatchJob, shared_model
from rodsim.app.inverse.parameter_keys import NumericKey, numeric_keys, scene_with

if TYPE_CHECKING:
    from rodsim.core.model import Model
    from rodsim.core.scene import Scene
    from rodsim.solvers.result import Result

__all__ = ["FACTOR", "case_penalty", "record_penalty", "stiffer_model"]

#: The factor on every penalty constant (``rodsim run``'s, ``penalty_error``'s default).
FACTOR = 10.0

#: The process's stiffer model ((scene JSON, keys) → stiffer base scene, its keys, its model,
#: the number of constants scaled, whether a case key is a penalty constant).
_STIFF: dict[tuple[str, tuple[str, ...]], tuple[Scene, list[NumericKey], Model | None, int,
                                                  bool]] = {}


def _penalty_key(key: NumericKey) -> bool:
    """Whether ``key`` names a penalty constant (any of their spellings, by its last part)."""
    from rodsim.app.trust import penalty_constants

    return any(key.path.split(".")[-1] in spellings
               for spellings in penalty_constants().values())


def stiffer_model(job: BatchJob) -> tuple[Scene, list[NumericKey], Model | None, int, bool]:
    """The stiffer base scene (every penalty ×``FACTOR``), its keys, its model (None when
    the scene has no penalty), how many constants were scaled, and whether a case key is a
    penalty constant; built once per process and batch."""
    from rodsim.app.api import load_scene
    from rodsim.app.discretisation import BUDGET_FLOOR
    from rodsim.app.trust import stiffer_scene
    from rodsim.core.model import Model

    cached = _STIFF.get((job.scene_json, job.keys))
    if cached is None:
        base, keys, _ = shared_model(job)
        data, count = stiffer_scene(base, FACTOR)
        data["solver"]["max_wall_time"] = min(float(base.solver.max_wall_time), BUDGET_FLOOR)
        stiff = load_scene(data)
        cached = (stiff, numeric_keys(stiff, job.keys), Model(stiff) if count else None, count,
                  any(_penalty_key(key) for key in keys))
        _STIFF.clear()  # one batch at a time
        _STIFF[job.scene_json, job.keys] = cached
    return cached


def case_penalty(job: BatchJob, case: int, result: Result) -> float | None:
    """The penalty estimate of ``case``'s converged ``result`` [L]: 0 for a scene without
    penalties, None when the stiffer solve fails (the archive's NaN)."""
    import numpy as np

    from rodsim.app.api import solve
    from rodsim.app.trust import penalty_error, penalty_estimate
    from rodsim.solvers import DEFAULT_INTEGRATOR

    stiff, keys, model, count, per_case = stiffer_model(job)
    if count == 0:
        return 0.0
    if per_case:
        error = penalty_error(result, FACTOR).error
        return float(error) if np.isfinite(error) else None
    assert model is not None
    scene = scene_with(stiff, keys, job.values[case])
    stiffer = solve(scene, DEFAULT_INTEGRATOR, model=model.with_values(scene),
                    initial_state=result.state)
    if not stiffer.success:
        return None
    return penalty_estimate(result, stiffer, FACTOR)


def record_penalty(job: BatchJob, case: int, record: dict[str, Any], result: Result) -> None:
    """Add ``case``'s ``penalty_error`` to its record when the batch asks for it."""
    if job.penalty:
        record["penalty_error"] = case_penalty(job, case, result)

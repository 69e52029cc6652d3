"""Warm-started batches (``rodsim.solve_many(..., warm=True)``, ``rodsim batch --warm``;
docs/batch.md, "Warm starts").

A cold case (rodsim/app/batch.py) is solved from rest, as ``rodsim.solve`` solves it alone;
most of its cost is the Newton iterations that bring the rods from rest to the load
(7.2 a case on average on random tdcr-two-segment cases, up to 45). A warm case starts
instead from the equilibrium of a neighbouring case, moved by the tangent predictor
x + (dx/dp) Δp, which costs one force evaluation and one back-substitution with the
factorisation that neighbour's verification already made (J Δx = −F(x; p_new), the first
chord step of the new case; ``rodsim.app.inverse.tracker``'s predictor without its
central differences). It then runs the same ``static`` warm solve as ``rodsim.solve`` with
an ``initial_state``: Newton at full load, polished to round-off (each iteration after the
tolerance must halve the residual), and, should Newton fail from there, the cold solve
from rest within the same run. Measured on random tdcr-two-segment cases at a neighbour
distance of 0.1–0.2 of the cases' ranges: 3–4 Newton iterations instead of 6–45.

Which neighbour: the cases are put in one solve order by a greedy nearest-neighbour path
(``solve_order``) through the cases' values, each key scaled by its range over the table,
starting from case 0 (within groups of ``ORDER_GROUP`` consecutive cases, so that the order
costs O(cases × ORDER_GROUP)). The order is cut into segments of ``SEGMENT`` cases: the
first case of a segment is solved cold, every other one warm from the case before it in
the order (cold too when that one failed). A chunk is a range of positions in the solve
order made of whole segments (``solve_many`` rounds the chunk up to a multiple of
``SEGMENT``; a chunk that started inside a segment would first solve the segment's earlier
cases again, unrecorded). A case's answer therefore depends only on the table, never on the
chunks or the workers: the same table gives the same equilibria bit for bit on every run,
whatever the chunk size and the number of workers.

What a warm case is not: bit for bit the cold solve. Both are Newton roots polished until a
step no longer halves the residual; where the residual is at its floor, such states can
still lie a Newton correction apart: up to 1.0e-9 m (2.6e-9 L) over 1 000 random
tdcr-two-segment cases, median 7e-16 m (docs/benchmarks.md, "Many equilibria: batches").
On a model with several equilibria for one case (a buckled branch), a warm start may reach
another one than the solve from rest: the cold batch is the default for that reason.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from rodsim.app.batch_job import SEGMENT, BatchJob, shape_record, shared_model
from rodsim.app.batch_penalty import record_penalty
from rodsim.app.inverse.parameter_keys import scene_with
from rodsim.app.study_points import solved_record

if TYPE_CHECKING:
    from rodsim.core.model import Model
    from rodsim.core.scene import Scene
    from rodsim.solvers.result import Result

__all__ = ["ORDER_GROUP", "solve_order", "warm_chunk"]

#: Cases whose nearest-neighbour path is found together (the order's cost is quadratic in it).
ORDER_GROUP = 2000

#: What the next case of a segment starts from: the last equilibrium and J factored there.
Previous = tuple[np.ndarray, Callable[[np.ndarray], np.ndarray]]


def solve_order(values: np.ndarray) -> np.ndarray:
    """The solve order of the (cases, keys) table ``values``: a greedy nearest-neighbour path
    in the values scaled by each key's range (a key of one value is left out), from the
    first case of each group of ``ORDER_GROUP`` consecutive cases; ties go to the lower
    case. A permutation of the cases."""
    span = np.ptp(values, axis=0)
    scaled = (values - values.min(axis=0)) / np.where(span > 0.0, span, 1.0)
    order = np.empty(len(values), dtype=np.int64)
    for begin in range(0, len(values), ORDER_GROUP):
        points = scaled[begin:begin + ORDER_GROUP]
        free = np.ones(len(points), dtype=bool)
        current = 0
        for position in range(len(points)):
            order[begin + position] = begin + current
            free[current] = False
            if position + 1 < len(points):
                distance = ((points - points[current]) ** 2).sum(axis=1)
                distance[~free] = np.inf
                current = int(np.argmin(distance))
    return order


def _predicted(integrator: Any, model: Model, previous: Previous | None
               ) -> tuple[np.ndarray | None, int]:
    """The start of a case on ``model`` from the last equilibrium ``previous`` (None: from
    rest): the tangent predictor when the integrator takes one, else that equilibrium
    itself; and the force evaluations it cost (0 or 1)."""
    if previous is None:
        return None, 0
    x, factor = previous
    if not integrator.takes_predictor:
        return x, 0
    force = model.force(x)
    if not np.isfinite(force).all():
        return x, 1
    dx = factor(-force)
    if not np.isfinite(dx).all():
        return x, 1
    return integrator.predicted(model, x, dx), 1


def _warm_case(job: BatchJob, case: int, previous: Previous | None, recorded: bool = True
               ) -> tuple[dict[str, Any], Previous | None]:
    """Solve ``case`` from ``previous`` (None: from rest) with the shared model; the record
    (as ``rodsim.app.batch``'s cold case) and what the next case starts from (None after
    a failure, or when the verification made no factorisation). ``recorded``: the case is
    one of the chunk's (its penalty estimate is made when the batch asks for it)."""
    import time

    from rodsim.solvers import registered_integrators

    kept: list[Previous | None] = [None]

    def solve_case() -> tuple[Scene, Result]:
        started = time.perf_counter()
        base, keys, model = shared_model(job)
        scene = scene_with(base, keys, job.values[case])
        case_model = model.with_values(scene)
        integrator = registered_integrators()[job.integrator].for_scene(scene)
        start, evaluations = _predicted(integrator, case_model, previous)
        result, run = integrator.run(integrator.init(case_model, start, started))
        result.stats["force_evals"] = result.stats.get("force_evals", 0) + evaluations
        factored = run.factored
        if (result.success and factored is not None and factored[2][1] is not None
                and np.array_equal(factored[1], result.state)):
            kept[0] = result.state, factored[2][1]
        return scene, result

    record, solved = solved_record({"case": case}, solve_case)
    if solved is not None:
        shape_record(record, solved[1])
        if recorded:  # a case solved only to start the next one needs no estimate
            record_penalty(job, case, record, solved[1])
    return record, kept[0]


def warm_chunk(job: BatchJob, start: int, end: int) -> dict[str, Any]:
    """The record of positions ``start`` to ``end`` (excluded) of the solve order
    ``job.order``: its cases in that order (module docstring). A chunk that starts inside a
    segment solves the segment's earlier cases first, without recording them."""
    assert job.order is not None
    cases = []
    previous: Previous | None = None
    for position in range(start - start % SEGMENT, end):
        if position % SEGMENT == 0:
            previous = None
        record, previous = _warm_case(job, int(job.order[position]), previous,
                                      position >= start)
        if position >= start:
            cases.append(record)
    return {"start": start, "end": end, "cases": cases}

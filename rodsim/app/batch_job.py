"""A batch's job and what every worker shares (rodsim/app/batch.py; docs/batch.md): the
picklable ``BatchJob`` a chunk is run from, the process's model of the batch's base scene
(built once per process and batch), and a solved case's shape in its record.

``SEGMENT``: a warm batch's cases per segment of its solve order (rodsim/app/batch_warm.py:
the first case of each segment is solved from rest, the others from their predecessor).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from rodsim.app.inverse.parameter_keys import NumericKey, numeric_keys
from rodsim.core.scene import Scene

if TYPE_CHECKING:
    from rodsim.core.model import Model
    from rodsim.solvers.result import Result

__all__ = ["BatchJob", "SEGMENT", "shared_model", "shape_record"]

#: A warm batch's cases per segment (rodsim/app/batch_warm.py).
SEGMENT = 25


@dataclass(frozen=True)
class BatchJob:
    """What a worker needs to run any chunk of a batch (picklable): the base scene as JSON
    and TOML, the integrator, the keys (their full names) and the (cases, keys) values."""

    scene_json: str
    scene_toml: str
    integrator: str
    keys: tuple[str, ...]
    values: np.ndarray
    chunk: int
    #: Warm starts (rodsim/app/batch_warm.py): the solve order, a permutation of the cases,
    #: whose positions the chunks cover; None: cold cases, chunks in case order.
    order: np.ndarray | None = None
    #: Each case's penalty estimate (rodsim/app/batch_penalty.py) is computed and stored.
    penalty: bool = False

    @property
    def warm(self) -> bool:
        return self.order is not None

    def cases_of(self, start: int, end: int) -> list[int]:
        """The cases of the chunk of positions ``start`` to ``end`` (excluded)."""
        if self.order is None:
            return list(range(start, end))
        return [int(case) for case in self.order[start:end]]

    @property
    def cases(self) -> int:
        return len(self.values)

    def chunks(self) -> list[tuple[int, int]]:
        """(first case, end) of every chunk."""
        return [(start, min(start + self.chunk, self.cases))
                for start in range(0, self.cases, self.chunk)]

    def definition(self) -> dict[str, Any]:
        """The parts folder's marker: what a resumed batch must share (the values by their
        SHA-256, their exact bytes)."""
        digest = hashlib.sha256(np.ascontiguousarray(self.values, dtype="<f8").tobytes())
        definition = {"kind": "batch", "base_scene_json": self.scene_json,
                      "base_scene_toml": self.scene_toml, "integrator": self.integrator,
                      "keys": list(self.keys), "cases": self.cases, "chunk": self.chunk,
                      "values_sha256": digest.hexdigest()}
        if self.order is not None:  # the order too: it decides each case's start
            order = hashlib.sha256(np.ascontiguousarray(self.order, dtype="<i8").tobytes())
            definition |= {"warm": True, "segment": SEGMENT,
                           "order_sha256": order.hexdigest()}
        if self.penalty:  # its chunks carry the estimates
            definition["penalty_estimates"] = True
        return definition


#: The process's model of the last batch's base scene ((its JSON, the keys) → scene, keys,
#: model): worker processes keep it across the chunks they run.
_MODELS: dict[tuple[str, tuple[str, ...]], tuple[Scene, list[NumericKey], Model]] = {}


def shared_model(job: BatchJob) -> tuple[Scene, list[NumericKey], Model]:
    """The base scene, its keys and its model, built once per process and batch."""
    from rodsim.core.memory import check_memory
    from rodsim.core.model import Model

    cached = _MODELS.get((job.scene_json, job.keys))
    if cached is None:
        base = Scene.from_json(job.scene_json, job.scene_toml)
        check_memory(base)
        cached = base, numeric_keys(base, job.keys), Model(base)
        _MODELS.clear()  # one batch at a time: no growing cache
        _MODELS[job.scene_json, job.keys] = cached
    return cached


def shape_record(record: dict[str, Any], result: Result) -> None:
    """Add a solved case's control points and segment orientations to its record."""
    record["position"] = np.concatenate([r.positions for r in result.rods.values()]).tolist()
    record["quaternion"] = np.concatenate([r.quaternions
                                           for r in result.rods.values()]).tolist()

"""A study's resolved spec and its grid: what a worker needs to run the points of one size
of a study, and what a study archive stores as ``spec_json`` to re-run them without the
study file (``StudySpec``); the declaration types a study file uses (``Sweep``;
``rodsim.app.study.Study``)."""

from __future__ import annotations

import itertools
import json
from dataclasses import dataclass, fields
from typing import Any

from rodsim.core.scene import Scene

__all__ = ["StudyError", "Sweep", "SweepSpec", "StudySpec", "grid_shape", "grid_points",
           "point_scene"]


class StudyError(ValueError):
    """A study definition, name, size or archive is invalid."""


@dataclass(frozen=True)
class Sweep:
    """One swept scene value: a dimension of the study's Dataset.

    ``key`` is a scene key as for ``--set`` (full dotted path or unambiguous suffix), or a
    tuple of keys swept together (each value is then a tuple with one entry per key);
    ``values`` are the scene values; ``labels`` the coordinate values when the scene values
    are not scalars (term lists, tuples), default the values themselves.
    """

    name: str
    key: str | tuple[str, ...]
    values: tuple[Any, ...]
    units: str = "1"
    long_name: str = ""
    labels: tuple[Any, ...] | None = None

    @property
    def coordinate(self) -> tuple[Any, ...]:
        return self.labels if self.labels is not None else self.values


@dataclass(frozen=True)
class SweepSpec(Sweep):
    """One sweep of a ``StudySpec``, as stored: the fields of ``Sweep``, with
    ``values`` as JSON values (a list where a declaration has a tuple)."""

    def scene_values(self, i: int) -> dict[str, Any]:
        """The scene values of the sweep's ``i``-th point, by scene key."""
        if isinstance(self.key, str):
            return {self.key: self.values[i]}
        return dict(zip(self.key, self.values[i], strict=True))

    def to_dict(self) -> dict[str, Any]:
        """The sweep as a JSON object (the layout of ``spec_json``'s ``sweeps``)."""
        return {"name": self.name,
                "key": self.key if isinstance(self.key, str) else list(self.key),
                "values": [list(v) if isinstance(v, tuple) else v for v in self.values],
                "units": self.units, "long_name": self.long_name,
                "labels": None if self.labels is None else list(self.labels)}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SweepSpec:
        key = data["key"]
        labels = data.get("labels")
        return cls(data["name"], key if isinstance(key, str) else tuple(key),
                   tuple(data["values"]), data.get("units", "1"), data.get("long_name", ""),
                   None if labels is None else tuple(labels))


@dataclass(frozen=True)
class StudySpec:
    """One size of a study, resolved: everything a worker needs to run its points, and what
    a study archive stores as ``spec_json`` (``to_json``) to re-run them without the
    study file. ``from_json`` reads what ``to_json`` (or any earlier rodsim) wrote.

    Attributes
    ----------
    name, title, paper, integrator, reference, plot, history, sigma_points
        As in the ``Study`` declaration.
    size
        ``small`` or ``full``.
    base_scene_json, base_scene_toml
        The resolved base scene (``Scene.to_json``) and its file's text.
    sweeps
        The grid, one ``SweepSpec`` per dimension.
    """

    name: str
    title: str
    paper: str
    size: str
    integrator: str | None
    reference: str | None
    plot: str
    history: bool
    sigma_points: int
    base_scene_json: str
    base_scene_toml: str
    sweeps: tuple[SweepSpec, ...]

    def to_dict(self) -> dict[str, Any]:
        """The spec as a JSON object (the layout of ``spec_json``)."""
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "sweeps"}
        return out | {"sweeps": [sweep.to_dict() for sweep in self.sweeps]}

    def to_json(self) -> str:
        """Canonical JSON (sorted keys): byte for byte what study archives store."""
        return json.dumps(self.to_dict(), sort_keys=True)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> StudySpec:
        """The spec of a JSON object as ``to_dict`` writes it (StudyError if it is not
        one)."""
        try:
            return cls(**{f.name: data[f.name] for f in fields(cls)
                          if f.name not in ("sweeps", "base_scene_toml")},
                       base_scene_toml=data.get("base_scene_toml", ""),
                       sweeps=tuple(SweepSpec.from_dict(s) for s in data["sweeps"]))
        except (KeyError, TypeError, AttributeError) as exc:
            raise StudyError(f"not a study spec ({type(exc).__name__}: {exc})") from None

    @classmethod
    def from_json(cls, text: str) -> StudySpec:
        """The spec stored as ``text`` (an archive's ``spec_json``)."""
        try:
            data = json.loads(text)
        except (ValueError, RecursionError):
            raise StudyError("study spec: not valid JSON, or nested too deeply") from None
        if not isinstance(data, dict):
            raise StudyError(f"study spec: not a JSON object (got {type(data).__name__})")
        return cls.from_dict(data)

    def base_scene(self) -> Scene:
        """The resolved base scene."""
        return Scene.from_json(self.base_scene_json, self.base_scene_toml)

    @property
    def rod_names(self) -> list[str]:
        """The base scene's rods, in scene order."""
        return list(json.loads(self.base_scene_json)["rods"])


def grid_shape(spec: StudySpec) -> tuple[int, ...]:
    return tuple(len(s.values) for s in spec.sweeps)


def grid_points(spec: StudySpec) -> list[tuple[int, ...]]:
    """Every point of the grid as a tuple of indices, in C order."""
    return list(itertools.product(*(range(n) for n in grid_shape(spec))))


def point_scene(spec: StudySpec, index: tuple[int, ...]) -> Scene:
    """The scene of one grid point: the base scene with each sweep's value set."""
    values: dict[str, Any] = {}
    for sweep, i in zip(spec.sweeps, index, strict=True):
        values.update(sweep.scene_values(i))
    return spec.base_scene().with_values(values)

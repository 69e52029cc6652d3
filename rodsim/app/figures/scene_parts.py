"""What a figure of one state draws, read from an archive alone: the rods, the tendons'
paths, the obstacles, the loads and the contact forces (the run figure, the contact figure
and the 3-D view share it).

- A rod tendon (``coupling = "conserving"`` or ``"one_way"``) is drawn by its control
  points; a string tendon (rodsim/core/routing.py) by its routing points
  r(s) + ρ_y(s) d1(s) + ρ_z(s) d2(s) at the catheter's nodes between its start and end and
  at both ends (the termination is the last), with the directors of the quaternion
  interpolated linearly in s between the segment midpoints (clamped to the end segments).
- A string tendon on spacer disks (``spacers = true``) puts a disk on its catheter at each
  of its routing points: centred on r(s), normal to the section's d3 there, its radius the
  tendon's ``disk_radius`` when the scene gives one, else
  ``rodsim.app.figures.spacer_disks.DISK_MARGIN`` times its routing offset at s; the
  largest of those of the tendons on spacers that pass there (one disk per arc length and
  catheter).
- Loads are the rod and tendon terms that push (``figure_layer = "load"``): a tip load (mass
  and force) at the tip, each point load's force and moment where it acts, a distributed
  load's resultant at the middle of each span, gravity's total weight at the rod's middle
  node, and a tendon's actuation force at the end of the tendon it pulls.
- Every registered term says how it is drawn by its ``Term.figure_layer``
  (``term_drawings``; tests/test_term_contract.py walks the registry).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import Any

import numpy as np
import xarray as xr

from rodsim.app.figures.spacer_disks import DISK_MARGIN, Disk
from rodsim.core.obstacles import Obstacle, build_obstacle
from rodsim.core.rod.quaternion import directors
from rodsim.core.routing import Routing, string_span
from rodsim.core.terms import registered_terms
from rodsim.core.terms._dead_load import unit_direction
from rodsim.core.terms.base import FIGURE_LAYERS

__all__ = ["term_drawings", "FRAME_DIMENSIONS", "SHAPE", "TENDON", "LOAD", "CONTACT",
           "Arrow", "TendonPath", "SceneParts", "Disk", "scene_parts", "at_step"]

#: How a term shows in a figure (its ``rodsim.core.terms.base.Term.figure_layer``): in the
#: rods' shape, as a tendon's path, as load arrows, or as the contact forces on the obstacles.
SHAPE, TENDON, LOAD, CONTACT = FIGURE_LAYERS


def term_drawings() -> dict[str, str]:
    """How each registered term is drawn, by name: its declared ``figure_layer`` (every term
    declares one, tests/test_term_contract.py)."""
    return {name: kind.figure_layer for name, kind in registered_terms().items()}


@dataclass(frozen=True)
class Arrow:
    """A force [N] or a moment [N m] (``moment``) at a point [m]; ``gid`` names it in the
    figure (``load:<owner>:<term>`` or ``contact:<rod>``)."""

    gid: str
    label: str
    point: np.ndarray
    vector: np.ndarray
    moment: bool = False


@dataclass(frozen=True)
class TendonPath:
    """A tendon's path (P, 3) [m]: a string tendon's routing points (``string``, at rest arc
    lengths ``s`` (P,) [m] along its catheter) or a rod tendon's control points; the
    termination is the last point."""

    name: str
    points: np.ndarray
    string: bool
    s: np.ndarray | None = None


@dataclass(frozen=True)
class SceneParts:
    """One state of an archive, ready to draw (see the module docstring)."""

    title: str
    rods: dict[str, np.ndarray]
    radii: dict[str, float]
    tendons: list[TendonPath]
    obstacles: list[Obstacle]
    loads: list[Arrow] = field(default_factory=list)
    contacts: list[Arrow] = field(default_factory=list)
    disks: list[Disk] = field(default_factory=list)

    def points(self) -> np.ndarray:
        """Every control point and tendon point (n, 3): what the view must contain."""
        parts = [*self.rods.values(), *(t.points for t in self.tendons)]
        return np.concatenate(parts) if parts else np.zeros((0, 3))


#: The dimensions along which an archive holds several states: a track's steps, a
#: trajectory's output times.
FRAME_DIMENSIONS = ("step", "time")


def at_step(variable: xr.DataArray, step: int | None) -> np.ndarray:
    """``variable`` at a track's step or a trajectory's output time ``step`` (the last by
    default); a variable without either dimension as it is."""
    for dimension in FRAME_DIMENSIONS:
        if dimension in variable.dims:
            return variable.isel({dimension: -1 if step is None else step}).values
    return variable.values


#: Largest |coordinate| of a shape the figures draw [m]: beyond it their squared lengths
#: overflow (a fuzzed archive's 1e300 m did); no scene comes near it. Larger and infinite
#: coordinates are left out as NaN ones are.
DRAWABLE = 1e100


def _arc_length(positions: np.ndarray) -> np.ndarray:
    """Arc length along the nodes [m]: the routing's s where an archive has no ``s`` (the
    contract does not require it)."""
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(positions, axis=0),
                                                           axis=1))])


def scene_parts(ds: xr.Dataset, step: int | None = None) -> SceneParts:
    """The parts of run, fit, reach, track or trajectory archive ``ds`` (a track's step
    ``step`` or a trajectory's output time of that index, the last by default; a
    track's loads are drawn with the values of that step, a trajectory's with its programs'
    values at that time: ``rodsim.app.figures.state_scene``)."""
    from rodsim.app.figures.state_scene import state_scene

    scene = state_scene(ds, step)
    raw = json.loads(scene.to_json())
    positions = at_step(ds["position"], step)
    # A coordinate that is infinite or beyond DRAWABLE is left out as a NaN one is (the
    # figures draw a shape without its non-finite points).
    positions = np.where(np.abs(positions) < DRAWABLE, positions, np.nan)
    node_rod = ds["rod"].values.astype(str)
    quaternions = at_step(ds["quaternion"], step) if "quaternion" in ds else None
    segment_rod = ds["segment_rod"].values.astype(str) if "segment_rod" in ds else None
    tendons_raw = raw.get("tendons", {}) or {}
    rods = {name: positions[node_rod == name] for name in dict.fromkeys(node_rod)}
    frames = {}  # none where the archive has no segment_s (the contract does not require it)
    if quaternions is not None and segment_rod is not None and "segment_s" in ds:
        for name in rods:
            mine = segment_rod == name
            frames[name] = (ds["segment_s"].values[mine], quaternions[mine])
    node_s = {name: (ds["s"].values[node_rod == name] if "s" in ds
                     else _arc_length(rods[name])) for name in rods}
    paths: list[TendonPath] = []
    holes: dict[str, list[tuple[np.ndarray, np.ndarray, float]]] = {}
    for name, table in tendons_raw.items():
        if name in rods:
            paths.append(TendonPath(name, rods.pop(name), string=False))
        elif "tendon_string" in table and table["catheter"] in frames:
            catheter = table["catheter"]
            points, s, offset = _string_path(
                table, rods[catheter], node_s[catheter], *frames[catheter],
                float(raw["rods"][catheter]["length"]))
            paths.append(TendonPath(name, points, string=True, s=s))
            if table["tendon_string"].get("spacers"):
                given = float(table["tendon_string"].get("disk_radius", 0.0))
                holes.setdefault(catheter, []).append((s, offset, given))
    disks = [disk for catheter, found in holes.items()
             for disk in _disks(catheter, found, rods[catheter], node_s[catheter],
                                *frames[catheter])]
    obstacles = [build_obstacle(name, table)
                 for name, table in scene.data.get("obstacles", {}).items()]
    rods_raw = raw["rods"]
    loads = [arrow for name, table in rods_raw.items() if name in rods
             for arrow in _rod_loads(name, table, rods[name], node_s[name],
                                     frames.get(name))]
    for name, table in tendons_raw.items():
        if "tendon_actuation" in table.get("terms", ()):
            loads.extend(_actuation(name, table, paths, frames.get(table["catheter"])))
    contacts: list[Arrow] = []
    if "contact_force" in ds:
        forces = at_step(ds["contact_force"], step)
        contacts = [Arrow(f"contact:{node_rod[i]}", "contact force", positions[i], forces[i])
                    for i in np.flatnonzero(np.linalg.norm(forces, axis=1) > 0.0)]
    radii = {name: float(rods_raw[name]["radius"]) for name in rods}
    return SceneParts(str(ds.attrs.get("title", scene.name)), rods, radii, paths, obstacles,
                      loads, contacts, disks)


def _disks(catheter: str, holes: list[tuple[np.ndarray, np.ndarray, float]],
           nodes: np.ndarray, node_s: np.ndarray, knots: np.ndarray,
           quaternions: np.ndarray) -> list[Disk]:
    """The spacer disks of ``catheter`` at the arc lengths of the routing points
    ``holes`` (each tendon's s, |ρ(s)| and disk_radius, 0 when not given): one per arc
    length, as large as the largest any of its tendons asks (module docstring)."""
    s = np.concatenate([found for found, _, _ in holes])
    offset = np.concatenate([rho for _, rho, _ in holes])
    given = np.concatenate([np.full(len(found), radius) for found, _, radius in holes])
    wanted = np.where(given > 0.0, given, DISK_MARGIN * offset)
    at = np.unique(s)
    largest = np.array([wanted[s == x].max() for x in at])
    # the radius drawn is a disk_radius when the largest asked is one
    sized = [bool(given[s == x][np.argmax(wanted[s == x])] > 0.0) for x in at]
    centres = _along(at, node_s, nodes)
    normals = _frame_at(at, knots, quaternions)[:, 2]
    return [Disk(catheter, float(x), c, n, float(r), by_scene)
            for x, c, n, r, by_scene in zip(at, centres, normals, largest, sized, strict=True)]


def _frame_at(s: np.ndarray, knots: np.ndarray, quaternions: np.ndarray) -> np.ndarray:
    """Directors (len(s), 3, 3) of the quaternion interpolated in s between the segment
    midpoints ``knots`` (clamped beyond the first and last)."""
    if len(knots) == 1:
        q = np.repeat(quaternions, len(s), axis=0)
    else:
        k = np.clip(np.searchsorted(knots, s, side="right") - 1, 0, len(knots) - 2)
        w = np.clip((s - knots[k]) / (knots[k + 1] - knots[k]), 0.0, 1.0)[:, None]
        q = (1.0 - w) * quaternions[k] + w * quaternions[k + 1]
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    return directors(q)


def _along(s: np.ndarray, node_s: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """The centerline r(s) (len(s), 3), linear between the control points."""
    return np.stack([np.interp(s, node_s, nodes[:, k]) for k in range(3)], axis=1)


def _string_path(table: dict[str, Any], nodes: np.ndarray, node_s: np.ndarray,
                 knots: np.ndarray, quaternions: np.ndarray, length: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The routing points (P, 3) [m], their rest arc lengths (P,) [m] and their
    offsets |ρ(s)| (P,) [m] from the centerline."""
    string = SimpleNamespace(**table["tendon_string"])
    routing = Routing.of(float(table["offset"]), table["direction"], string)
    start, end = string_span(string, length)
    h = float(np.min(np.diff(node_s))) if len(node_s) > 1 else length
    inner = node_s[(node_s > start + 0.25 * h) & (node_s < end - 0.25 * h)]
    s = np.concatenate([[start], inner, [end]])
    frame = _frame_at(s, knots, quaternions)
    rho = routing.offsets(s)
    return (_along(s, node_s, nodes) + rho[:, 0:1] * frame[:, 0] + rho[:, 1:2] * frame[:, 1],
            s, np.hypot(rho[:, 0], rho[:, 1]))


def _rod_loads(name: str, table: dict[str, Any], nodes: np.ndarray, node_s: np.ndarray,
               frames: tuple[np.ndarray, np.ndarray] | None) -> list[Arrow]:
    """The load arrows of rod ``name``'s load terms (module docstring)."""
    terms = table.get("terms", ())
    out = []
    if "tip_load" in terms:
        o = table["tip_load"]
        force = np.asarray(o["force"], dtype=float) + o["mass"] * o["gravity"] * unit_direction(
            o.get("direction", [0.0, -1.0, 0.0]), f"rods.{name}.tip_load.direction")
        label = f"tip load ({o['mass'] * 1e3:.3g} g)" if o["mass"] else "tip force"
        out.append(Arrow(f"load:{name}:tip_load", label, nodes[-1], force))
    if "point_loads" in terms:
        for load in table["point_loads"]["loads"]:
            s = np.array([float(load["s"])])
            point = _along(s, node_s, nodes)[0]
            force, moment = (np.asarray(load[k], dtype=float) for k in ("force", "moment"))
            if load.get("frame") == "body" and frames is not None:
                d = _frame_at(s, *frames)[0]
                force, moment = force @ d, moment @ d
            out.append(Arrow(f"load:{name}:point_loads", "point force", point, force))
            if np.any(moment):
                out.append(Arrow(f"load:{name}:point_loads", "point moment", point, moment,
                                 moment=True))
    if "distributed_load" in terms:
        o = table["distributed_load"]
        spans = [{"start": node_s[0], "end": node_s[-1], "force_per_length":
                  o["force_per_length"]}, *o["spans"]]
        for span in spans:
            q = np.asarray(span["force_per_length"], dtype=float)
            middle = np.array([0.5 * (span["start"] + span["end"])])
            out.append(Arrow(f"load:{name}:distributed_load",
                             "distributed load (resultant of a span)",
                             _along(middle, node_s, nodes)[0],
                             q * (span["end"] - span["start"])))
    if "gravity" in terms:
        weight = _mass(table) * float(table["gravity"]["gravity"])
        direction = unit_direction(table["gravity"].get("direction", [0.0, -1.0, 0.0]),
                                   f"rods.{name}.gravity.direction")  # older archives: −y
        out.append(Arrow(f"load:{name}:gravity", "weight (total)", nodes[len(nodes) // 2],
                         weight * direction))
    return [arrow for arrow in out if np.any(arrow.vector)]


def _mass(table: dict[str, Any]) -> float:
    """The rod's mass ρ A L [kg] (with sections, summed over them; a section's area 0
    means the annulus between its inner radius and the rod's)."""
    radius, density, length = (float(table[k]) for k in ("radius", "density", "length"))
    sections = table.get("sections") or ()
    if not sections:
        return density * math.pi * radius**2 * length
    total = 0.0
    for section in sections:
        area = float(section.get("area") or 0.0) or math.pi * (
            radius**2 - float(section.get("inner_radius") or 0.0) ** 2)
        total += density * area * (float(section["end"]) - float(section["start"]))
    return total


def _actuation(name: str, table: dict[str, Any], paths: list[TendonPath],
               catheter: tuple[np.ndarray, np.ndarray] | None) -> list[Arrow]:
    """The actuation force F_A on rod tendon ``name``: at its tip along −d3 of the
    catheter's last segment (distal), or at its base along −d3 of the catheter's first
    (proximal): rodsim/core/terms/tendon_actuation.py."""
    path = next((p for p in paths if p.name == name), None)
    if path is None or catheter is None:
        return []
    o = table["tendon_actuation"]
    distal = o["point"] == "distal"
    d3 = directors(catheter[1][-1 if distal else 0] / np.linalg.norm(
        catheter[1][-1 if distal else 0]))[2]
    return [Arrow(f"load:{name}:tendon_actuation", "actuation F_A",
                  path.points[-1 if distal else 0], -float(o["force"]) * d3)]

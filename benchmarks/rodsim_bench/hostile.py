"""Benchmark ``hostile``: a seeded family of hostile command lines, each run as its own
process, over the surfaces where rodsim once crashed, hung or answered wrongly (issue 37):
helix pitch against N, tendon ends anywhere along (and beyond) the catheter, routing
ramped per track step, obstacles through the rest state (a plane moved across a catheter,
and a guidewire laid straight through a curved vessel), supports pushed into obstacles,
joints off the nodes, sections in any order and stiffness, elastic bases from limp to rigid.

Every try is ``python -m rodsim run|track ...`` with a wall-time limit, sorted by outcome:

- ``refused``: exit 2 with one line on stderr (bad input said clearly) — fine;
- ``failed``: exit 1 with its message (a solver failure said clearly) — fine;
- ``solved``: exit 0. A ``run`` that solved is checked in this process against the same
  scene at twice the nodes (2N − 1) and with a second integrator (``static``, or ``ida``
  when the first was static). It ``disagrees`` when the refined tip is farther than
  :data:`DISAGREEMENT` L and three times the discretisation error the run itself stated
  (its archive's ``discretisation_error``: a coarse run that warned of its error is not a
  wrong success), or when the second integrator's tip is farther than :data:`DISAGREEMENT`
  L — a wrong success, or two equilibria of a scene that has several (a human reads the
  table's detail);
- ``traceback``, ``hang`` (over the limit), ``multi-line`` (exit 2 with more than one line)
  and ``crash`` (any other exit, a signal) — defects.

Writes ``hostile-<size>.json`` and ``.md``: the counts per surface and outcome, and every
defect and disagreement with its command line. Nothing is asserted: the aim (issue 37) is
0 tracebacks, 0 hangs and 0 wrong successes over ≥ 300 tries (``--size full``).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

import rodsim
from rodsim.solvers.base import Progress
from rodsim_bench.machine import machine, write_report

__all__ = ["run", "SURFACES", "classify", "toml_text"]

#: Tries per size.
SIZES = {"small": 6, "full": 320}
#: Wall-time limit of one try [s]: far above any try's honest cost on a loaded machine.
LIMIT = 120.0
#: A solved run whose tip moves more than this times the longest rod under a doubled N or
#: a second integrator is reported as a disagreement.
DISAGREEMENT = 1e-2

#: A try: (surface, rodsim arguments, scene files to write {name: TOML text}).
Try = tuple[str, list[str], dict[str, str]]


def toml_text(table: dict[str, Any], prefix: str = "") -> str:
    """A scene dict as TOML (numbers, strings, booleans, lists of them, nested tables and
    lists of tables): what the harness writes for its generated scenes."""

    def value(item: Any) -> str:
        if isinstance(item, bool):
            return "true" if item else "false"
        if isinstance(item, str):
            return '"' + item.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(item, list | tuple):
            return "[" + ", ".join(value(v) for v in item) + "]"
        return repr(float(item)) if isinstance(item, float) else str(item)

    lines: list[str] = []
    tables: list[tuple[str, dict[str, Any], bool]] = []  # (key, table, one of an array)
    for key, item in table.items():
        if isinstance(item, dict):
            tables.append((key, item, False))
        elif isinstance(item, list) and item and all(isinstance(v, dict) for v in item):
            tables.extend((key, v, True) for v in item)
        else:
            lines.append(f"{key} = {value(item)}")
    text = "\n".join(lines) + ("\n" if lines else "")
    for key, sub, array in tables:
        name = f"{prefix}{key}"
        text += f"\n{'[[' + name + ']]' if array else '[' + name + ']'}\n" + toml_text(
            sub, f"{name}.")
    return text


def _rod(rng: np.random.Generator, **values: Any) -> dict[str, Any]:
    """A user's rod: a polymer catheter, a nitinol or a steel wire, at random."""
    modulus, radius = [(5e7, 1.5e-3), (6e10, 4e-4), (2e11, 3e-4)][rng.integers(3)]
    return {"length": float(rng.uniform(0.05, 0.3)), "radius": radius,
            "youngs_modulus": modulus, "density": 1100.0, "nodes": int(rng.integers(5, 42)),
            "terms": ["stretch", "bend_twist", "centerline", "tip_load"],
            "tip_load": {"force": [0.0, -float(10 ** rng.uniform(-4, 0)), 0.0]}} | values


def _helix(rng: np.random.Generator) -> Try:
    return ("helix pitch and N", ["run", "catheter-helical",
                                  "--set", f"helix_pitch={rng.uniform(0.002, 0.4):.4g}",
                                  "--set", f"helix_radius={rng.uniform(0.0005, 0.0075):.4g}",
                                  "--set", f"nodes={rng.choice([6, 11, 21, 41, 81])}"], {})


def _tendon_end(rng: np.random.Generator) -> Try:
    return ("tendon ends", ["run", "catheter-pull-ring",
                            "--set", f"wire_up.tendon_string.end={rng.uniform(-0.02, 0.15):.4g}",
                            "--set", f"wire_up.tendon_string.tension={rng.uniform(0, 5):.3g}",
                            "--set", f"nodes={rng.choice([6, 11, 21, 41])}"], {})


def _routing_ramp(rng: np.random.Generator) -> Try:
    start, stop = rng.uniform(0.0005, 0.012, size=2)
    return ("routing ramped per step", ["track", "catheter-helical",
                                        "--set", "nodes=21", "--ramp",
                                        f"helix_radius={start:.4g}:{stop:.4g}:3"], {})


def _obstacle(rng: np.random.Generator) -> Try:
    y = rng.uniform(-0.006, 0.006)
    normal = [0.0, float(rng.choice([-1.0, 1.0])), 0.0]
    return ("obstacles through the rest state", [
        "run", "tip-on-tissue", "--set", f"obstacles.tissue.point=[0, {y:.4g}, 0]",
        "--set", f"obstacles.tissue.normal={normal}",
        "--integrator", str(rng.choice(["static", "ida", "cvode"]))], {})


def _support_into_obstacle(rng: np.random.Generator) -> Try:
    scene = {"name": "hostile-support",
             "rods": {"catheter": _rod(rng) | {"supports": {"tip": {
                 "s": 0.0, "displacement": [0.0, float(rng.uniform(-0.02, 0.02)), 0.0]}}}},
             "obstacles": {"wall": {"type": "plane", "rods": ["catheter"],
                                    "point": [0.0, float(rng.uniform(-0.01, 0.01)), 0.0],
                                    "normal": [0.0, -1.0, 0.0]}}}
    rod = scene["rods"]["catheter"]
    rod["supports"]["tip"]["s"] = rod["length"]
    return ("supports into obstacles", ["run", "scene.toml"], {"scene.toml": toml_text(scene)})


def _joint(rng: np.random.Generator) -> Try:
    base, joined = _rod(rng), _rod(rng)
    s = float(rng.choice([base["length"], rng.uniform(0, base["length"])]))
    joined |= {"clamp": "free", "terms": [*joined["terms"], "joint"],
               "joint": {"rod": "base", "s": s,
                         "orientation": bool(rng.integers(2))}}
    scene = {"name": "hostile-joint", "rods": {"base": base, "joined": joined}}
    return ("joints", ["run", "scene.toml"], {"scene.toml": toml_text(scene)})


def _sections(rng: np.random.Generator) -> Try:
    """Spans that cover the rod (as a user writes them), each changing one property by a
    factor 1e-3 to 10; one try in four then broken: a gap, a reversed span or an end past
    the rod."""
    rod = _rod(rng)
    cuts = np.sort(rng.uniform(0.0, rod["length"], size=int(rng.integers(0, 3))))
    edges = [0.0, *cuts.tolist(), rod["length"]]
    scales = {"youngs_modulus": rod["youngs_modulus"], "radius": rod["radius"],
              "density": rod["density"]}
    sections = []
    for start, end in zip(edges[:-1], edges[1:], strict=True):
        key = str(rng.choice(list(scales)))
        sections.append({"start": start, "end": end,
                         key: float(10 ** rng.uniform(-3, 1)) * scales[key]})
    if rng.random() < 0.25:
        broken = sections[int(rng.integers(len(sections)))]
        how = int(rng.integers(3))
        if how == 0:
            broken["start"] += 0.1 * (broken["end"] - broken["start"])
        elif how == 1:
            broken["start"], broken["end"] = broken["end"], broken["start"]
        else:
            broken["end"] *= 1.5
    rod["sections"] = sections
    return ("sections", ["run", "scene.toml"],
            {"scene.toml": toml_text({"name": "hostile-sections", "rods": {"rod": rod}})})


def _elastic_base(rng: np.random.Generator) -> Try:
    rod = _rod(rng, clamp="elastic")
    rod["base"] = {"translational_stiffness": float(10 ** rng.uniform(-6, 9)),
                   "rotational_stiffness": float(10 ** rng.uniform(-8, 4)),
                   "torsional_stiffness": float(10 ** rng.uniform(-8, 4))}
    return ("elastic bases", ["run", "scene.toml"],
            {"scene.toml": toml_text({"name": "hostile-base", "rods": {"rod": rod}})})


#: The surfaces, each a generator of tries.
SURFACES: tuple[Callable[[np.random.Generator], Try], ...] = (
    _helix, _tendon_end, _routing_ramp, _obstacle, _support_into_obstacle, _joint, _sections,
    _elastic_base)

#: Tries of ``_vessel_through_rest`` per size, after the surfaces' tries and from their own
#: seed (``VESSEL_SEED``), so the surfaces' tries stay those of earlier reports.
VESSEL_TRIES = {"small": 2, "full": 12}
VESSEL_SEED = 3737


def vessel_csv(straight: float = 0.05, bend: float = 0.03, exit_length: float = 0.04,
               lumen: float = 0.0015) -> str:
    """A user's vessel as a csv centerline (x,y,z,radius): ``straight`` along +x, a 90-degree
    bend of radius ``bend`` toward +y, ``exit_length`` along +y (the user guidewire's
    vessel90.csv: 50 mm, 30 mm, 40 mm, lumen 1.5 mm), points every 5 mm on the straights
    and every 5 degrees on the bend."""
    rows = [(x, 0.0) for x in np.arange(0.0, straight, 0.005)]
    angles = np.radians(np.arange(0.0, 90.0, 5.0))
    rows += [(straight + bend * np.sin(a), bend * (1.0 - np.cos(a))) for a in angles]
    rows += [(straight + bend, bend + y) for y in np.arange(0.0, exit_length + 1e-9, 0.005)]
    return "x,y,z,radius\n" + "".join(f"{x:.6f},{y:.6f},0.000000,{lumen}\n" for x, y in rows)


def _vessel_through_rest(rng: np.random.Generator) -> Try:
    """A user's 0.014-inch nitinol guidewire laid straight through a 90-degree vessel: its
    rest shape leaves the vessel at the bend (cvode once settled there folded through itself
    with exit 0). Any integrator; ida is given 60 s (it spent its budget there until a run
    from a rest shape through a wall was judged once the contact had had its chance,
    rodsim/core/contact_validity.py: it now fails in a few seconds)."""
    integrator = str(rng.choice(["static", "cvode", "ida"]))
    scene = {"name": "hostile-vessel", "rods": {"wire": {
        "length": float(rng.uniform(0.17, 0.25)), "radius": 0.000178,
        "youngs_modulus": 60e9, "density": 6450.0, "nodes": int(rng.choice([41, 61, 81])),
        "origin": [-0.1, 0.0, 0.0]}},
        "obstacles": {"vessel": {"type": "tube", "rods": ["wire"], "centerline": "csv",
                                 "file": "vessel.csv"}}}
    arguments = ["run", "scene.toml", "--integrator", integrator]
    if integrator == "ida":
        arguments += ["--set", "max_wall_time=60"]
    return ("obstacles through the rest state", arguments,
            {"scene.toml": toml_text(scene), "vessel.csv": vessel_csv()})


def classify(code: int | None, stderr: str) -> str:
    """The outcome of a try from its exit code (None: over the limit) and stderr."""
    if code is None:
        return "hang"
    if "Traceback (most recent call last)" in stderr:
        return "traceback"
    lines = [line for line in stderr.splitlines()
             if line.strip() and not line.startswith("rodsim: warning")]
    if code == 2:
        return "refused" if len(lines) == 1 else "multi-line"
    return {0: "solved", 1: "failed"}.get(code, "crash")


def _tip_gap(folder: Path, arguments: list[str], stated: float) -> str:
    """'' when the solved run agrees with twice its nodes (within :data:`DISAGREEMENT` L or
    three times its ``stated`` discretisation error [L]) and with a second integrator
    (within :data:`DISAGREEMENT` L); else what disagreed."""
    scene_name = str(folder / arguments[1]) if arguments[1].endswith(".toml") else arguments[1]
    overrides = [arguments[k + 1] for k, word in enumerate(arguments) if word == "--set"]
    chosen = [arguments[k + 1] for k, word in enumerate(arguments) if word == "--integrator"]
    scene = rodsim.load_scene(scene_name, overrides)
    integrator = chosen[0] if chosen else scene.solver.integrator
    length = max(rod.length for rod in scene.rods.values())
    first = rodsim.solve(scene, integrator)
    refined = scene.with_values({f"rods.{name}.nodes": 2 * rod.nodes - 1
                                 for name, rod in scene.rods.items()})
    checks = {"2N - 1 nodes": rodsim.solve(refined, integrator),
              "second integrator": rodsim.solve(scene, "ida" if integrator == "static"
                                                else "static")}
    gaps = []
    for label, other in checks.items():
        if not other.success:
            continue  # the check could not solve it: no verdict from it
        gap = max(float(np.linalg.norm(first.tip(name) - other.tip(name))) for name in scene.rods)
        allowed = max(DISAGREEMENT, 3.0 * stated) if label == "2N - 1 nodes" else DISAGREEMENT
        if gap > allowed * length:
            gaps.append(f"{label}: tip {gap / length:.2g} L away (stated discretisation "
                        f"error {stated:.2g} L)")
    return "; ".join(gaps)


def run(size: str, output_dir: Path, progress: Progress) -> list[Path]:
    rng = np.random.default_rng(37)
    tries = [SURFACES[k % len(SURFACES)](rng) for k in range(SIZES[size])]
    vessel_rng = np.random.default_rng(VESSEL_SEED)
    tries += [_vessel_through_rest(vessel_rng) for _ in range(VESSEL_TRIES[size])]
    rows = []
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    for k, (surface, arguments, files) in enumerate(tries):
        progress(k / len(tries), f"hostile: {surface}")
        with tempfile.TemporaryDirectory() as folder:
            for name, text in files.items():
                (Path(folder) / name).write_text(text)
            command = [sys.executable, "-m", "rodsim", *arguments, "-o",
                       str(Path(folder) / "out.nc")]
            try:
                done = subprocess.run(command, cwd=folder, env=env, capture_output=True,
                                      text=True, timeout=LIMIT, check=False)
                code, stderr = done.returncode, done.stderr
            except subprocess.TimeoutExpired:
                code, stderr = None, ""
            outcome = classify(code, stderr)
            detail = stderr.strip().splitlines()[-1][:200] if stderr.strip() else ""
            if outcome == "solved" and arguments[0] == "run":
                with xr.open_dataset(Path(folder) / "out.nc") as archive:
                    stated = float(archive.attrs.get("discretisation_error", 0.0))
                gap = _tip_gap(Path(folder), arguments, 0.0 if np.isnan(stated) else stated)
                if gap:
                    outcome, detail = "disagrees", gap
            rows.append({"surface": surface, "arguments": arguments, "files": files,
                         "outcome": outcome, "detail": detail})
    report = {"benchmark": "hostile", "size": size, "machine": machine(), "tries": rows,
              "limit_s": LIMIT}
    return write_report(report, markdown(report), output_dir / f"hostile-{size}")


DEFECTS = ("traceback", "hang", "multi-line", "crash")


def markdown(report: dict) -> str:
    m = report["machine"]
    rows = report["tries"]
    outcomes = ("refused", "failed", "solved", "disagrees", *DEFECTS)
    counts = Counter((row["surface"], row["outcome"]) for row in rows)
    surfaces = list(dict.fromkeys(row["surface"] for row in rows))
    lines = [f"# Hostile command lines ({report['size']})", "",
             f"{m['cpu']}, {m['cores_available']} cores, Python {m['python']}, commit "
             f"{m['git_commit'][:10]}, {m['date']}. {len(rows)} tries, each its own process "
             f"(limit {report['limit_s']:.0f} s); seeded (37).", "",
             "| surface | " + " | ".join(outcomes) + " |",
             "|---|" + "--:|" * len(outcomes)]
    for surface in surfaces:
        lines.append(f"| {surface} | " + " | ".join(str(counts[(surface, o)]) for o in outcomes)
                     + " |")
    lines.append("| all | " + " | ".join(str(sum(row["outcome"] == o for row in rows))
                                         for o in outcomes) + " |")
    flagged = [row for row in rows if row["outcome"] in (*DEFECTS, "disagrees")]
    if flagged:
        lines += ["", "## Defects and disagreements", ""]
        for row in flagged:
            lines.append(f"- **{row['outcome']}** ({row['surface']}): `rodsim "
                         f"{' '.join(row['arguments'])}` — {row['detail']}")
    return "\n".join(lines) + "\n"

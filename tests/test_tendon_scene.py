"""Tendon scenes as scenes: no tendon code in single-rod runs, archives that hold every rod,
and clear one-line errors for bad [tendons.<rod>] input."""

from __future__ import annotations

import copy
import functools
import inspect
import json
import sys
from collections import Counter

import numpy as np
import pytest
import xarray as xr

import rodsim
import rodsim.core.tendon
from rodsim.app.api import rerun
from rodsim.core.base_places import registered_base_places
from rodsim.core.scene import SceneError, scene_paths
from rodsim.core.terms import registered_terms
from rodsim.core.terms.base import TendonTerm, Term
from rodsim.io.archive import read_dataset, write_dataset
from rodsim.io.run_dataset import run_dataset

# ------------------------------------------------- (a) a single-rod scene runs no tendon code


def _wrap(counts: Counter, label: str, function):
    @functools.wraps(function)
    def counted(*args, **kwargs):
        counts[label] += 1
        return function(*args, **kwargs)

    return counted


def _instrument_class(monkeypatch, counts: Counter, cls: type, stop: tuple[type, ...]) -> int:
    """Wrap every method of ``cls`` (own and inherited up to, excluding, ``stop``) with a
    call counter; returns how many were wrapped."""
    names = set()
    for base in cls.__mro__:
        if base in stop:
            break
        names |= {n for n in vars(base) if not n.startswith("__") or n == "__init__"}
    wrapped = 0
    for name in sorted(names):
        raw = inspect.getattr_static(cls, name)
        label = f"{cls.__name__}.{name}"
        if isinstance(raw, staticmethod):
            new = staticmethod(_wrap(counts, label, raw.__func__))
        elif isinstance(raw, classmethod):
            new = classmethod(_wrap(counts, label, raw.__func__))
        elif isinstance(raw, property):
            new = property(_wrap(counts, label, raw.fget))
        elif inspect.isfunction(raw):
            new = _wrap(counts, label, raw)
        else:
            continue  # class attributes (name, parameters, ...)
        monkeypatch.setattr(cls, name, new)
        wrapped += 1
    return wrapped


def instrument_tendon_code(monkeypatch) -> tuple[Counter, list[str]]:
    """Count calls into every method of every TendonTerm subclass in the registry (and the
    helper classes of their modules) and every function and class of rodsim/core/tendon.py."""
    counts: Counter = Counter()
    subclasses = [cls for cls in registered_terms().values() if issubclass(cls, TendonTerm)]
    assert {cls.name for cls in subclasses} >= set(rodsim.core.tendon.TENDON_TERMS)
    classes = set(subclasses)
    for cls in subclasses:  # helper classes defined next to the terms (PointOnLumen …)
        module = sys.modules[cls.__module__]
        classes |= {c for c in vars(module).values()
                    if inspect.isclass(c) and c.__module__ == module.__name__}
    classes |= {c for c in vars(rodsim.core.tendon).values()
                if inspect.isclass(c) and c.__module__ == rodsim.core.tendon.__name__}
    wrapped = 0
    for cls in sorted(classes, key=lambda c: c.__name__):
        stop = (Term, object) if issubclass(cls, Term) else (object,)
        wrapped += _instrument_class(monkeypatch, counts, cls, stop)
    # Module functions, also where other modules imported them by name (scene, model).
    functions = {name: f for name, f in vars(rodsim.core.tendon).items()
                 if inspect.isfunction(f) and f.__module__ == rodsim.core.tendon.__name__}
    for name, function in functions.items():
        counted = _wrap(counts, f"rodsim.core.tendon.{name}", function)
        for module in [m for key, m in sys.modules.items() if key.startswith("rodsim")]:
            for attribute, value in list(vars(module).items()):
                if value is function:
                    monkeypatch.setattr(module, attribute, counted)
        wrapped += 1
    labels = [c.__name__ for c in classes] + list(functions)
    assert wrapped > 20, f"only {wrapped} callables instrumented"
    return counts, labels


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
@pytest.mark.parametrize("integrator", ["static", "cvode"])
def test_single_rod_scene_runs_no_tendon_code(integrator, kernels, monkeypatch):
    counts, labels = instrument_tendon_code(monkeypatch)
    result = rodsim.solve("table1-50g", integrator, overrides=[f"kernels={kernels}"])
    assert result.success, result.message
    assert "reinits" not in result.stats or result.stats["reinits"] == 0
    # Placing a rod asks every registered base place whether it claims the rod
    # (rodsim/core/base_places.py): the tendon place's answer, a key lookup, is the registry's
    # own dispatch and not tendon work; every other tendon method still counts.
    lookups = {f"{place.__name__}.claims" for place in registered_base_places().values()}
    called = {k: v for k, v in counts.items() if v and k not in lookups}
    assert not called, f"tendon code ran in a single-rod scene: {called}"
    assert sorted(labels)  # the instrumentation covered these (for the failure message)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_instrumentation_counts_tendon_code_in_a_tendon_scene(kernels, monkeypatch):
    """Control: the same counters see the tendon code of a tendon scene (the compiled path
    calls each term's ``kernel_arguments`` instead of its numpy methods)."""
    counts, _ = instrument_tendon_code(monkeypatch)
    result = rodsim.solve("tendon-conserving", "static", overrides=[f"kernels={kernels}"])
    assert result.success, result.message
    for label in ("rodsim.core.tendon.check_tendon", "rodsim.core.tendon.tendon_origin",
                  "Tendon.of",
                  "ConservingLumen.registration"):
        assert counts[label] > 0, f"{label} not counted: {dict(counts)}"
    methods = (("__init__", "kernel_arguments") if kernels == "compiled" else
               ("__init__", "element_forces", "element_jacobians"))
    if kernels == "numpy":
        assert counts["Tendon.lumen_frame"] > 0 and counts["ConservingLumen._on_segments"] > 0
    for cls in registered_terms().values():
        # The string tendons (no rod) and the paper's lumen coupling have scenes of their own.
        if issubclass(cls, TendonTerm) and cls.name not in (
                "tendon_string", "tendon_string_displacement", "lumen"):
            for method in methods:
                if method == "element_jacobians" and cls.name == "tendon_actuation":
                    continue  # the proximal pull is a dead load: no Jacobian
                assert counts[f"{cls.__name__}.{method}"] > 0, f"{cls.__name__}.{method}"


# ----------------------------------------------------------- (b) the archive holds every rod
ARCHIVE_RUNS = [("table3-catheter1", "cvode"), ("tendon-conserving", "static")]


@functools.cache
def archived(scene_name: str, integrator: str) -> rodsim.solvers.result.Result:
    result = rodsim.solve(scene_name, integrator)
    assert result.success, result.message
    return result


@pytest.mark.parametrize(("scene_name", "integrator"), ARCHIVE_RUNS)
def test_archive_holds_every_rod(scene_name, integrator, tmp_path):
    result = archived(scene_name, integrator)
    dataset = run_dataset(result)
    rods = result.scene.data["rods"]
    assert list(dict.fromkeys(dataset["rod"].values.tolist())) == list(rods)
    for name, rod in rods.items():
        nodes = dataset["rod"].values == name
        segments = dataset["segment_rod"].values == name
        assert int(nodes.sum()) == rod["nodes"]
        assert int(segments.sum()) == rod["nodes"] - 1
        np.testing.assert_array_equal(dataset["position"].values[nodes],
                                      result.positions(name))
        np.testing.assert_array_equal(dataset["quaternion"].values[segments],
                                      result.rods[name].quaternions)
        selected = dataset.sel(node=dataset.rod == name)
        np.testing.assert_allclose(selected["s"].values,
                                   np.linspace(0.0, rod["length"], rod["nodes"]), atol=1e-15)
    table = result.scene.data["tendons"]["tendon"]
    if rods["tendon"]["clamp"] == "frame":
        # The clamped tendon base sits in the lumen at the catheter's base (Eq. 32).
        np.testing.assert_array_equal(result.positions("tendon")[0], [0.0, table["offset"], 0.0])
    # The actuation choice (docs/design.md, erratum 7) is recorded in every archive.
    attrs = dataset.attrs
    point = table["tendon_actuation"]["point"]
    stored = json.loads(attrs["scene_json"])
    assert stored["tendons"]["tendon"]["tendon_actuation"]["point"] == point
    assert stored["tendons"]["tendon"]["coupling"] == table["coupling"]
    assert stored["rods"]["tendon"]["clamp"] == rods["tendon"]["clamp"]
    if integrator == "cvode":
        # Registration changed during the run: the rerun below replays re-initialisations.
        assert attrs["stats_reinits"] >= 1

    path = write_dataset(dataset, tmp_path / "run.nc")
    back = read_dataset(path)
    xr.testing.assert_identical(dataset, back)


@pytest.mark.parametrize(("scene_name", "integrator"), ARCHIVE_RUNS)
def test_tendon_archive_reruns(scene_name, integrator, tmp_path, cli, capsys):
    path = write_dataset(run_dataset(archived(scene_name, integrator)), tmp_path / "run.nc")
    stored = read_dataset(path)
    again, difference = rerun(stored)
    assert again.success, again.message
    assert set(again.rods) == {"catheter", "tendon"}
    independent = max(
        float(np.max(np.linalg.norm(again.positions(name) - stored["position"].values[
            stored["rod"].values == name], axis=1))) for name in again.rods)
    assert independent < 1e-12
    assert difference == pytest.approx(independent, abs=1e-15)
    capsys.readouterr()
    assert cli(["rerun", str(path)]) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    assert "tip of tendon" in out and "tip of catheter" in out


# ------------------------------------------------------------ (c) bad tendon input, via CLI
BASE = scene_paths()["table3-catheter1"].read_text(encoding="utf-8")
TENDON_ROD = BASE.index("[rods.tendon]")


def edit(old: str, new: str, text: str = BASE, start: int = 0) -> str:
    """Replace the first ``old`` at or after ``start``."""
    index = text.index(old, start)
    return text[:index] + new + text[index + len(old):]


def in_tendon_rod(old: str, new: str) -> str:
    return edit(old, new, start=TENDON_ROD)


def renamed_tendon_table(name: str) -> str:
    return BASE.replace("[tendons.tendon", f"[tendons.{name}")


# A tendon in the lumen of a rod that is itself a tendon in the lumen of the first: a cycle
# (once built a bare KeyError in Model.__init__; now rejected by check_tendon).
CYCLE = (edit("offset = 0.003", "offset = 0.00005",
              edit('catheter = "catheter"', 'catheter = "wire"'))
         + '\n[rods.wire]\nlength = 0.16\nradius = 0.0001\nyoungs_modulus = 5.9e6\n'
           'stretch_modulus = 5.9e6\ndensity = 1e4\nnodes = 10\nclamp = "frame"\n'
           '[tendons.wire]\ncatheter = "tendon"\noffset = 0.00005\n')

# (id, scene text, extra CLI args, key the message must name)
CASES = [
    ("tendon-longer-than-catheter", in_tendon_rod("length = 0.16", "length = 0.17"), [],
     "rods.tendon.length"),
    ("tendon-shorter-than-catheter", in_tendon_rod("length = 0.16", "length = 0.15"), [],
     "rods.tendon.length"),
    ("offset-equals-radius", edit("offset = 0.003", "offset = 0.006"), [],
     "tendons.tendon.offset"),
    ("offset-beyond-radius", edit("offset = 0.003", "offset = 0.01"), [],
     "tendons.tendon.offset"),
    ("offset-zero", edit("offset = 0.003", "offset = 0.0"), [], "tendons.tendon.offset"),
    ("offset-negative", edit("offset = 0.003", "offset = -0.003"), [],
     "tendons.tendon.offset"),
    ("set-offset-beyond-radius", BASE, ["--set", "offset=0.007"], "tendons.tendon.offset"),
    ("tendon-through-the-catheter-wall", in_tendon_rod("radius = 0.0001", "radius = 0.004"),
     [], "tendons.tendon.offset"),
    ("catheter-with-orientation-clamp", edit('clamp = "frame"', 'clamp = "orientation"'), [],
     "rods.catheter.clamp"),
    ("tendon-nodes-zero", edit("nodes = 10 ", "nodes = 0 "), [], "rods.tendon.nodes"),
    ("tendon-nodes-two", edit("nodes = 10 ", "nodes = 2 "), [], "rods.tendon.nodes"),
    ("direction-zero", edit("direction = [1.0, 0.0]", "direction = [0.0, 0.0]"), [],
     "tendons.tendon.direction"),
    ("direction-wrong-length", edit("direction = [1.0, 0.0]", "direction = [1.0, 0.0, 0.0]"),
     [], "tendons.tendon.direction"),
    ("catheter-not-a-rod", edit('catheter = "catheter"', 'catheter = "sheath"'), [],
     "tendons.tendon.catheter"),
    ("tendon-table-not-a-rod", renamed_tendon_table("wire"), [], "tendons.wire"),
    ("tendon-is-its-own-catheter", edit('catheter = "catheter"', 'catheter = "tendon"'), [],
     "tendons.tendon.catheter"),
    ("tendons-in-each-others-lumen", CYCLE, [], ".catheter"),
    ("unknown-coupling", edit('coupling = "paper"', 'coupling = "glue"'), [],
     "tendons.tendon.coupling"),
    ("proximal-actuation-with-frame-clamp", edit('point = "distal"', 'point = "proximal"'),
     [], "rods.tendon.clamp"),
    ("orientation-clamp-with-distal-actuation",
     in_tendon_rod('clamp = "frame"', 'clamp = "orientation"'), [], "rods.tendon.clamp"),
    ("first-segment-clamp-on-a-tendon",
     in_tendon_rod('clamp = "frame"', 'clamp = "first_segment"'), [], "rods.tendon.clamp"),
    ("tendon-origin-set-by-hand", in_tendon_rod("nodes = 10", "origin = [0.0, 0.003, 0.0]\n"
                                                "nodes = 10"), [], "rods.tendon.origin"),
    ("unknown-key-in-tendon-table", edit('coupling = "paper"', 'coupling = "paper"\nstiff = 1'),
     [], "tendons.tendon.stiff"),
    ("unknown-key-in-tendon-term-table", edit("K_L = 1000.0", "K_L = 1000.0\nK_X = 1.0"), [],
     "tendons.tendon.lumen.K_X"),
    ("unknown-tendon-term", BASE.replace("[tendons.tendon]\n",
                                         '[tendons.tendon]\nterms = ["lumen", "glue"]\n'), [],
     "tendons.tendon.terms"),
    ("parameters-for-unlisted-tendon-term",
     BASE.replace("[tendons.tendon]\n", '[tendons.tendon]\nterms = ["lumen", '
                  '"endpoint_compliance", "tendon_actuation"]\n'), [],
     "tendons.tendon.endpoint_coupling"),
    # K_L = 0 means "from K_L_relative" (rodsim/core/terms/_relative.py); the relative
    # spelling must be positive, and only one of the two may be given.
    ("K_L_relative-zero", edit("K_L = 1000.0", "K_L_relative = 0.0"), [],
     "tendons.tendon.lumen.K_L_relative"),
    ("K_L-negative", edit("K_L = 1000.0", "K_L = -1000.0"), [], "tendons.tendon.lumen.K_L"),
    ("set-K_L_relative-zero", BASE, ["--set", "K_L_relative=0"],
     "tendons.tendon.lumen.K_L_relative"),
    ("K_L-and-K_L_relative", edit("K_L = 1000.0", "K_L = 1000.0\nK_L_relative = 10.0"), [],
     "tendons.tendon.lumen"),
    ("K_E_relative-zero", edit("K_E = 950.0", "K_E_relative = 0.0"), [],
     "tendons.tendon.endpoint_compliance.K_E_relative"),
    ("K_E-and-K_E_relative", edit("K_E = 950.0", "K_E = 950.0\nK_E_relative = 10.0"), [],
     "tendons.tendon.endpoint_compliance"),
    ("K_C-and-K_C_relative",
     edit("K_C = 2e5", "K_C = 2e5\nK_C_relative = 10.0", start=BASE.index("[tendons")), [],
     "tendons.tendon.endpoint_coupling"),
    ("K_C-negative", edit("K_C = 2e5", "K_C = -2e5", start=BASE.index("[tendons")), [],
     "tendons.tendon.endpoint_coupling.K_C"),
    ("negative-actuation-force", edit("force = 2.0", "force = -2.0"), [],
     "tendons.tendon.tendon_actuation.force"),
    ("unknown-actuation-point", edit('point = "distal"', 'point = "middle"'), [],
     "tendons.tendon.tendon_actuation.point"),
    ("hysteresis-above-one", edit("K_L = 1000.0", "K_L = 1000.0\nhysteresis = 2.0"), [],
     "tendons.tendon.lumen.hysteresis"),
    ("conserving-lumen-on-d_t-only",
     edit("K_L = 1000.0", 'K_L = 1000.0\nconstrain = "d_t"'), ["--set", "coupling=conserving"],
     "tendons.tendon.lumen.constrain"),
    ("tendons-not-a-table", "tendons = 3\n" + BASE.split("[tendons.tendon]")[0], [],
     "tendons"),
]


@pytest.mark.parametrize(("scene_text", "extra", "key"), [c[1:] for c in CASES],
                         ids=[c[0] for c in CASES])
def test_bad_tendon_input_exits_2_with_one_line_naming_the_key(scene_text, extra, key,
                                                               tmp_path, capsys, cli):
    out = tmp_path / "out"
    out.mkdir()
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text, encoding="utf-8")
    before = sorted(p.name for p in tmp_path.rglob("*"))

    try:
        code, crash = cli(["run", str(scene), "--integrator", "static", "-o",
                           str(out / "run.nc"), *extra]), None
    except Exception as exc:  # noqa: BLE001 - a crash is reported by the assertion below
        code, crash = None, f"{type(exc).__name__}: {exc}"
    captured = capsys.readouterr()
    assert crash is None, f"rodsim run crashed instead of exiting 2: {crash}"
    stderr = captured.err.strip()
    assert code == 2, f"exit code {code}; stderr: {stderr!r}"
    assert stderr.startswith("rodsim: error:"), stderr
    assert "\n" not in stderr, f"message is not one line: {stderr!r}"
    assert "Traceback" not in captured.err
    assert key in stderr, f"{key!r} not named in {stderr!r}"
    assert captured.out == ""
    assert list(out.iterdir()) == []
    assert sorted(p.name for p in tmp_path.rglob("*")) == before


def test_every_bad_input_case_is_distinct_and_the_base_is_valid():
    assert len({c[0] for c in CASES}) == len(CASES)
    assert len({(c[1], tuple(c[2])) for c in CASES}) == len(CASES)
    assert all(c[1] != BASE or c[2] for c in CASES)
    rodsim.load_scene(scene_paths()["table3-catheter1"])  # the unedited scene is valid


def chained_scene(wire_first: bool) -> dict:
    """tendon-conserving plus a thin 'wire' routed in the tendon's lumen."""
    data = copy.deepcopy(rodsim.load_scene("tendon-conserving").data)
    wire = copy.deepcopy(data["rods"]["tendon"]) | {"radius": 1e-5}
    order = ["catheter", "wire", "tendon"] if wire_first else ["catheter", "tendon", "wire"]
    data["rods"] = {name: data["rods"].get(name, wire) for name in order}
    data["tendons"]["wire"] = copy.deepcopy(data["tendons"]["tendon"]) | {
        "catheter": "tendon", "offset": 5e-5}
    return data


def test_a_tendon_in_a_tendons_lumen_does_not_depend_on_the_declaration_order():
    """A rod whose 'catheter' is itself a tendon must either work in any declaration order
    or be rejected with a SceneError naming tendons.wire.catheter — not crash (a regression
    test: the model once built the rods in declaration order and raised a bare KeyError)."""
    outcomes = []
    for wire_first in (False, True):
        try:
            rodsim.build_model(chained_scene(wire_first))
            outcomes.append("built")
        except SceneError as exc:
            assert "tendons.wire.catheter" in str(exc)
            outcomes.append("SceneError")
        except Exception as exc:  # noqa: BLE001 - what the bug raises
            outcomes.append(f"{type(exc).__name__}: {exc}")
    assert outcomes[0] == outcomes[1] and outcomes[0] in ("built", "SceneError"), outcomes


def test_the_actuation_point_can_be_switched_with_overrides():
    """`--set` must be able to switch table3-catheter1 to proximal actuation, which needs
    the point and the tendon's clamp changed together (docs/design.md, erratum 7: the choice is a
    scene value). Each intermediate scene is invalid on its own, so the overrides must be
    validated together, after all are applied."""
    changes = {"rods.tendon.clamp": "orientation",
               "tendons.tendon.tendon_actuation.point": "proximal"}
    scene = rodsim.load_scene("table3-catheter1").with_values(changes)
    assert scene.data["rods"]["tendon"]["clamp"] == "orientation"  # a valid scene
    errors = []
    for keys in (list(changes), list(reversed(changes))):
        try:
            rodsim.load_scene("table3-catheter1", [f"{key}='{changes[key]}'" for key in keys])
        except SceneError as exc:
            errors.append(str(exc))
    assert len(errors) < 2, f"no order of the --set assignments is accepted: {errors}"


@pytest.mark.parametrize("name", sorted(scene_paths()))
def test_a_shipped_scene_keeps_its_name(name):
    """The scene's name (archive attribute, default output file) is its own, not that of a
    rod or tendon table declared in it: two tendon scenes once both became 'tendon' and
    overwrote each other's default archive tendon-<integrator>.nc."""
    assert rodsim.load_scene(name).name == name

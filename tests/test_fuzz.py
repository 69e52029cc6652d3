"""Generated bad input against the command line (issues 15 and 23): scene files, ``--set``
strings, tampered archives of every kind (run, study, track, fit, reach), byte-level damage,
special files, bad arguments of ``track``, ``fit`` and ``reach``, tampered point files of a
study being resumed, and concurrent writers of one archive.

For every example: the exit code is one the CLI promises (0 success, 1 solver failure or a
rerun that differs, 2 bad input); exit 2 comes with exactly one line on stderr; no traceback
and no Python warning ever reaches the user; nothing is written outside the requested
output, and nothing at all on exit 2.

Two ways of running an example:

- in this process (``rodsim.app.cli.main(argv)``, the current folder a fresh one): cheap,
  but an exception never reaches a stderr (it fails the test by itself);
- as a separate process (:func:`cli_process`): forked from this one (the same code, the
  kernels already loaded) with its real file descriptors 1 and 2 captured and the
  interpreter's own handling of an uncaught exception (a traceback on stderr, exit 1), so
  a traceback, a C library's message or a warning printed anywhere is seen; a process
  still running after :data:`HANG` seconds is a hang, a failure. The concurrent writers are
  real ``python -m rodsim.app.cli`` processes.

Scenes are kept small and fast: ``--integrator static``, a wall-time budget of 0.5 s in
every base scene, and the machine's memory is set (for the memory estimate,
rodsim/core/memory.py) so that any scene with more than 300 control points in all is
refused.

Seeds and size: the tests of issue 15 (``--set``, scene files, run and study archives,
point files) run derandomized — the fixed-seed subset, the same examples every run; the
others vary their examples with the session's seed, printed in pytest's header (``rodsim
fuzz seed: N``; ``RODSIM_FUZZ_SEED=N`` replays a run). ``RODSIM_FUZZ_EXAMPLES=N`` runs N
examples per test (a longer, nightly run; the concurrent writers then run N // 10 rounds);
the default counts are :data:`EXAMPLES`.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import shutil
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr
from hypothesis import HealthCheck, assume, given, seed, settings
from hypothesis import strategies as st

import rodsim.core.memory
import rodsim.studies
from rodsim.app.cli import main
from rodsim.app.study import Study, Sweep
from rodsim.app.study_runner import parts_folder, run_study
from rodsim.io.archive import ArchiveError, read_dataset, write_dataset

#: The whole suite is marked ``slow`` (~25 s of CPU): the README's command leaves it out,
#: .ci/run runs it (``-m slow --runslow``).
pytestmark = pytest.mark.slow

#: Examples per test in the default run: the fixed-seed tests first, then the varying ones.
EXAMPLES = {"set": 30, "scene": 25, "rerun": 20, "plot": 15, "resume": 12,
            "inverse archives": 16, "inverse commands": 10, "damaged bytes": 10,
            "concurrent": 10}

#: The session's seed of the varying examples (set by tests/conftest.py).
SEED = int(os.environ.get("RODSIM_FUZZ_SEED", "0"))
#: Seconds after which a CLI process counts as hung.
HANG = float(os.environ.get("RODSIM_FUZZ_HANG", "120"))


def examples(kind: str) -> int:
    return int(os.environ.get("RODSIM_FUZZ_EXAMPLES", EXAMPLES[kind]))


def fuzz_settings(kind: str) -> settings:
    """The fixed-seed tests: derandomized, the same examples every run."""
    return settings(max_examples=examples(kind), deadline=None, derandomize=True,
                    database=None, suppress_health_check=[HealthCheck.too_slow,
                                                         HealthCheck.data_too_large])


def varying(kind: str) -> Callable:
    """The varying tests: examples drawn from the session's seed (:data:`SEED`)."""
    def decorate(test: Callable) -> Callable:
        return seed(SEED)(settings(
            max_examples=examples(kind), deadline=None, derandomize=False, database=None,
            suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                   HealthCheck.function_scoped_fixture])(test))
    return decorate


BUDGET = "max_wall_time=0.5"
RUN = ["--integrator", "static", "--set", "nodes=6", "--set", BUDGET]

SCENE = """\
name = "fuzz"
description = "a small scene for the fuzz tests"
[rods.catheter]
length = 0.12
radius = 0.006
youngs_modulus = 5.9e6
stretch_modulus = 5.9e6
density = 11040.0
nodes = 6
clamp = "frame"
origin = [0.0, 0.0, 0.0]
terms = ["stretch", "bend_twist", "centerline", "tip_load"]
[rods.catheter.centerline]
K_P = 1e4
[rods.catheter.tip_load]
mass = 0.05
force = [0.0, 0.0, 0.0]
[solver]
integrator = "static"
tolerance = 1e-9
max_wall_time = 0.5
[solver.static]
max_newton = 30
"""

#: Study resumed by the fuzz tests: three quick points.
STUDY = Study(name="zz_fuzz_resume", title="fuzz", paper="tests only", scene="table1-50g",
              integrator="static", reference="exact", overrides=(BUDGET,),
              sweeps={"small": [Sweep("nodes", "rods.catheter.nodes", (6, 7, 8), "1", "N")]})

DEEP = "[" * 50_000 + "]" * 50_000

# Strategies ------------------------------------------------------------------------------

NASTY = ["", "nan", "inf", "-inf", "1e300", "-1e300", "1e-320", "0", "-0", "1e4", "true",
         "[]", "{}", "[[[[]]]]", DEEP, '"\\u0000"', "'\x00'", '"../../x"', '"/abs/x"',
         "[1, 2]", "[1, 2, 3]", "[nan, 0, 0]", '["stretch"]', '"a.b"', "{a = 1}",
         "9" * 400, '"' + "x" * 500 + '"', "[" + "1," * 200 + "1]", "\u00e9\u4e2d", "=",
         '"\n"']

toml_values = st.one_of(
    st.sampled_from(NASTY),
    st.integers(-10**6, 10**6).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(
        lambda f: "nan" if f != f else ("inf" if f == float("inf") else
                                        "-inf" if f == float("-inf") else repr(f))),
    st.text(max_size=25),
    st.text(max_size=15).map(json.dumps),
    st.lists(st.integers(-3, 3), max_size=4).map(str),
)

KEYS = ["nodes", "length", "radius", "youngs_modulus", "stretch_modulus", "density",
        "poisson_ratio", "clamp", "origin", "terms", "K_P", "mass", "force", "gravity",
        "tip_load.mass", "centerline.K_P", "name", "description", "tolerance",
        "max_wall_time", "integrator", "solver.static.max_newton",
        "solver.static.first_load_step", "solver.static.min_load_step",
        "solver.static.penalty_ratio", "rods.catheter.nodes", "rods", "solver", "tendons",
        "catheter", "x", "rods.catheter", "tip_load"]

#: Valid assignments, so that some examples succeed.
VALID = ["mass=0.02", "nodes=7", "K_P=2e4", "tip_load.force=[0, -0.1, 0]", 'name="ok.1"',
         'terms=["stretch", "bend_twist", "centerline"]', "tip_load.gravity=9.7",
         "origin=[0, 0.01, 0]", "clamp='first_segment'", "solver.static.max_newton=40",
         'description="fuzz"', "youngs_modulus=6e6"]

#: Mostly real keys (so that values reach validation), sometimes any text.
keys = st.one_of(st.sampled_from(KEYS), st.sampled_from(KEYS), st.sampled_from(KEYS),
                 st.text(max_size=15))

json_junk = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-10**12, 10**12),
              st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12)),
    lambda children: st.one_of(st.lists(children, max_size=3),
                               st.dictionaries(st.text(max_size=6), children, max_size=3)),
    max_leaves=6)

attribute_junk = st.one_of(st.text(max_size=40), st.integers(-10**9, 10**9),
                           st.floats(allow_nan=True, allow_infinity=True),
                           st.sampled_from(["null", "42", "[]", "{}", "{", DEEP, "nan"]),
                           json_junk.map(json.dumps))


# Running one example ---------------------------------------------------------------------


def files(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


class Outcome:
    """What one CLI call did: exit code, stdout, stderr lines, warnings, files added."""

    def __init__(self, code: int, out: str, err: str, caught: list, added: set[str],
                 removed: set[str]) -> None:
        self.code, self.out, self.err = code, out, err
        self.lines = err.strip().splitlines()
        self.caught = caught
        self.added, self.removed = added, removed

    def check(self, allowed_codes: set[int], allowed_files: set[str]) -> None:
        """The promises of the module docstring."""
        assert self.code in allowed_codes, (self.code, self.err)
        assert "Traceback" not in self.err, self.err
        assert not self.caught, [str(w.message) for w in self.caught]
        if self.code == 2:
            assert len(self.lines) == 1, self.err
            assert self.lines[0].startswith("rodsim"), self.err
            assert not self.added and not self.removed, (self.added, self.removed)
        else:
            assert self.added <= allowed_files, (self.added, allowed_files)
            assert all(line.startswith(("rodsim", "[")) for line in self.lines), self.err


def call(argv: list[str], folder: Path) -> Outcome:
    """``main(argv)`` with ``folder/cwd`` as the current folder; files under ``folder``
    before and after, stdout, stderr and warnings captured."""
    cwd = folder / "cwd"
    cwd.mkdir(exist_ok=True)
    before = files(folder)
    out, err = io.StringIO(), io.StringIO()
    previous = os.getcwd()
    os.chdir(cwd)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), \
                warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                code = main(argv)
            except SystemExit as exc:  # argparse
                code = exc.code
    finally:
        os.chdir(previous)
    after = files(folder)
    return Outcome(code, out.getvalue(), err.getvalue(), list(caught), after - before,
                   before - after)


@pytest.fixture(scope="module")
def root(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


def fresh(root: Path) -> Path:
    return Path(tempfile.mkdtemp(dir=root))


@pytest.fixture(scope="module", autouse=True)
def kernels_loaded():
    """Compile (or load from the disk cache) the kernels before the timed runs: the wall-time
    budget covers model assembly, and a fresh process's first assembly loads numba."""
    rodsim.solve("table1-50g", "static", overrides=["nodes=6"])


@pytest.fixture(scope="module", autouse=True)
def small_machine():
    """Any scene of more than 300 control points is refused by the memory estimate."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(rodsim.core.memory, "physical_memory",
                      lambda: 300 * rodsim.core.memory.BYTES_PER_NODE)
        yield


@pytest.fixture(scope="module")
def archives(root) -> dict[str, xr.Dataset]:
    """A run archive and a study archive, written once."""
    folder = root / "base"
    folder.mkdir()
    assert main(["run", *RUN, "-o", str(folder / "run.nc")]) == 0
    run_study(STUDY, "small", folder / "study.nc", workers=1)
    return {"run": read_dataset(folder / "run.nc"), "study": read_dataset(folder / "study.nc")}


@pytest.fixture(scope="module")
def parts(root) -> Path:
    """The parts folder of a finished STUDY (kept), and STUDY registered for the CLI."""
    folder = root / "studies"
    folder.mkdir()
    (folder / f"{STUDY.name}.py").write_text(
        f"from rodsim.app.study import Study, Sweep\n\nSTUDY = {STUDY!r}\n", encoding="utf-8")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(rodsim.studies, "__path__", [*rodsim.studies.__path__, str(folder)])
        patch.delitem(sys.modules, f"rodsim.studies.{STUDY.name}", raising=False)
        output = root / "parts" / "study.nc"
        output.parent.mkdir()
        run_study(STUDY, "small", output, workers=1, keep_parts=True)
        yield parts_folder(output)


# run: --set strings and scene files --------------------------------------------------------


@fuzz_settings("set")
@given(assignments=st.lists(st.one_of(
    *[st.tuples(keys, toml_values).map(lambda kv: f"{kv[0]}={kv[1]}")] * 4,
    st.text(max_size=30), *[st.sampled_from(VALID)] * 3), min_size=1, max_size=3))
def test_fuzz_set_strings(root, assignments):
    folder = fresh(root)
    argv = ["run", *RUN]
    for assignment in assignments:
        argv += ["--set", assignment]
    outcome = call([*argv, "-o", str(folder / "out.nc")], folder)
    outcome.check({0, 1, 2}, {"out.nc"})
    assert ("out.nc" in outcome.added) == (outcome.code == 0)


def mutate_scene(draw: Callable, text: str) -> bytes:
    """One mutation of a scene file's text."""
    lines = text.splitlines()
    kind = draw(st.sampled_from(["value", "insert", "truncate", "bytes", "delete"]))
    if kind == "value":
        candidates = [i for i, line in enumerate(lines) if " = " in line]
        i = draw(st.sampled_from(candidates))
        key = lines[i].split(" = ")[0]
        lines[i] = f"{key} = {draw(toml_values)}"
    elif kind == "insert":
        lines.insert(draw(st.integers(0, len(lines))), draw(st.one_of(
            st.text(max_size=40), st.tuples(keys, toml_values).map(" = ".join),
            st.sampled_from(["[rods]", "[rods.a.b]", '[rods."a.b"]', "[tendons.catheter]",
                             "[solver.bogus]", f"deep = {DEEP}", "[[rods]]", "name = 1"]))))
    elif kind == "truncate":
        return text.encode()[:draw(st.integers(0, len(text)))]
    elif kind == "delete":
        del lines[draw(st.integers(0, len(lines) - 1))]
    else:
        data = bytearray(text.encode())
        for _ in range(draw(st.integers(1, 4))):
            data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
        return bytes(data)
    return ("\n".join(lines) + "\n").encode("utf-8", "surrogatepass")


@fuzz_settings("scene")
@given(data=st.data())
def test_fuzz_scene_files(root, data):
    folder = fresh(root)
    scene = folder / "scene.toml"
    scene.write_bytes(mutate_scene(data.draw, SCENE))
    outcome = call(["run", str(scene), "--integrator", "static", "-o",
                    str(folder / "out.nc")], folder)
    outcome.check({0, 1, 2}, {"out.nc"})


# rerun and plot: tampered archives ------------------------------------------------------


def leaves(node: Any, path: tuple = ()) -> list[tuple]:
    """Paths to every value in a JSON document (containers included)."""
    out = [path]
    if isinstance(node, dict):
        for key, value in node.items():
            out += leaves(value, (*path, key))
    elif isinstance(node, list):
        for i, value in enumerate(node):
            out += leaves(value, (*path, i))
    return out


def replaced(node: Any, path: tuple, value: Any) -> Any:
    if not path:
        return value
    node[path[0]] = replaced(node[path[0]], path[1:], value)
    return node


JSON_ATTRIBUTES = ("scene_json", "integrator_options", "spec_json")


def tamper_archive(draw: Callable, ds: xr.Dataset) -> xr.Dataset:
    """One tampering of an archive: attributes, JSON documents, variables or values."""
    ds = ds.copy(deep=True)
    kind = draw(st.sampled_from(["drop attribute", "set attribute", "drop variable",
                                 "edit json", "values", "study attribute"]))
    if kind == "drop attribute":
        ds.attrs.pop(draw(st.sampled_from(sorted(ds.attrs))))
    elif kind == "set attribute":
        name = draw(st.one_of(st.sampled_from(sorted(ds.attrs)), st.text(min_size=1,
                                                                         max_size=10)))
        ds.attrs[name] = draw(attribute_junk)
    elif kind == "drop variable":
        ds = ds.drop_vars(draw(st.sampled_from(sorted(ds.variables))))
    elif kind == "edit json":
        name = draw(st.sampled_from([a for a in JSON_ATTRIBUTES if a in ds.attrs]))
        document = json.loads(ds.attrs[name])
        path = draw(st.sampled_from(leaves(document)))
        ds.attrs[name] = json.dumps(replaced(document, path, draw(json_junk)))
    elif kind == "values":
        name = draw(st.sampled_from([v for v in ds.data_vars
                                     if ds[v].dtype.kind == "f"]))
        flat = ds[name].values.reshape(-1)
        flat[draw(st.integers(0, flat.size - 1))] = draw(st.sampled_from(
            [np.nan, np.inf, 1e300, -1.0, 0.0]))
    else:
        ds.attrs["study"] = draw(st.text(max_size=10))
    return ds


def write_tampered(data, archives, folder: Path) -> Path:
    kind = data.draw(st.sampled_from(["run", "study"]))
    tampered = tamper_archive(data.draw, archives[kind])
    path = folder / "tampered.nc"
    try:
        write_dataset(tampered, path)
    except (ArchiveError, TypeError, ValueError):
        assume(False)  # netCDF cannot hold this attribute: not an archive anyone can make
    return path


@fuzz_settings("rerun")
@given(data=st.data())
def test_fuzz_rerun_tampered_archives(root, archives, data):
    folder = fresh(root)
    path = write_tampered(data, archives, folder)
    outcome = call(["rerun", str(path)], folder)
    outcome.check({0, 1, 2}, set())


@fuzz_settings("plot")
@given(data=st.data())
def test_fuzz_plot_tampered_archives(root, archives, data):
    folder = fresh(root)
    path = write_tampered(data, archives, folder)
    outcome = call(["plot", str(path), "--format", "svg"], folder)
    outcome.check({0, 2}, {"tampered.svg"})


# study resume: tampered point files ----------------------------------------------------


@fuzz_settings("resume")
@given(data=st.data())
def test_fuzz_resume_with_tampered_point_files(root, parts, data):
    folder = fresh(root)
    output = folder / "out" / "study.nc"
    output.parent.mkdir()
    shutil.copytree(parts, parts_folder(output))
    target = parts_folder(output) / data.draw(st.sampled_from(
        ["point-0.json", "point-1.json", "point-2.json", "spec.json"]))
    kind = data.draw(st.sampled_from(["edit", "delete key", "replace", "truncate"]))
    text = target.read_text(encoding="utf-8")
    if kind in ("edit", "delete key"):
        document = json.loads(text)
        paths = [p for p in leaves(document) if p]
        path = data.draw(st.sampled_from(paths))
        if kind == "edit":
            document = replaced(document, path, data.draw(json_junk))
        else:
            parent = document
            for part in path[:-1]:
                parent = parent[part]
            del parent[path[-1]]
        target.write_text(json.dumps(document), encoding="utf-8")
    elif kind == "replace":
        target.write_bytes(data.draw(st.one_of(st.binary(max_size=50),
                                               json_junk.map(lambda v: json.dumps(v).encode()),
                                               st.just(DEEP.encode()))))
    else:
        target.write_text(text[:data.draw(st.integers(0, len(text)))], encoding="utf-8")
    outcome = call(["study", STUDY.name, "--size", "small", "--workers", "1", "-o",
                    str(output)], folder)
    # Success removes the parts folder and writes the archive; a refused folder is kept.
    allowed = {"out/study.nc"}
    outcome.check({0, 1, 2}, allowed)
    if outcome.code in (0, 1):
        assert output.exists() and not parts_folder(output).exists()


# As a separate process -------------------------------------------------------------------


def cli_process(argv: list[str], folder: Path) -> Outcome:
    """``rodsim`` with ``argv`` in a separate process, forked from this one, its current
    folder ``folder/cwd``; its real stdout and stderr (file descriptors 1 and 2), exit code,
    and the files under ``folder`` before and after. An uncaught exception ends it as the
    interpreter ends ``rodsim``: a traceback on stderr, exit 1. Still running after
    :data:`HANG` s: killed, and the test fails (a hang)."""
    cwd = folder / "cwd"
    cwd.mkdir(exist_ok=True)
    before = files(folder)
    out_file, err_file = folder.parent / f"{folder.name}.out", folder.parent / f"{folder.name}.err"
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        code = 1
        try:
            os.dup2(os.open(out_file, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644), 1)
            os.dup2(os.open(err_file, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644), 2)
            sys.stdout = open(1, "w", closefd=False)  # noqa: SIM115 - the process's own
            sys.stderr = open(2, "w", closefd=False)  # noqa: SIM115
            warnings.resetwarnings()  # the interpreter's defaults, not pytest's filters
            warnings.simplefilter("default")
            os.chdir(cwd)
            try:
                code = main(argv)
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else 1
        except BaseException:  # what the interpreter does with an uncaught exception
            import traceback

            traceback.print_exc()
            code = 1
        finally:
            with contextlib.suppress(Exception):
                sys.stdout.flush()
                sys.stderr.flush()
            os._exit(code)
    waited = 0.0
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        if waited > HANG:
            os.kill(pid, 9)
            os.waitpid(pid, 0)
            pytest.fail(f"rodsim {' '.join(argv)[:200]} hung (> {HANG:g} s)")
        time.sleep(0.02)
        waited += 0.02
    code = os.waitstatus_to_exitcode(status)
    out, err = out_file.read_text(errors="replace"), err_file.read_text(errors="replace")
    out_file.unlink()
    err_file.unlink()
    after = files(folder)
    return Outcome(code, out, err, [], after - before, before - after)


INVERSE_RUN = ["--set", "nodes=6", "--set", BUDGET]


@pytest.fixture(scope="module")
def kinds(root) -> dict[str, Path]:
    """One archive of each kind (run, study, track, fit, reach), small, written once."""
    folder = root / "kinds"
    folder.mkdir()
    paths = {kind: folder / f"{kind}.nc" for kind in ("run", "study", "track", "fit",
                                                        "reach")}
    assert main(["run", *RUN, "-o", str(paths["run"])]) == 0
    run_study(STUDY, "small", paths["study"], workers=1)
    assert main(["track", "table1-50g", *INVERSE_RUN, "--ramp", "tip_load.mass=0.05:0.06:3",
                 "-o", str(paths["track"])]) == 0
    nodes = read_dataset(paths["run"])["position"].values
    data = folder / "data.csv"
    data.write_text("x,y,z\n" + "\n".join(",".join(f"{v:.17g}" for v in p) for p in nodes))
    assert main(["fit", "table1-50g", *INVERSE_RUN, "--data", str(data), "--param",
                 "youngs_modulus", "-o", str(paths["fit"])]) == 0
    assert main(["reach", "table1-50g", *INVERSE_RUN, "--tip",
                 f"{nodes[-1, 0]},{nodes[-1, 1] + 1e-4},0", "--actuate", "tip_load.force[1]",
                 "--tolerance", "1e-3", "-o", str(paths["reach"])]) == 0
    return paths


@varying("inverse archives")
@given(data=st.data())
def test_fuzz_tampered_track_fit_and_reach_archives(root, kinds, data):
    """Tampered track, fit and reach archives through ``rerun`` and ``plot``."""
    folder = fresh(root)
    kind = data.draw(st.sampled_from(["track", "fit", "reach"]))
    tampered = tamper_archive(data.draw, read_dataset(kinds[kind]))
    path = folder / "tampered.nc"
    try:
        write_dataset(tampered, path)
    except (ArchiveError, TypeError, ValueError):
        assume(False)
    if data.draw(st.booleans()):
        call(["plot", str(path), "--format", "svg"], folder).check({0, 2}, {"tampered.svg"})
    else:
        call(["rerun", str(path)], folder).check({0, 1, 2}, set())


def damaged(draw: Callable, source: Path, target: Path) -> None:
    """A copy of ``source`` with bytes overwritten at drawn offsets, or truncated."""
    data = bytearray(source.read_bytes())
    if draw(st.integers(0, 4)) == 0:
        data = data[:draw(st.integers(0, len(data) - 1))]
    else:
        for _ in range(draw(st.integers(1, 4))):
            start = draw(st.integers(0, len(data) - 1))
            count = draw(st.integers(1, 64))
            data[start:start + count] = draw(st.binary(min_size=count, max_size=count))
    target.write_bytes(bytes(data[:len(source.read_bytes())]))


@varying("damaged bytes")
@given(data=st.data())
def test_fuzz_damaged_bytes_of_every_archive_kind(root, kinds, data):
    """Byte-level damage of each archive kind through ``plot`` and ``rerun``, as processes."""
    folder = fresh(root)
    kind = data.draw(st.sampled_from(sorted(kinds)))
    path = folder / "damaged.nc"
    damaged(data.draw, kinds[kind], path)
    if kind == "study" or data.draw(st.booleans()):
        outcome = cli_process(["plot", str(path), "--format", "svg"], folder)
        outcome.check({0, 2}, {"damaged.svg"})
    else:
        cli_process(["rerun", str(path)], folder).check({0, 1, 2}, set())


NUMBERS = st.one_of(st.sampled_from(["0", "-0", "1", "-5", "0.05", "1e300", "-1e300", "nan",
                                     "inf", "1e-320", "", "x", "1,2", "0x10", "9" * 40]),
                    st.floats(-10, 10).map(repr))
RAMP_KEYS = ["tip_load.mass", "tip_load.force[0]", "tip_load.force[5]", "youngs_modulus",
             "nodes", "rods.catheter.length", "bogus", "", "K_P", "origin", "clamp"]
ACTUATE = ["tip_load.force[0]", "tip_load.force[1]", "tip_load.mass", "youngs_modulus",
           "nodes", "bogus", "", "tip_load.force"]
OUTPUTS = [None, "out.nc", "", "out/", "missing/out.nc", "out"]


def inverse_argv(draw: Callable, folder: Path) -> tuple[list[str], str | None]:
    """A generated ``track``, ``fit`` or ``reach`` command (and its ``-o``)."""
    command = draw(st.sampled_from(["track", "fit", "reach"]))
    argv = [command, "table1-50g", *INVERSE_RUN]
    if command == "track":
        for _ in range(draw(st.integers(1, 2))):
            count = draw(st.one_of(st.sampled_from(["2", "3", "1", "0", "-1", "x",
                                                    "100000000", "2.5"]),
                                   st.integers(2, 6).map(str)))
            argv += ["--ramp", f"{draw(st.sampled_from(RAMP_KEYS))}={draw(NUMBERS)}:"
                     f"{draw(NUMBERS)}:{count}"]
        if draw(st.booleans()):
            argv.append("--allow-unstable")
        if draw(st.integers(0, 3)) == 0:
            argv += ["--integrator", draw(st.sampled_from(["cvode", "paper", "bogus"]))]
    elif command == "fit":
        data = folder / "data.csv"
        header = draw(st.sampled_from(["x,y,z", "x,y,z,s", "s,z,y,x", "x,y", "a,b,c", ""]))
        rows = draw(st.lists(st.lists(NUMBERS, min_size=2, max_size=4).map(",".join),
                             max_size=8))
        scale = draw(st.sampled_from([1.0, 1e3, 1e-3]))
        straight = [f"{0.012 * i * scale},0,0" for i in range(draw(st.integers(0, 8)))]
        data.write_text("\n".join([header, *straight, *rows]) + "\n", encoding="utf-8")
        argv += ["--data", str(data)]
        for _ in range(draw(st.integers(1, 2))):
            argv += ["--param", draw(st.sampled_from(ACTUATE))]
    else:
        argv += ["--tip", ",".join(draw(st.lists(NUMBERS, min_size=2, max_size=4)))]
        for _ in range(draw(st.integers(1, 3))):
            argv += ["--actuate", draw(st.sampled_from(ACTUATE))]
        if draw(st.booleans()):
            argv += ["--tolerance", draw(NUMBERS)]
    output = draw(st.sampled_from(OUTPUTS))
    if output is not None:
        argv += ["-o", output]
    return argv, output


@varying("inverse commands")
@given(data=st.data())
def test_fuzz_track_fit_and_reach_commands(root, data):
    """Generated arguments and data of ``track``, ``fit`` and ``reach``, as processes, with
    and without ``-o``: an archive and its figure, or nothing."""
    folder = fresh(root)
    argv, output = inverse_argv(data.draw, folder)
    outcome = cli_process(argv, folder)
    scene = "table1-50g"
    if output is None:
        allowed = {"cwd/runs", f"cwd/runs/{scene}-{argv[0]}.nc",
                   f"cwd/runs/{scene}-{argv[0]}.png"}
    else:
        stem = output.removesuffix(".nc")
        allowed = {f"cwd/{output}", f"cwd/{stem}.png"}
    outcome.check({0, 1, 2}, allowed)


SPECIAL = ["fifo", "folder", "/dev/zero", "/dev/null", "socket"]


@pytest.mark.parametrize("special", SPECIAL)
@pytest.mark.parametrize("command", ["rerun", "plot", "fit", "run"])
def test_fuzz_special_files_are_refused_as_inputs(root, special, command):
    """A FIFO blocked rerun, plot and fit --data forever; /dev/zero exhausted memory."""
    import socket

    folder = fresh(root)
    path = folder / "special"
    if special == "fifo":
        os.mkfifo(path)
    elif special == "folder":
        path.mkdir()
    elif special == "socket":
        server = socket.socket(socket.AF_UNIX)
        server.bind(str(path))
        server.close()
    else:
        path = Path(special)
    argv = {"rerun": ["rerun", str(path)], "plot": ["plot", str(path), "-o",
                                                     str(folder / "fig")],
            "fit": ["fit", "table1-50g", "--data", str(path), "--param", "youngs_modulus",
                    "-o", str(folder / "fit.nc")],
            "run": ["run", str(path), "-o", str(folder / "run.nc")]}[command]
    outcome = cli_process(argv, folder)
    outcome.check({2}, set())


def test_fuzz_concurrent_writers_of_one_archive(root):
    """Rounds of three real ``rodsim run -o same.nc`` at once: every one exits 0 (a warning
    at most), and the file is a complete archive of one of them."""
    import subprocess

    folder = fresh(root)
    target = folder / "same.nc"
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    for round_ in range(max(1, examples("concurrent") // 10)):
        masses = [0.01 * (i + 1) + 0.001 * round_ for i in range(3)]
        runs = [subprocess.Popen([sys.executable, "-m", "rodsim.app.cli", "run", "--integrator",
                                  "static", "--set", "nodes=6", "--set",
                                  f"tip_load.mass={mass}", "-o", str(target)],
                                 cwd=folder, env=env, stdout=subprocess.DEVNULL,
                                 stderr=subprocess.PIPE, text=True) for mass in masses]
        for run in runs:
            _, err = run.communicate(timeout=HANG)
            assert run.returncode == 0, err
            assert all(line.startswith(("rodsim: warning: ", "[")) for line in
                       err.splitlines() if line.strip()), err
        stored = read_dataset(target)
        mass = json.loads(stored.attrs["scene_json"])["rods"]["catheter"]["tip_load"]["mass"]
        assert mass in masses
    assert sorted(p.name for p in folder.iterdir()) == ["same.nc"]

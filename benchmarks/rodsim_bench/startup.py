"""What a user waits for around the solve (``rodsim bench startup``): whole-process CPU time
of short commands, measured in one run as ratios.

Commands (each a fresh process, median of the repeats; CPU = user + system time of the
child, from ``resource.getrusage(RUSAGE_CHILDREN)``, so the machine's load from others
counts less than in wall time):

- ``import``: ``python -c "import numpy, scipy.sparse"``, the floor every command pays;
- ``help``: ``rodsim --help``;
- ``run``: ``rodsim run`` of the default scene into a temporary folder (the installed
  command's process: rodsim/app/lean.py; its ``solver.kernels = "auto"`` is ``tiered``:
  numpy evaluations, the compiled kernels only once numpy has cost what loading them would,
  rodsim/core/kernel_tier.py);
- ``run, compiled kernels``: the same with ``--set solver.kernels=compiled`` (what
  ``rodsim run`` did before the tiered path);
- ``run, plain process``: the same ``rodsim run`` through ``main(argv)`` in a process that
  exits normally and keeps dask visible to xarray — what every ``rodsim run`` cost before
  the lean process (the help epilog aside);
- issue 35's two aims: ``run tdcr-two-segment`` (``rodsim run tdcr-two-segment``, warm
  kernel cache) and ``import rodsim + solve tdcr-two-segment`` (``python -c "import rodsim;
  rodsim.solve('tdcr-two-segment')"``, the Python entry: its ``solver.kernels = "auto"`` is
  ``compiled``, so numba and the scene's cached kernels are loaded);
- the floors under them: ``python -c pass``, ``import numpy``, ``import numba``, and
  ``import numpy, scipy.sparse, numba`` (what the Python entry imports before its first
  compiled evaluation).

With ``RODSIM_BENCH_BASELINE`` set to a git revision (rodsim_bench/baseline.py), issue 35's
two commands are also run with that revision's tree, interleaved with the rest (rows
``... (baseline <commit>)``; a warm-up run first fills the tree's own numba cache).

And the breakdown of one ``rodsim run`` into phases (a child process that does what the
command does, step by step, reading its own CPU clock between steps; the exit is the
child's total CPU minus its clock at the end), once as a plain process (compiled kernels,
dask visible, the archive written through xarray, normal exit: the command before the lean
process) and once as the lean one (the tiered kernels, so numba is not imported; dask
hidden, the archive written without xarray, early exit).

And the breakdown of issue 35's ``rodsim run tdcr-two-segment`` the same way, in the lean
process as the command runs it (tiered kernels, dask hidden, early exit), the run's two
estimates (penalty and discretisation: three re-solves) included; with
``RODSIM_BENCH_BASELINE`` also with the baseline revision's tree (before / after in one run).

Outputs ``startup-<size>.nc`` and ``startup-<size>.md`` (with the machine description).
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import numpy as np
import xarray as xr

from rodsim.io.archive import write_dataset
from rodsim_bench.baseline import BaselineTree, baseline_revision
from rodsim_bench.machine import machine

__all__ = ["run", "COMMANDS"]

#: small: one repeat without the warm-up round (a smoke run: every command and phase timed
#: once, with cold bytecode and numba caches for the first); full: a warm-up round, then 5.
SIZES = {"small": {"repeats": 1, "warm_up": False}, "full": {"repeats": 5, "warm_up": True}}

#: A plain process: main(argv) returns and the interpreter exits normally.
_PLAIN = "import sys\nfrom rodsim.app.cli import main\nsys.exit(main(sys.argv[1:]))"

#: label -> argv after the Python executable ({out}: the temporary folder).
COMMANDS = {
    "import": ["-c", "import numpy, scipy.sparse"],
    "help": ["-m", "rodsim", "--help"],
    "run": ["-m", "rodsim", "run", "-o", "{out}/run.nc"],
    "run, compiled kernels": ["-m", "rodsim", "run", "--set", "solver.kernels=compiled",
                              "-o", "{out}/compiled.nc"],
    "run, plain process": ["-c", _PLAIN, "run", "-o", "{out}/plain.nc"],
    "run tdcr-two-segment": ["-m", "rodsim", "run", "tdcr-two-segment", "-o", "{out}/tdcr.nc"],
    "import rodsim + solve tdcr-two-segment": [
        "-c", "import rodsim; rodsim.solve('tdcr-two-segment')"],
    "python -c pass": ["-c", "pass"],
    "import numpy": ["-c", "import numpy"],
    "import numba": ["-c", "import numba"],
    "import numpy, scipy.sparse, numba": ["-c", "import numpy, scipy.sparse, numba"],
}

#: Issue 35's two commands, also run with the baseline revision's tree when one is named.
ISSUE_35 = ("run tdcr-two-segment", "import rodsim + solve tdcr-two-segment")

#: The phases of one ``rodsim run``, each timed on the child's CPU clock.
_PHASES = textwrap.dedent("""
    import json, os, sys, time
    clock = time.process_time
    marks = []
    def mark(name):
        marks.append((name, clock()))
    mark("interpreter start")
    from rodsim.app.threads import pin_threads
    pin_threads()
    early = sys.argv[2] == "lean"
    if early:
        from rodsim.app.lean import hide_dask
        hide_dask()
    import numpy, scipy.sparse, scipy.sparse.linalg
    mark("numpy + scipy.sparse/linalg import")
    if not early:  # the tiered kernels of a short run never import numba
        import numba
    mark("numba import (lean: none, the tiered kernels stayed on numpy)")
    if not early:  # the command reads SUNDIALS' version from sksundae's files (issue 35)
        import sksundae
    mark("scikit-sundae import (lean: none, its version read from the package's files)")
    import rodsim.app.api as api
    import rodsim.solvers
    rodsim.solvers.registered_integrators()
    mark("rodsim modules and integrators")
    scene = api.load_scene(None)
    if early:  # what the command does with solver.kernels = "auto"
        scene = scene.with_values({"solver.kernels": "tiered"})
    mark("scene load")
    model = api.build_model(scene)
    mark("Model(...) (plain: kernels loaded; J at rest)")
    result = api.solve(scene, model=model)
    mark("solve")
    if early:  # the command now: no xarray (rodsim/io/netcdf_writer.py)
        import netCDF4
        mark("archive libraries import (plain: xarray + netCDF4; lean: netCDF4)")
        from rodsim.io.run_dataset import run_content
        content = run_content(result)
        mark("archive content (provenance)")
        from rodsim.io.archive import write_content
        write_content(content, sys.argv[1])
        mark("netCDF write")
    else:  # before: the xarray Dataset and its to_netcdf
        import xarray, netCDF4
        mark("archive libraries import (plain: xarray + netCDF4; lean: netCDF4)")
        from rodsim.io.run_dataset import run_dataset
        dataset = run_dataset(result)
        mark("archive content (provenance)")
        from rodsim.io.archive import write_dataset
        write_dataset(dataset, sys.argv[1])
        mark("netCDF write")
    from rodsim.app.cli.run import print_run_summary as _print_run_summary
    saved = sys.stdout
    sys.stdout = open(os.devnull, "w")
    _print_run_summary(result, None)
    sys.stdout.close()
    sys.stdout = saved
    mark("summary")
    print(json.dumps(marks), flush=True)
    if early:
        os._exit(0)
""")


#: The phases of ``rodsim run tdcr-two-segment`` (issue 35), each on the child's CPU clock.
_TDCR_PHASES = textwrap.dedent("""
    import json, os, sys, time
    clock = time.process_time
    marks = []
    def mark(name):
        marks.append((name, clock()))
    mark("interpreter start")
    from rodsim.app.threads import pin_threads
    pin_threads()
    from rodsim.app.lean import hide_dask
    hide_dask()
    import numpy, scipy.sparse, scipy.sparse.linalg, scipy.sparse.csgraph
    mark("numpy + scipy.sparse/linalg/csgraph import")
    import rodsim.app.api as api
    import rodsim.solvers
    rodsim.solvers.registered_integrators()
    mark("rodsim modules and integrators")
    scene = api.load_scene("tdcr-two-segment").with_values({"solver.kernels": "tiered"})
    mark("scene load")
    result = api.solve(scene)
    mark("model + solve (numpy kernels)")
    from rodsim.app.trust import assess
    estimate = assess(result)
    mark("penalty and discretisation estimates (3 re-solves; before: scipy.interpolate)")
    import netCDF4
    mark("netCDF4 import")
    from rodsim.io.run_dataset import run_content
    content = run_content(result)
    mark("archive content (provenance; before: scikit-sundae imported; self-crossing)")
    from rodsim.io.archive import write_content
    write_content(content, sys.argv[1])
    mark("netCDF write")
    from rodsim.app.cli.run import print_run_summary
    saved = sys.stdout
    sys.stdout = open(os.devnull, "w")
    print_run_summary(result, None)
    print(estimate.text())
    sys.stdout.close()
    sys.stdout = saved
    mark("summary (references)")
    print(json.dumps(marks), flush=True)
    os._exit(0)
""")


def _child_cpu(argv: list[str], pythonpath: str | None = None) -> tuple[float, str]:
    """CPU seconds (user + system) of one child process, and its stdout. The child may
    write and read Python's bytecode caches as a user's installation does
    (PYTHONDONTWRITEBYTECODE, set in some development shells, would make every import
    compile rodsim's sources again: ~0.1 s of a ``rodsim run``); the first, warm-up round
    writes them."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    if pythonpath is not None:  # another revision's tree (RODSIM_BENCH_BASELINE), run in
        env["PYTHONPATH"] = pythonpath  # it: -m and -c put the current folder first
    done = subprocess.run([sys.executable, *argv], capture_output=True, text=True, env=env,
                          timeout=1800, check=False, cwd=pythonpath)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"{argv}: exit {done.returncode}: {done.stderr[-500:]}")
    return (after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime,
            done.stdout)


def _phases(folder: str, exit_kind: str, pythonpath: str | None = None) -> dict[str, float]:
    """The phases of one run: ``exit_kind`` "plain" or "lean" (the default scene), or
    "tdcr" (issue 35's command; ``pythonpath``: another revision's tree)."""
    if exit_kind == "tdcr":
        cpu, out = _child_cpu(["-c", _TDCR_PHASES, f"{folder}/tdcr-phases.nc"], pythonpath)
    else:
        cpu, out = _child_cpu(["-c", _PHASES, f"{folder}/phases.nc", exit_kind])
    marks = json.loads(out.splitlines()[-1])
    phases = {name: t - marks[k - 1][1] for k, (name, t) in enumerate(marks) if k > 0}
    phases = {"interpreter start": marks[0][1]} | phases
    phases["interpreter exit"] = cpu - marks[-1][1]
    phases["total"] = cpu
    return phases


def _commands(folder: str) -> tuple[dict[str, tuple[list[str], str | None]],
                                     dict[str, str | None]]:
    """label -> (argv, PYTHONPATH or None): ``COMMANDS``, and issue 35's two with the
    baseline revision's tree when ``RODSIM_BENCH_BASELINE`` names one; and the trees of the
    tdcr breakdown (label -> PYTHONPATH or None)."""
    commands: dict[str, tuple[list[str], str | None]] = {
        label: ([word.format(out=folder) for word in argv], None)
        for label, argv in COMMANDS.items()}
    trees: dict[str, str | None] = {"this tree": None}
    revision = baseline_revision()
    if revision:
        tree = BaselineTree(revision, Path(folder))
        for label in ISSUE_35:
            commands[f"{label} (baseline {tree.commit[:7]})"] = (commands[label][0],
                                                                 str(tree.tree))
        trees[f"baseline {tree.commit[:7]}"] = str(tree.tree)
    return commands, trees


def run(size: str, output_dir: str | Path, progress=None) -> list[Path]:
    repeats = SIZES[size]["repeats"]
    phases: dict[str, list[dict[str, float]]] = {"plain": [], "lean": []}
    with tempfile.TemporaryDirectory(prefix="rodsim-startup-") as folder:
        commands, trees = _commands(folder)
        times: dict[str, list[float]] = {label: [] for label in commands}
        tdcr: dict[str, list[dict[str, float]]] = {label: [] for label in trees}
        if SIZES[size]["warm_up"]:  # bytecode and numba caches written before timing
            for argv, path in commands.values():
                _child_cpu(argv, path)
            _phases(folder, "lean")
        for repeat in range(repeats):  # interleaved, so that a load change hits every row
            for label, (argv, path) in commands.items():
                if progress is not None:
                    progress(repeat / repeats, f"startup: {label} ({repeat + 1}/{repeats})")
                cpu, _ = _child_cpu(argv, path)
                times[label].append(cpu)
            for kind in phases:
                phases[kind].append(_phases(folder, kind))
            for label, path in trees.items():
                tdcr[label].append(_phases(folder, "tdcr", path))
    median = {label: float(np.median(values)) for label, values in times.items()}
    names = list(phases["plain"][0])
    phase_median = {kind: [float(np.median([p[name] for p in runs])) for name in names]
                    for kind, runs in phases.items()}
    tdcr_names = list(tdcr["this tree"][0])
    tdcr_median = {label: [float(np.median([p[name] for p in runs])) for name in tdcr_names]
                   for label, runs in tdcr.items()}

    ds = xr.Dataset(
        {"cpu": (("command", "repeat"), np.array([times[c] for c in times]),
                 {"units": "s", "long_name": "whole-process CPU time (user + system)"}),
         "cpu_median": ("command", [median[c] for c in times],
                        {"units": "s", "long_name": "median whole-process CPU time"}),
         "phase_cpu": (("exit", "phase"),
                       np.array([phase_median["plain"], phase_median["lean"]]),
                       {"units": "s", "long_name": "median CPU time of each phase of a run"})},
        coords={"command": ("command", list(times), {"long_name": "command"}),
                "repeat": ("repeat", np.arange(repeats), {"long_name": "repeat"}),
                "exit": ("exit", ["plain", "lean"],
                         {"long_name": "plain process (normal exit, dask visible) or lean "
                          "(early exit, dask hidden)"}),
                "phase": ("phase", names, {"long_name": "phase of one rodsim run"}),
                "tree": ("tree", list(trees), {"long_name": "this tree or the baseline's"}),
                "tdcr_phase": ("tdcr_phase", tdcr_names,
                               {"long_name": "phase of rodsim run tdcr-two-segment"})})
    ds.attrs = {"title": "rodsim: whole-process CPU time of short commands", "size": size,
                "benchmark": "startup",
                **{f"machine_{k}": v for k, v in machine().items()}}
    output = Path(output_dir) / f"startup-{size}.nc"
    write_dataset(ds, output)
    floor = median["import"]
    lines = [f"# Start-up: whole-process CPU ({size}, median of {repeats})", "",
             "| command | CPU [s] | / import numpy, scipy.sparse |", "|---|--:|--:|"]
    lines += [f"| {label} | {median[label]:.3f} | {median[label] / floor:.2f} |"
              for label in times]
    lines += ["", "| phase of one `rodsim run` | plain process [s] | lean process [s] |",
              "|---|--:|--:|"]
    lines += [f"| {name} | {a:.3f} | {b:.3f} |" for name, a, b in
              zip(names, phase_median["plain"], phase_median["lean"], strict=True)]
    lines += ["", "| phase of `rodsim run tdcr-two-segment` | "
              + " | ".join(f"{label} [s]" for label in trees) + " |",
              "|---|" + "--:|" * len(trees)]
    lines += [f"| {name} | " + " | ".join(f"{tdcr_median[label][k]:.3f}" for label in trees)
              + " |" for k, name in enumerate(tdcr_names)]
    lines += ["", "Machine: " + ", ".join(f"{k} {v}" for k, v in machine().items())]
    table = output.with_suffix(".md")
    table.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return [output, table]

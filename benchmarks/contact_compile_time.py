"""First-call (cold numba cache) and warm-cache time of the contact kernels, before/after.

    python benchmarks/contact_compile_time.py --baseline REV [--repeats 3] [-o FILE]

For each contact scene, each repeat and each tree (this checkout, and REV's code extracted
with ``git archive``), interleaved: a fresh process with an empty NUMBA_CACHE_DIR (cold),
then a second process on that cache (warm). Each process times numba's import, the contact
term's kernel (load, first evaluate, first energy, on a numpy-built model: nothing else
compiled before it), the compiled model (every other kernel) and a static solve, in CPU and
wall seconds. One JSON line per process on stdout (or FILE); a summary (medians) at the end.
Uses the machine as it is: run it alone (docs/benchmarks.md, "How the numbers are measured").
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BASE = {"name": "contract", "rods": {"catheter": {
    "length": 0.1, "radius": 0.001, "nodes": 21, "youngs_modulus": 2e8, "density": 1100.0,
    "terms": ["stretch", "bend_twist", "centerline", "tip_load"],
    "tip_load": {"mass": 0.0, "force": [0.0, -0.01, 0.0]}}}}
SCENES = {
    "tip-on-tissue": "tip-on-tissue",  # plane
    "vessel-insertion": "vessel-insertion",  # tube
    "sphere": {**BASE, "obstacles": {"o": {"type": "sphere", "rods": ["catheter"],
                                           "center": [0.07, -0.02, 0.0], "radius": 0.015}}},
    "capsule": {**BASE, "obstacles": {"o": {"type": "capsule", "rods": ["catheter"],
                                            "start": [0.06, -0.012, -0.02],
                                            "end": [0.06, -0.012, 0.02], "radius": 0.008}}},
}


def child(name: str) -> None:
    import numpy as np

    import rodsim
    from rodsim.core.kernels import load_kernel
    from rodsim.core.model import Model
    from rodsim.core.terms.contact import Contact

    out: dict[str, object] = {"scene": name}

    def timed(key, f):
        wall, cpu = time.perf_counter(), time.process_time()
        value = f()
        out[f"{key}_wall"] = time.perf_counter() - wall
        out[f"{key}_cpu"] = time.process_time() - cpu
        return value

    scene = rodsim.load_scene(SCENES[name])
    timed("numba_import", lambda: __import__("numba"))
    model = Model(scene, kernels="numpy")
    term = next(t for t in model.terms if isinstance(t, Contact))
    full = model.full(model.x0)

    def contact() -> None:
        kernel = load_kernel(term)
        arguments = kernel.bind(term.kernel_arguments())
        nodes = term.dofs.shape[0]
        kernel.evaluate(full, *arguments, 1.0, True, np.zeros(full.size + 1),
                        term.dofs.astype(np.int64), True, np.zeros(9 * nodes + 1),
                        np.arange(9 * nodes).reshape(nodes, 3, 3))
        kernel.energy(full, *arguments)

    timed("contact", contact)
    compiled = timed("other_kernels", lambda: Model(scene, kernels="compiled"))
    out["success"] = timed("solve", lambda: rodsim.solve(scene, "static",
                                                         model=compiled)).success
    print(json.dumps(out))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", required=True, help="git revision to compare with")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("-o", "--output", type=Path)
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child)
        return
    work = Path(tempfile.mkdtemp(prefix="contact-compile-"))
    baseline = work / "baseline"
    baseline.mkdir()
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", args.baseline],
                             check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(baseline)], input=archive, check=True)
    trees = {"before": baseline, "after": ROOT}
    rows = []
    stream = open(args.output, "w") if args.output else sys.stdout
    for repeat in range(args.repeats):
        for scene in SCENES:
            for label, tree in trees.items():
                cache = work / f"cache-{label}-{scene}-{repeat}"
                cache.mkdir()
                for state in ("cold", "warm"):
                    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(tree)}
                    done = subprocess.run([sys.executable, str(Path(__file__).resolve()),
                                           "--baseline", args.baseline, "--child", scene],
                                          env=env, cwd=work, capture_output=True, text=True)
                    if done.returncode:  # the baseline may lack a type (capsule)
                        continue
                    row = {"tree": label, "repeat": repeat, "cache": state,
                           "load": os.getloadavg()[0], **json.loads(done.stdout.splitlines()[-1])}
                    rows.append(row)
                    print(json.dumps(row), file=stream, flush=True)
    for scene in SCENES:
        for label in trees:
            for state in ("cold", "warm"):
                mine = [r for r in rows if (r["scene"], r["tree"], r["cache"])
                        == (scene, label, state)]
                if mine:
                    contact = statistics.median(r["contact_cpu"] for r in mine)
                    total = statistics.median(r["contact_cpu"] + r["other_kernels_cpu"]
                                              + r["solve_cpu"] for r in mine)
                    print(f"{scene:17s} {label:6s} {state}: contact kernel {contact:.2f} s CPU, "
                          f"first solve in all {total:.2f} s CPU (median of {len(mine)})",
                          file=sys.stderr)


if __name__ == "__main__":
    main()

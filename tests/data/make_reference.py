"""Regenerate tests/data/scene_reference.npz: the equilibrium of every shipped scene.

For each shipped scene (``rodsim.core.scene.scene_paths()``) the file holds the control
point positions and segment quaternions of every rod at equilibrium with the ``static``
integrator and with the scene's own integrator (``solver.integrator``) when that is another
one (each takes under a second once the kernels are compiled). tests/test_scene_reference.py
re-solves every one and compares to round-off: it is the "no number changes" check of
refactorings.

Rerun this script ONLY when a change of the numbers is intended, and name the change (and
this regeneration) in the commit message. The committed file was generated from commit
7e59fe6 (before the CF archive work):

    git worktree add --detach /tmp/ref 7e59fe6
    PYTHONPATH=/tmp/ref python tests/data/make_reference.py tests/data/scene_reference.npz

A new shipped scene gets its reference with ``--add``, which keeps every stored array as it
is and solves only the scenes the file lacks (their commit is stored as
``commit/<scene>``):

    python tests/data/make_reference.py --add tests/data/scene_reference.npz

``--redo NAME`` (repeatable, with ``--add``) drops one scene's arrays first, to regenerate
the reference of a scene whose numbers are meant to change (say so in the commit).
"""

from __future__ import annotations

import argparse
import subprocess
import time
from pathlib import Path

import numpy as np


def reference(skip: set[str] = frozenset()) -> dict[str, np.ndarray]:
    import rodsim
    from rodsim.core.scene import scene_paths

    arrays: dict[str, np.ndarray] = {}
    for name in sorted(set(scene_paths()) - skip):
        scene = rodsim.load_scene(name)
        integrators = ["static"]
        default = scene.data["solver"]["integrator"]
        if default != "static":
            integrators.append(default)
        for integrator in integrators:
            started = time.perf_counter()
            result = rodsim.solve(scene, integrator)
            elapsed = time.perf_counter() - started
            if not result.success:
                raise SystemExit(f"{name} with {integrator} failed: {result.message}")
            print(f"{name:20s} {integrator:8s} {elapsed:6.2f} s")
            for rod, shape in result.rods.items():
                arrays[f"{name}/{integrator}/{rod}/position"] = shape.positions
                arrays[f"{name}/{integrator}/{rod}/quaternion"] = shape.quaternions
    return arrays


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output", type=Path)
    parser.add_argument("--add", action="store_true",
                        help="keep the file's arrays; solve only the scenes it lacks")
    parser.add_argument("--redo", action="append", default=[], metavar="NAME",
                        help="with --add: drop this scene's arrays first (repeatable)")
    args = parser.parse_args()
    import rodsim

    root = Path(rodsim.__file__).resolve().parents[1]
    commit = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                            text=True, check=False).stdout.strip()
    if args.add:
        with np.load(args.output) as data:
            stored = {key: data[key] for key in data.files
                      if key.split("/")[0] not in args.redo
                      and key.removeprefix("commit/") not in args.redo}
        present = {key.split("/")[0] for key in stored if key.count("/") == 3}
        added = reference(present)
        for name in {key.split("/")[0] for key in added}:
            added[f"commit/{name}"] = np.array(commit)
        np.savez_compressed(args.output, **stored, **added)
        print(f"added {len(added)} arrays to {args.output}")
        return
    arrays = reference()
    arrays["commit"] = np.array(commit)
    arrays["rodsim_version"] = np.array(rodsim.__version__)
    np.savez_compressed(args.output, **arrays)
    print(f"wrote {args.output} ({len(arrays) - 2} arrays, rodsim from {root}, commit {commit})")


if __name__ == "__main__":
    main()

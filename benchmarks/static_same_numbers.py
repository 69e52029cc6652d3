"""Every number of a set of static solves, written by one checkout and compared with another's
(a refactor of the solve must leave them the same bytes).

``dump OUT.pkl``: in this process (with its rodsim), the static solves of six shipped scenes
(tdcr-two-segment, table1-50g, table3-catheter1, catheter-pull-ring, four-tendons,
tendon-conserving) and of 12 seeded tdcr-two-segment tension cases (``rodsim_bench.batch``'s
``random_cases``, seed 2026), each solved twice on one model (the second warm); per solve its
state, residual, statistics (but the wall time), message, verdict, options, tendon tensions,
tension profiles, point states, rods and history. ``compare A.pkl B.pkl``: the fields that
differ, and their count. A baseline's side runs from its own tree (``git archive``):

    PYTHONPATH=$PWD/benchmarks python benchmarks/static_same_numbers.py dump after.pkl
    (cd /tmp/base && PYTHONPATH=$PWD:$PWD/benchmarks python \\
        /path/to/benchmarks/static_same_numbers.py dump before.pkl)
    python benchmarks/static_same_numbers.py compare before.pkl after.pkl
"""

from __future__ import annotations

import pickle
import sys
from pathlib import Path
from typing import Any

import numpy as np

SCENES = ("tdcr-two-segment", "table1-50g", "table3-catheter1", "catheter-pull-ring",
          "four-tendons", "tendon-conserving")


def dump(path: Path) -> None:
    import rodsim
    from rodsim_bench.batch import random_cases

    scenes: list[tuple[str, Any]] = [(name, rodsim.load_scene(name)) for name in SCENES]
    base = rodsim.load_scene("tdcr-two-segment")
    cases = random_cases(12, seed=2026)
    for k in range(12):
        scenes.append((f"tdcr-case{k}", base.with_overrides(
            [f"{key}={float(cases[key][k])!r}" for key in cases if "tension" in key])))
    out = {}
    for name, scene in scenes:
        model = rodsim.build_model(scene)
        for repeat in range(2):
            r = rodsim.solve(scene, "static", model=model)
            out[f"{name}/{repeat}"] = {
                "state": r.state.tobytes(), "success": r.success, "message": r.message,
                "residual": np.float64(r.residual).tobytes(),
                "stats": {k: v for k, v in r.stats.items() if k != "wall_time"},
                "stability": repr(r.stability), "options": r.options,
                "tension": r.tendon_tension, "profiles": repr(r.tension_profiles),
                "slips": repr(r.point_states), "history": repr(r.history),
                "rods": {n: (s.positions.tobytes(), s.quaternions.tobytes())
                         for n, s in r.rods.items()}}
        print(name, r.success, r.stats.get("newton_iters"), flush=True)
    path.write_bytes(pickle.dumps(out))


def compare(first: Path, second: Path) -> int:
    a, b = (pickle.loads(p.read_bytes()) for p in (first, second))
    if a.keys() != b.keys():
        print("the two hold different solves")
        return 1
    different = [(key, field) for key in a for field in a[key] if a[key][field] != b[key][field]]
    for key, field in different:
        print("different:", key, field)
    print(f"{len(a)} solves compared, {len(different)} fields different")
    return 1 if different else 0


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "dump":
        dump(Path(sys.argv[2]))
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        sys.exit(compare(Path(sys.argv[2]), Path(sys.argv[3])))
    else:
        sys.exit(__doc__)

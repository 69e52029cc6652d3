"""The compiled kernels are cached on disk: a second process loads them instead of compiling.

Two fresh interpreters evaluate the same scenes with ``solver.kernels = "compiled"`` and a
private numba cache folder (NUMBA_CACHE_DIR): the first compiles (cache misses), the second
must find every kernel in the cache (hits, no miss). Each reports numba's own dispatcher
statistics.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow  # two fresh interpreters, the first compiling every kernel

SCRIPT = """
import json, sys
import numpy as np
import rodsim
from rodsim.core.model import Model
misses = hits = 0
for name in ("table1-50g", "table3-catheter1"):
    model = Model(rodsim.load_scene(name), "compiled")
    model.evaluate(model.x0)
    for call in model._kernel_calls:
        stats = call.kernel.evaluate.stats
        misses += sum(stats.cache_misses.values())
        hits += sum(stats.cache_hits.values())
print(json.dumps({"misses": misses, "hits": hits}))
"""


def run_fresh(cache: str) -> dict[str, int]:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    done = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True,
                          text=True, timeout=600, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_a_second_process_loads_the_kernels_from_the_disk_cache(tmp_path):
    first = run_fresh(str(tmp_path))
    second = run_fresh(str(tmp_path))
    print(f"first process: {first}; second process: {second}")
    assert first["misses"] > 0, "the first process should compile into the empty cache"
    assert second["misses"] == 0, "the second process recompiled a kernel"
    assert second["hits"] > 0

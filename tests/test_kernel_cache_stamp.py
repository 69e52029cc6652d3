"""The kernels' disk cache follows every kernel source, not only a function's own file
(rodsim/core/kernel_cache_stamp.py).

The end-to-end check edits a helper module in a temporary copy of the package: numba alone
keeps the dependent kernel's cached code (its own file did not change) and the old number;
the stamp removes that code and the kernel computes the new one. The rest checks the stamp's
parts on their own: a matching stamp removes nothing, a changed one removes the kernel
modules' cache files only, and the digest covers every module the kernels compile in.
"""

from __future__ import annotations

import ast
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from rodsim.core.kernel_cache_stamp import (
    KERNEL_FOLDER,
    OUTSIDE_SOURCES,
    STAMP_PREFIX,
    kernel_sources,
    refresh_cache,
    source_digest,
    stamp_name,
)

PACKAGE = KERNEL_FOLDER.parent.parent

#: Evaluates constant_force (which inlines _scatter.add_force) on one element of force
#: (1, 1, 1) at scale 2 and reports the result, numba's statistics and the stamp's work.
SCRIPT = """
import json
import numpy as np
import rodsim
import rodsim.core.kernels as kernels
from rodsim.core.kernels import constant_force
force = np.zeros(3)
constant_force.evaluate(np.zeros(3), np.ones((1, 3)), 2.0, True, force,
                        np.array([[0, 1, 2]]), False, np.zeros(1), np.zeros((1, 1, 1), np.int64))
stats = constant_force.evaluate.stats
print(json.dumps({"force": force.tolist(), "misses": sum(stats.cache_misses.values()),
                  "hits": sum(stats.cache_hits.values()), "cache": str(stats.cache_path),
                  "removed": list(kernels.REMOVED_CACHE_FILES), "package": rodsim.__file__}))
"""


def _copy_package(root: Path) -> Path:
    """A copy of the rodsim package under ``root`` without compiled files; its kernels
    folder."""
    shutil.copytree(PACKAGE, root / "rodsim", ignore=shutil.ignore_patterns("__pycache__"))
    return root / "rodsim" / "core" / "kernels"


def _run(root: Path, cache: Path | None) -> dict:
    """SCRIPT in a fresh interpreter importing the copy under ``root``; numba's cache in
    ``cache`` (NUMBA_CACHE_DIR) or, for None, where numba puts it by itself."""
    env = {key: value for key, value in os.environ.items() if key != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(root)
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = str(cache)
    done = subprocess.run([sys.executable, "-c", SCRIPT], env=env, cwd=root,
                          capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert report["package"].startswith(str(root)), report
    return report


@pytest.mark.slow  # a new process compiles a kernel: 3.1 s of CPU; the digest's own
# tests below (a helper edit changes it) run every time
def test_a_helper_edit_reaches_the_kernel_that_inlines_it(tmp_path):
    """Edit only _scatter.py (add_force, inlined into constant_force.evaluate) in a copy:
    the next process computes the edited helper's force, not the cached old one."""
    kernels = _copy_package(tmp_path)
    cache = tmp_path / "cache"
    first = _run(tmp_path, cache)
    assert first["force"] == [2.0, 2.0, 2.0]
    assert first["misses"] > 0
    second = _run(tmp_path, cache)
    assert second["force"] == [2.0, 2.0, 2.0]
    assert second["removed"] == [], "the stamp matched: nothing may be removed"
    assert second["hits"] > 0 and second["misses"] == 0, "the cached code should load"
    assert Path(second["cache"]).parent == cache

    scatter = kernels / "_scatter.py"
    old = "force[target[e, a]] += scale * local[a]"
    assert old in scatter.read_text()
    scatter.write_text(scatter.read_text().replace(old, "force[target[e, a]] += 3.0 * scale "
                                                        "* local[a]"))
    third = _run(tmp_path, cache)
    assert third["force"] == [6.0, 6.0, 6.0], "the dependent kernel ran the old helper"
    assert any(name.startswith("constant_force.evaluate-") for name in third["removed"])
    assert third["misses"] > 0
    digest = source_digest(sorted(kernels.glob("*.py"))
                           + [kernels.parent / name for name in OUTSIDE_SOURCES])
    assert _stamps(Path(third["cache"])) == [stamp_name(digest)]


def _stamps(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith(STAMP_PREFIX))


def test_without_numba_cache_dir_the_stamp_sits_beside_the_modules(tmp_path):
    """numba's in-tree choice (a writable __pycache__ beside the modules) is found too."""
    kernels = _copy_package(tmp_path)
    env = {key: value for key, value in os.environ.items() if key != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(tmp_path)
    subprocess.run([sys.executable, "-c", "import rodsim.core.kernels"], env=env,
                   cwd=tmp_path, check=True, timeout=300)
    assert len(_stamps(kernels / "__pycache__")) == 1


def _fill(folder: Path) -> list[str]:
    """Fake cache files: two of kernel modules, and others that are not theirs."""
    names = ["tendon_string.evaluate_group-40.py311.nbi",
             "tendon_string.evaluate_group-40.py311.1.nbc",
             "other_module.f-3.py311.nbi", "tendon_string.cpython-311.pyc", "notes.txt"]
    for name in names:
        (folder / name).write_bytes(b"x")
    return names


def test_a_matching_stamp_removes_nothing(tmp_path):
    names = _fill(tmp_path)
    (tmp_path / stamp_name("abc")).touch()
    assert refresh_cache(tmp_path, "abc") == []
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([*names, stamp_name("abc")])


def test_a_changed_or_missing_stamp_removes_the_kernel_cache_files_only(tmp_path):
    names = _fill(tmp_path)
    kernel_files = names[:2]
    assert sorted(refresh_cache(tmp_path, "abc")) == sorted(kernel_files)  # no stamp yet
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == sorted([*names[2:], stamp_name("abc")]), "another file moved"
    _fill(tmp_path)
    assert refresh_cache(tmp_path, "abc") == []
    assert sorted(refresh_cache(tmp_path, "def")) == sorted(kernel_files)
    assert _stamps(tmp_path) == [stamp_name("def")], "the old stamp must go"


def test_the_digest_follows_a_helper_and_a_new_module(tmp_path):
    """One byte of tendon_string_path.py, or one more file, changes the digest."""
    copies = []
    for path in kernel_sources():
        copy = tmp_path / path.name
        copy.write_bytes(path.read_bytes())
        copies.append(copy)
    before = source_digest(copies)
    assert before == source_digest()
    helper = tmp_path / "tendon_string_path.py"
    helper.write_bytes(helper.read_bytes() + b"\n")
    assert source_digest(copies) != before
    helper.write_bytes(helper.read_bytes()[:-1])
    assert source_digest(copies) == before
    extra = tmp_path / "new_kernel.py"
    extra.write_bytes(b"")
    assert source_digest([*copies, extra]) != before


def _rodsim_imports(path: Path) -> set[str]:
    """The rodsim modules ``path`` imports (any depth, a ``from a import b`` as ``a.b``
    and ``a``)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            found.add(node.module)
            found.update(f"{node.module}.{alias.name}" for alias in node.names)
    return {name for name in found if name.startswith("rodsim.")}


def test_the_digest_covers_every_module_the_kernels_compile_in():
    """Every rodsim module a kernel module imports, directly or through another, outside
    the kernels folder is one of OUTSIDE_SOURCES (its functions or constants become the
    kernels' machine code). The package's __init__ compiles nothing: its imports (the
    terms' types, the stamp itself) are left out."""
    core = KERNEL_FOLDER.parent
    outside: set[Path] = set()
    todo = [path for path in sorted(KERNEL_FOLDER.glob("*.py")) if path.name != "__init__.py"]
    while todo:
        for module in _rodsim_imports(todo.pop()):
            if module.startswith("rodsim.core.kernels"):
                continue
            file = PACKAGE.parent / (module.replace(".", "/") + ".py")
            if file.exists() and file not in outside:
                outside.add(file)
                todo.append(file)
    assert outside, "the kernels import rodsim.core.rod.quaternion at least"
    assert sorted(str(file.relative_to(core)) for file in outside) == sorted(OUTSIDE_SOURCES)

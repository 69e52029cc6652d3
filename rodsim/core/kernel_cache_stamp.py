"""The source stamp of the compiled kernels' disk cache: a helper's edit recompiles its users.

numba keys the cached machine code of a function (``njit(cache=True)``) on its own file's
source alone. A kernel that inlines or calls a function of another module (``tendon_string``'s
``evaluate_group`` and ``tendon_string_path``, every kernel and ``_scatter``) or compiles in
a constant of one (``_quaternion`` and rodsim/core/rod/quaternion.py's arrays,
``tendon_string_path`` and rodsim/core/tendon_friction.py's thresholds) keeps its cached
code when only that other module changes: a checkout that edits a helper alone ran the old
code, and the same scene gave the old numbers, until the cache files were deleted by hand.

So before the first kernel module is imported in a process (``rodsim.core.kernels`` calls
``check_kernel_cache`` when it is imported), the sources of every kernel module (each .py in
rodsim/core/kernels) and of the modules outside it that the kernels compile in
(``OUTSIDE_SOURCES``) are hashed together (``source_digest``: SHA-256 of their names and
bytes, about 1 ms) and compared with the stamp in the folder where numba keeps the kernels'
cache (``cache_folder``: the folder numba's own locators choose for a file
of rodsim/core/kernels: ``NUMBA_CACHE_DIR``, else ``__pycache__`` beside the modules when it
is writable, else numba's user cache folder). The stamp is an empty file named by the
digest (``stamp_name``): its existence is the comparison, and creating it is atomic, with no
content to be read half written (so no write-then-rename here beside rodsim/io/atomic.py,
which the core layer may not import). When there is no stamp of the current digest (a source
changed, or a cache from before stamps), the old stamps and the kernel modules' cache files
(``*.nbi``, ``*.nbc``) in that folder are removed and then the new stamp is created. Each
cache folder has its own stamp. The functions compiled from a module outside the kernels
folder keep their own cache where numba puts it (``contact_penalty.onset``): numba checks
those against their own source, which is all their code depends on.

Concurrent processes: two processes that both find no current stamp both remove the files;
the second may remove what the first has just compiled. That costs a recompile, never a wrong
number (both compile the same sources, numba writes each file by rename and reads a removed
one as a miss), and no process fails: a file already gone is skipped, and a folder where a
file cannot be removed or the stamp created is left without a current stamp (the next
process tries again; numba caches nothing in a folder it cannot write either).

Nothing here imports numba before a kernel is wanted: ``import rodsim`` does not load this
module, and without numba there is no cache to check.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

__all__ = ["KERNEL_FOLDER", "OUTSIDE_SOURCES", "STAMP_PREFIX", "STAMP_SUFFIX", "cache_folder",
           "check_kernel_cache", "kernel_sources", "refresh_cache", "source_digest",
           "stamp_name"]

#: The kernel modules' folder (rodsim/core/kernels).
KERNEL_FOLDER = Path(__file__).resolve().parent / "kernels"
#: Modules outside the kernels folder whose functions or constants a kernel compiles in,
#: relative to rodsim/core (tests/test_kernel_cache_stamp.py checks the list against the
#: kernels' imports).
OUTSIDE_SOURCES = ("contact_penalty.py", "displacement_friction.py", "rod/quaternion.py",
                   "tendon_friction.py", "turn_gradient.py")
#: A stamp file's name in a cache folder: the prefix, the digest, the suffix.
STAMP_PREFIX, STAMP_SUFFIX = "rodsim-kernels-", ".stamp"


def kernel_sources() -> list[Path]:
    """The files the kernels' machine code is compiled from: every .py of the kernels folder
    (sorted by name), then ``OUTSIDE_SOURCES``."""
    core = KERNEL_FOLDER.parent
    return sorted(KERNEL_FOLDER.glob("*.py")) + [core / name for name in OUTSIDE_SOURCES]


def source_digest(paths: Iterable[Path] | None = None) -> str:
    """SHA-256 (hex) of the files' names and bytes, in order (``kernel_sources`` by default);
    a file's name counts, so a module renamed or added changes it too."""
    digest = hashlib.sha256()
    for path in kernel_sources() if paths is None else paths:
        data = path.read_bytes()
        digest.update(f"{path.name}\0{len(data)}\0".encode())
        digest.update(data)
    return digest.hexdigest()


def cache_folder(probe: Callable[..., Any]) -> Path | None:
    """The folder numba caches the functions of ``probe``'s file in (``probe``: any function
    defined in rodsim/core/kernels), found by numba's own locators (so ``NUMBA_CACHE_DIR``
    and ``NUMBA_CACHE_LOCATOR_CLASSES`` count) and created as numba would; None without numba
    or when numba finds no writable folder (it then caches nothing)."""
    try:
        from numba.core.caching import CompileResultCacheImpl
    except ImportError:
        return None
    try:
        return Path(CompileResultCacheImpl(probe).locator.get_cache_path())
    except (RuntimeError, OSError):
        return None


def stamp_name(digest: str) -> str:
    """The name of the stamp file of ``digest``: the digest is the name, the file is empty."""
    return f"{STAMP_PREFIX}{digest}{STAMP_SUFFIX}"


def _kernel_cache_file(name: str, modules: set[str]) -> bool:
    """Whether ``name`` is a numba cache file (index or data) of a function of one of
    ``modules`` (numba names them ``module.function-line.pyXY[.N].nbc|.nbi``)."""
    return name.endswith((".nbi", ".nbc")) and name.split(".", 1)[0] in modules


def refresh_cache(folder: Path, digest: str) -> list[str]:
    """Compare ``digest`` with ``folder``'s stamp; when it differs, remove the old stamp, the
    kernel modules' cache files there, and then create the stamp of ``digest``. Returns the
    names of the cache files removed (none when the stamp matched). A file another process
    removed first is skipped; a folder where a file cannot be removed or the stamp created
    is left without a stamp, so the next process tries again (module docstring)."""
    ours = stamp_name(digest)
    try:
        names = sorted(os.listdir(folder))
    except OSError:
        return []
    if ours in names:
        return []
    modules = {path.stem for path in KERNEL_FOLDER.glob("*.py")}
    old_stamps = [name for name in names
                  if name.startswith(STAMP_PREFIX) and name.endswith(STAMP_SUFFIX)]
    removed: list[str] = []
    for name in old_stamps + [name for name in names if _kernel_cache_file(name, modules)]:
        try:
            os.remove(folder / name)
        except FileNotFoundError:
            continue  # another process removed it first
        except OSError:
            return removed  # not ours to remove: no stamp, the next process tries again
        if name not in old_stamps:
            removed.append(name)
    try:
        os.close(os.open(folder / ours, os.O_WRONLY | os.O_CREAT, 0o644))
    except OSError:
        pass  # an unwritable folder: numba writes no cache there either
    return removed


def check_kernel_cache(probe: Callable[..., Any]) -> list[str]:
    """``refresh_cache`` of the kernels' cache folder (``cache_folder(probe)``) with the
    digest of their sources; the names of the files removed. Called once per process by
    ``rodsim.core.kernels`` before any kernel module is imported."""
    folder = cache_folder(probe)
    if folder is None:
        return []
    return refresh_cache(folder, source_digest())

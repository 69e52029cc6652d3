"""A scene's memory estimate, checked before its model is built.

Peak memory grows linearly with the total number of control points: the state, the sparse
Jacobian (about 120 entries per control point) and the LU factors of its linear solves;
``BYTES_PER_NODE`` rounds the largest measured cost per control point up (18–24 kB:
docs/benchmark-history.md, "Measurements behind the core's constants"). A scene whose estimate
exceeds the machine's physical memory, or what the process's address-space limit
(``ulimit -v``) leaves, is refused (``SceneError``, exit 2) rather than left to the
out-of-memory killer after minutes of assembly.
"""

from __future__ import annotations

import os

from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError

__all__ = ["BYTES_PER_NODE", "estimated_bytes", "physical_memory", "process_limit",
           "check_memory"]

#: Estimated peak memory per control point [bytes] (module docstring).
BYTES_PER_NODE = 25_000


def estimated_bytes(scene: Scene) -> int:
    """Estimated peak memory [bytes] of solving ``scene``."""
    return BYTES_PER_NODE * sum(rod.nodes for rod in scene.rods.values())


def physical_memory() -> int | None:
    """The machine's physical memory [bytes], or None where it cannot be read."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def process_limit() -> int | None:
    """What the process may still allocate under its address-space limit (``ulimit -v``,
    RLIMIT_AS) [bytes]: the limit minus the address space already mapped; None without a
    limit (or where it cannot be read)."""
    try:
        import resource

        limit = resource.getrlimit(resource.RLIMIT_AS)[0]
        if limit == resource.RLIM_INFINITY:
            return None
        with open("/proc/self/statm", encoding="ascii") as statm:
            mapped = int(statm.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (ImportError, OSError, ValueError, IndexError):
        return None
    return max(limit - mapped, 0)


def check_memory(scene: Scene, available: int | None = None) -> None:
    """Raise SceneError when ``scene``'s estimate exceeds ``available`` bytes (default: the
    physical memory, or what the process's address-space limit leaves if that is less),
    saying the estimate."""
    what = "this machine's"
    if available is None:
        available = physical_memory()
        limit = process_limit()
        if limit is not None and (available is None or limit < available):
            available, what = limit, "the process's limit (ulimit -v) leaves of its"
    needed = estimated_bytes(scene)
    if available is not None and needed > available:
        nodes = needed // BYTES_PER_NODE
        raise SceneError(f"{nodes} control points in all need an estimated "
                         f"{needed / 1e9:.3g} GB, more than {what} "
                         f"{available / 1e9:.3g} GB of memory; lower rods.<rod>.nodes")

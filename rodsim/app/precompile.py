"""Compile the kernels ahead of time: ``rodsim compile`` and ``rodsim.compile_kernels``.

The compiled kernels (rodsim/core/kernels/) are numba functions cached on disk
(``cache=True``): the first process that calls one with new argument types compiles it
(seconds per kernel: 4.2 s for table1-50g's, docs/benchmark-history.md, "Round 17's figures
page", "Kernels") and writes the machine code where numba keeps its cache (``__pycache__``
beside the module when that is writable, else numba's user cache folder, or
``NUMBA_CACHE_DIR``); every later process loads it. On a fresh install that first compile
lands in whichever run first needs a kernel.

``compile_kernels`` moves it to a moment the user chooses: it solves, with
``solver.kernels = "compiled"``, every shipped scene with its own integrator, table1-50g
with every other registered integrator, the small scenes of rodsim/app/kernel_coverage.py
(every term, obstacle type, load, tendon routing and control, friction, joint) and one
model large enough for the compiled band passes, so that each kernel is compiled with the
argument types a solve gives it, by the code that gives them; and the Arnoldi steps of a
Tracker's verdicts (rodsim/core/kernels/_arnoldi.py), which no solve calls. A later process
then compiles nothing (tests/test_precompile.py counts numba's cache misses and the cache's
files).
Nothing here changes a number: the solves' results are dropped.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

__all__ = ["CompileSummary", "KernelCounts", "compile_kernels", "compile_steps",
           "kernel_counts"]

#: The package whose numba functions are counted.
KERNEL_PACKAGE = "rodsim.core.kernels"


@dataclass(frozen=True)
class KernelCounts:
    """What numba did in this process for rodsim's compiled functions (numba's own
    dispatcher statistics)."""

    #: Compiled functions called (each with at least one signature).
    kernels: int
    #: Their signatures (one per argument types they were called with).
    signatures: int
    #: Signatures compiled in this process (cache misses).
    compiled: int
    #: Signatures loaded from the disk cache (cache hits).
    loaded: int
    #: Where numba keeps the cache of one of them ("" when none was called).
    cache: str = ""


def _dispatchers() -> list[Any]:
    """rodsim's numba functions loaded in this process, each once."""
    seen: dict[int, Any] = {}
    for name, module in list(sys.modules.items()):
        if module is None or not (name == KERNEL_PACKAGE
                                  or name.startswith(KERNEL_PACKAGE + ".")):
            continue
        for value in vars(module).values():
            if hasattr(value, "py_func") and hasattr(value, "stats") and hasattr(
                    value, "signatures"):
                seen.setdefault(id(value), value)
    return list(seen.values())


def kernel_counts() -> KernelCounts:
    """This process's ``KernelCounts`` (zeros when no kernel module is loaded: nothing
    here imports numba)."""
    kernels = signatures = compiled = loaded = 0
    cache = ""
    for dispatcher in _dispatchers():
        if not dispatcher.signatures:
            continue
        kernels += 1
        signatures += len(dispatcher.signatures)
        stats = dispatcher.stats
        compiled += sum(stats.cache_misses.values())
        loaded += sum(stats.cache_hits.values())
        cache = cache or str(stats.cache_path or "")
    return KernelCounts(kernels, signatures, compiled, loaded, cache)


@dataclass(frozen=True)
class CompileStep:
    """One solve of ``compile_kernels``: a scene (a shipped name or a scene table), the
    integrator (None: the scene's own) and overrides."""

    label: str
    scene: Any
    integrator: str | None = None
    overrides: tuple[str, ...] = ()


def compile_steps(scenes: Iterable[str] | None = None) -> list[CompileStep]:
    """The solves of ``compile_kernels`` (module docstring); ``scenes``: only these shipped
    scenes or rodsim/app/kernel_coverage.py scene names, each with its own integrator and
    with ``static`` (the error estimates' re-solves, batches, tracks; ValueError naming the
    unknown ones). Another integrator may call a kernel with other argument types: the
    full list solves table1-50g with each."""
    from rodsim.app.kernel_coverage import LARGE_SCENE, coverage_scenes
    from rodsim.core.scene import scene_paths
    from rodsim.solvers import registered_integrators

    shipped = list(scene_paths())
    small = coverage_scenes()
    if scenes is not None:
        names = list(scenes)
        unknown = [n for n in names if n not in shipped and n not in small]
        if unknown:
            raise ValueError(f"no scene {', '.join(map(repr, unknown))} to compile for; the "
                             f"scenes are {', '.join([*shipped, *small])}")
        steps = []
        for n in names:
            steps.append(CompileStep(n, small.get(n, n),
                                     "static" if n in small else None))
            if n not in small:
                steps.append(CompileStep(f"{n} (static)", n, "static"))
        return steps
    steps = [CompileStep(n, n) for n in shipped]
    steps += [CompileStep(f"table1-50g ({kind})", "table1-50g", kind)
              for kind in registered_integrators() if kind != "cvode"]
    steps += [CompileStep(n, scene, "static") for n, scene in small.items()]
    name, overrides = LARGE_SCENE
    steps.append(CompileStep(f"{name} (large)", name, None, overrides))
    return steps


@dataclass(frozen=True)
class CompileSummary:
    """What ``compile_kernels`` did."""

    #: The solves made.
    steps: int
    #: This process's counts once they are done (``kernel_counts``).
    counts: KernelCounts
    #: CPU time of the call (user + system of this process) [s]: a report, never a choice.
    seconds: float
    #: The solves that raised, with their message (their kernels may be missing).
    failed: tuple[str, ...] = ()

    def text(self) -> str:
        """The summary lines."""
        counts = self.counts
        lines = [f"compiled    {counts.compiled} kernel signatures and loaded {counts.loaded} "
                 f"from the cache ({counts.kernels} kernels, {self.steps} solves) in "
                 f"{self.seconds:.1f} s CPU",
                 f"cache       {counts.cache or '(no kernel called)'}"]
        lines += [f"failed      {failure}" for failure in self.failed]
        return "\n".join(lines)


def _compile_verdict_steps() -> None:
    """The compiled Arnoldi steps of a sequence's stability verdicts (a Tracker's, a track's:
    rodsim/core/stability_tracking.py), which no solve calls: compiled on a small band LU
    through the wrapper a verdict calls them by, so with its argument types."""
    import numpy as np
    from scipy.linalg import lapack

    from rodsim.core.stability_band import BandLU
    from rodsim.core.stability_tracking import _band_steps

    ab = np.zeros((4, 6), order="F")
    ab[2], ab[1, 1:], ab[3, :-1] = 2.0, 0.5, 0.5
    lu, pivots, _ = lapack.dgbtrf(ab, 1, 1)
    basis = np.zeros((4, 6))
    basis[0, 0] = 1.0
    _band_steps(BandLU(lu, pivots, 1, 1), -1.0)(basis, np.zeros((4, 3)), 0, 3)


def compile_kernels(scenes: Sequence[str] | None = None,
                    progress: Callable[[float | None, str], None] | None = None
                    ) -> CompileSummary:
    """Compile (or load) every kernel and signature a scene can need into numba's on-disk
    cache (module docstring); ``scenes``: only those shipped or coverage scenes.
    ``progress``: a callback ``(fraction, status)`` (``rodsim.app.progress``).
    ValueError for an unknown scene name."""
    from rodsim.app.api import solve

    steps = compile_steps(scenes)
    start = time.process_time()
    failed: list[str] = []
    for index, step in enumerate(steps):
        if progress is not None:
            progress(index / len(steps), f"compiling kernels: {step.label}")
        try:
            solve(step.scene, step.integrator,
                  overrides=(*step.overrides, "solver.kernels=compiled"))
        except Exception as exc:  # noqa: BLE001 - one scene's failure never stops the rest
            failed.append(f"{step.label}: {exc}")
    if scenes is None:
        _compile_verdict_steps()
    if progress is not None:
        progress(1.0, f"compiled the kernels of {len(steps)} solves")
    return CompileSummary(len(steps), kernel_counts(), time.process_time() - start,
                          tuple(failed))

"""Compiled (numba) kernels of the energy terms, one file per term, loaded on first use.

Each module defines ``evaluate``, compiled with ``numba.njit(cache=True)`` so the machine
code is written to disk (``__pycache__`` beside the module, or numba's user cache) and a
second process loads it instead of compiling. Every kernel has the same signature::

    evaluate(x, *constants, scale, want_force, force, force_target,
             want_jacobian, jacobian, jacobian_target)

``x`` is the full state, ``constants`` what the term's ``kernel_arguments()`` returns,
``scale`` a factor on the whole output (load fraction, penalty continuation). For element
``e`` the kernel adds ``scale`` × its force on local coordinate ``a`` to
``force[force_target[e, a]]`` and ``scale`` × ∂F_a/∂x_b to
``jacobian[jacobian_target[e, a, b]]`` — the model's free-coordinate index and CSC data slot,
with one dump slot past the end for clamped coordinates. A module may also define
``energy(x, *constants) -> float`` (the term's energy, unscaled), which the line searches of
``static`` and ``paper`` evaluate; without it the model calls the term's numpy ``energy``.
The numpy methods of the term are the reference the kernel must reproduce
(tests/test_kernels.py).

Nothing here is imported until a model evaluates with ``solver.kernels = "compiled"``, so
``import rodsim`` does not pay for numba.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rodsim.core.terms.base import Term

__all__ = ["load_kernel"]


def load_kernel(term: Term) -> tuple[Callable[..., None], Callable[..., float] | None]:
    """The compiled ``evaluate`` and ``energy`` (None where the module has none) of a term
    (compiled, or loaded from the disk cache, on the first call with each argument type)."""
    name = term.kernel or term.name
    try:
        module = importlib.import_module(f"{__name__}.{name}")
    except ModuleNotFoundError as exc:
        if exc.name == "numba":
            raise RuntimeError("solver.kernels = 'compiled' needs numba (pip install numba); "
                               "solver.kernels = 'numpy' runs without it") from None
        raise
    return module.evaluate, getattr(module, "energy", None)

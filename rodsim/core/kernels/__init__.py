"""Compiled (numba) kernels of the energy terms, one file per term, loaded on first use.

Each module defines ``evaluate``, compiled with ``numba.njit(cache=True)`` so the machine
code is written to disk (``__pycache__`` beside the module, or numba's user cache) and a
second process loads it instead of compiling. Every kernel has the same signature::

    evaluate(x, *constants, scale, want_force, force, force_target,
             want_jacobian, jacobian, jacobian_target)

``x`` is the full state, ``constants`` the term's constants, ``scale`` a factor on the whole
output (load fraction, penalty continuation). A term hands its constants *by name*: its
``kernel_arguments()`` returns a mapping from the kernel's parameter names to values, and
``Kernel.bind`` orders them by the kernel's own signature (a missing or unknown name is
an error, never a silently shifted argument). For element ``e`` the kernel adds ``scale`` ×
its force on local coordinate ``a`` to ``force[force_target[e, a]]`` and ``scale`` ×
∂F_a/∂x_b to ``jacobian[jacobian_target[e, a, b]]`` — the model's free-coordinate index and
CSC data slot, with one dump slot past the end for clamped coordinates. A module may also
define ``energy(x, *constants) -> float`` (the term's energy, unscaled, the same constants),
which the line searches of ``static`` and ``paper`` evaluate; without it the model calls the
term's numpy ``energy``. The numpy methods of the term are the reference the kernel must
reproduce (tests/test_kernels.py).

A module may also define ``evaluate_group``, one call for several terms of its kind (the
string tendons of one catheter)::

    evaluate_group(x, *group_constants, scales, want_force, force, force_target,
                   want_jacobian, jacobian, jacobian_target)

with the terms' constants packed by the term class (``Term.group_arguments``, bound by
name like a single term's), ``scales`` one factor per term, and the members' target maps
stacked along their elements in term order. It must add what the members' ``evaluate``
calls add, in the same order (rodsim/core/kernel_group.py).

Such a module's energies may come in one call too: ``energy_group(x, *group_constants,
energies)`` (exactly ``evaluate_group``'s constants) writes each member's energy, unscaled,
into ``energies`` — the numbers its own ``energy`` gives, bit for bit. It lives in a
module ``NAME_energy`` beside the kernel module ``NAME`` (``tendon_string_energy``).

Nothing here is imported until a model evaluates with ``solver.kernels = "compiled"``, so
``import rodsim`` does not pay for numba.

numba checks a function's cached machine code against its own file only, so a kernel that
inlines a helper of another module (``tendon_string`` and ``tendon_string_path``) would keep
running the helper's old code after the helper alone is edited. Importing this package
therefore first checks the cache folder's stamp against a digest of all the kernels' sources
and removes the kernels' cache files when they differ (rodsim/core/kernel_cache_stamp.py),
before any kernel module is imported.
"""

from __future__ import annotations

import functools
import importlib
import importlib.util
import inspect
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, NamedTuple

from rodsim.core.kernel_cache_stamp import check_kernel_cache

if TYPE_CHECKING:
    from rodsim.core.terms.base import KernelArguments, Term

__all__ = ["Kernel", "load_kernel", "NUMPY_KERNEL", "OUTPUT_PARAMETERS", "GROUP_OUTPUT_PARAMETERS",
           "signature_constants"]

#: The parameters every ``evaluate`` takes after its constants, in this order.
OUTPUT_PARAMETERS = ("scale", "want_force", "force", "force_target", "want_jacobian",
                     "jacobian", "jacobian_target")
#: The parameters an ``evaluate_group`` takes after its constants, in this order.
GROUP_OUTPUT_PARAMETERS = ("scales", *OUTPUT_PARAMETERS[1:])


class Kernel(NamedTuple):
    """A term's compiled kernel module: ``evaluate``, ``energy`` (None where the module has
    none) and the names of the constants both take after the state ``x``, read from
    ``evaluate``'s signature; ``evaluate_group`` and its constants where the module has one
    (else None and ())."""

    evaluate: Callable[..., None]
    energy: Callable[..., float] | None
    constants: tuple[str, ...]
    module: str
    evaluate_group: Callable[..., None] | None = None
    group_constants: tuple[str, ...] = ()
    #: The companion module's ``energy_group`` (module docstring), or None.
    energy_group: Callable[..., None] | None = None

    def bind(self, arguments: KernelArguments) -> tuple[Any, ...]:
        """The constants ``arguments`` names, in the order of the kernel's signature; raises
        TypeError naming the kernel when a name is missing or unknown."""
        return _bind(self.module, self.constants, arguments)

    def bind_group(self, arguments: KernelArguments) -> tuple[Any, ...]:
        """``bind`` for ``evaluate_group``'s constants."""
        return _bind(self.module, self.group_constants, arguments)


def _bind(module: str, constants: tuple[str, ...], arguments: KernelArguments) -> tuple[
        Any, ...]:
    """The constants ``arguments`` names, in the order ``constants``; TypeError naming the
    kernel module when a name is missing or unknown."""
    missing = [name for name in constants if name not in arguments]
    unknown = [name for name in arguments if name not in constants]
    if missing or unknown:
        raise TypeError(f"kernel rodsim.core.kernels.{module}: "
                        f"missing constants {missing}, unknown constants {unknown} "
                        f"(its signature takes {', '.join(constants)})")
    return tuple(arguments[name] for name in constants)


def signature_constants(function: Callable[..., Any], outputs: tuple[str, ...] = ()) -> tuple[
        str, ...]:
    """The parameter names of a kernel function between the state ``x`` and ``outputs``
    (the trailing parameters, checked to be exactly those)."""
    python = getattr(function, "py_func", function)  # a numba dispatcher keeps the source
    names = tuple(inspect.signature(python).parameters)
    if not names or names[0] != "x":
        raise TypeError(f"kernel {python.__module__}.{python.__name__}: first parameter "
                        f"must be the state x, got {names[:1]}")
    if outputs:
        if names[-len(outputs):] != outputs:
            raise TypeError(f"kernel {python.__module__}.{python.__name__}: must end with "
                            f"{', '.join(outputs)}")
        return names[1:-len(outputs)]
    return names[1:]


def load_kernel(term: Term) -> Kernel:
    """The compiled kernel of a term (compiled, or loaded from the disk cache, on the first
    call with each argument type); TypeError when its ``energy`` takes other constants than
    its ``evaluate``. A term without one (``Term.compiled`` False) gets ``NUMPY_KERNEL``,
    its own numpy methods behind the kernels' signature."""
    if not term.compiled:
        return NUMPY_KERNEL
    return _kernel_named(term.kernel or term.name)


def _numpy_evaluate(x: Any, term: Term, scale: float, want_force: bool, force: Any,
                    force_target: Any, want_jacobian: bool, jacobian: Any,
                    jacobian_target: Any) -> None:
    """A kernel's ``evaluate`` made of the term's numpy methods: scale × its element forces
    and Jacobians added at the targets (the dump slots included, as a kernel does)."""
    import numpy as np

    if want_force:
        np.add.at(force, force_target, scale * term.element_forces(x))
    if want_jacobian and term.has_jacobian:
        np.add.at(jacobian, jacobian_target, scale * term.element_jacobians(x))


def _numpy_energy(x: Any, term: Term) -> float:
    """A kernel's ``energy`` made of the term's numpy ``energy``."""
    value = term.energy(x)
    return float("nan") if value is None else value


#: The kernel of a term without a compiled one (``Term.compiled`` False): its constant is
#: the term itself (``kernel_arguments`` is not asked).
NUMPY_KERNEL = Kernel(_numpy_evaluate, _numpy_energy, ("term",), "(numpy methods)")


@functools.cache
def _kernel_named(name: str) -> Kernel:
    """``load_kernel`` of the kernel module ``name``, once per process: reading the
    signatures (``inspect``) on every model cost 0.5 ms of each assembly of tdcr-two-segment
    (docs/benchmark-history.md, "Model assembly"). A failure is not cached."""
    try:
        module = importlib.import_module(f"{__name__}.{name}")
    except ModuleNotFoundError as exc:
        if exc.name == "numba":
            raise RuntimeError("solver.kernels = 'compiled' needs numba (pip install numba); "
                               "solver.kernels = 'numpy' runs without it") from None
        raise
    constants = signature_constants(module.evaluate, OUTPUT_PARAMETERS)
    energy = getattr(module, "energy", None)
    if energy is not None and signature_constants(energy) != constants:
        raise TypeError(f"kernel rodsim.core.kernels.{name}: energy takes other constants "
                        f"than evaluate ({', '.join(constants)})")
    group = getattr(module, "evaluate_group", None)
    group_constants = (signature_constants(group, GROUP_OUTPUT_PARAMETERS) if group is not None
                       else ())
    energy_group = None
    if group is not None and importlib.util.find_spec(f"{__name__}.{name}_energy") is not None:
        energy_group = importlib.import_module(f"{__name__}.{name}_energy").energy_group
        if signature_constants(energy_group, ("energies",)) != group_constants:
            raise TypeError(f"kernel rodsim.core.kernels.{name}_energy: energy_group takes "
                            f"other constants than evaluate_group ({', '.join(group_constants)})")
    return Kernel(module.evaluate, energy, constants, name, group, group_constants, energy_group)


def _cache_probe() -> None:
    """A function of this folder: ``check_kernel_cache`` asks numba where it caches one."""


#: The stale cache files this process removed on import (empty when the stamp matched).
REMOVED_CACHE_FILES = tuple(check_kernel_cache(_cache_probe))

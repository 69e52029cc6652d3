"""How the compiled path calls one kernel for several terms: ``KernelGroup``, made from the
model's ``KernelCall`` list by ``kernel_units``.

Each call of a numba kernel has a fixed cost besides its work: the dispatcher checks the
type of each of its arguments (twenty-one for a string tendon: 2.6 µs a call on
tdcr-two-segment, measured with a zero tension, which returns at once) and the kernel
allocates its scratch arrays. A kernel module that defines ``evaluate_group``
(rodsim/core/kernels/__init__.py) takes several terms of its kind in one call, their
constants packed by the term class (``Term.group_arguments``) and their target maps
stacked, and may share work between them (the string tendons of one catheter pass through
the same nodes).

Which terms are grouped is a rule on the terms alone, never on timing: a streak of consecutive
terms (in the model's order) of one class with equal ``Term.group_key`` (not None), whose
kernel has an ``evaluate_group``, whose elements have the same width and that are all
evaluated on the same state (``Term.offsets``), at least two of them. Consecutive, so that
the force vector receives the members' additions in the order of one call per term.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np

from rodsim.core.kernel_call import KernelCall

__all__ = ["KernelGroup", "kernel_units"]


class KernelGroup(NamedTuple):
    """One ``evaluate_group`` call for the terms of ``calls`` (module docstring)."""

    #: The members' own calls, in the model's term order.
    calls: tuple[KernelCall, ...]
    #: The kernel module's ``evaluate_group``.
    evaluate: Callable[..., None]
    #: The members' constants packed by their class, in ``evaluate_group``'s order.
    arguments: tuple[Any, ...]
    #: The members' ``force_target`` stacked along their elements.
    force_target: np.ndarray
    #: The members' ``jacobian_target`` stacked along their elements.
    jacobian_target: np.ndarray
    #: The kernel's ``energy_group`` (the members' energies in one call,
    #: rodsim/core/kernels/__init__.py), or None.
    energy: Callable[..., None] | None = None

    @property
    def offsets(self) -> bool:
        """Whether the members are evaluated on the offset state (``Term.offsets``)."""
        return self.calls[0].term.offsets

    def scales(self, scale: Callable[[int, Any], float]) -> np.ndarray:
        """The factor on each member's output, ``scale(term_index, term)``."""
        return np.array([scale(call.term_index, call.term) for call in self.calls])


def _key(call: KernelCall) -> tuple[Any, ...] | None:
    """What two calls must share to be grouped, or None (evaluated alone)."""
    term = call.term
    key = term.group_key()
    if key is None or call.kernel.evaluate_group is None:
        return None
    return (type(term), key, call.force_target.shape[1], term.offsets)


def _group(streak: Sequence[KernelCall], previous: dict[tuple[int, ...], KernelGroup]
           ) -> KernelGroup:
    """The group of the calls ``streak``; the packed constants and stacked targets of the
    previous group of the same members kept where they are the same objects."""
    known = previous.get(tuple(id(call.term) for call in streak))
    if known is not None and all(a.term is b.term for a, b in zip(known.calls, streak,
                                                                   strict=True)):
        arguments = known.arguments
    else:
        kernel = streak[0].kernel
        arguments = kernel.bind_group(type(streak[0].term).group_arguments(
            [call.term for call in streak]))
    stacked = None
    for group in previous.values():
        if len(group.calls) == len(streak) and all(
                a.force_target is b.force_target and a.jacobian_target is b.jacobian_target
                for a, b in zip(group.calls, streak, strict=True)):
            stacked = group.force_target, group.jacobian_target
            break
    if stacked is None:
        stacked = (np.ascontiguousarray(np.concatenate([c.force_target for c in streak])),
                   np.ascontiguousarray(np.concatenate([c.jacobian_target for c in streak])))
    evaluate = streak[0].kernel.evaluate_group
    assert evaluate is not None
    return KernelGroup(tuple(streak), evaluate, arguments, *stacked, streak[0].kernel.energy_group)


def kernel_units(calls: Sequence[KernelCall], previous: Sequence[KernelCall | KernelGroup]
                 = ()) -> list[KernelCall | KernelGroup]:
    """``calls`` with each streak of consecutive groupable calls (module docstring) made one
    ``KernelGroup``, in order; ``previous``: the units of the model these calls came from
    (what they share with it is not packed again)."""
    kept = {tuple(id(call.term) for call in unit.calls): unit for unit in previous
            if isinstance(unit, KernelGroup)}
    units: list[KernelCall | KernelGroup] = []
    streak: list[KernelCall] = []
    streak_key: tuple[Any, ...] | None = None

    def close() -> None:
        if len(streak) >= 2:
            units.append(_group(streak, kept))
        else:
            units.extend(streak)

    for call in calls:
        key = _key(call)
        if key is not None and key == streak_key:
            streak.append(call)
            continue
        close()
        streak, streak_key = [call], key
    close()
    return units

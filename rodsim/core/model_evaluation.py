"""The evaluation of a model: F(x) = −∂E/∂x (plus non-conservative penalty forces), its
Jacobian ∂F/∂x in the pattern's CSC order, and E(x).

Two evaluation paths compute the same numbers (``solver.kernels``): ``compiled`` (what
``auto``, the default, means for a model) calls each term's numba kernel
(``rodsim.core.kernels``), which accumulates straight into the force vector and the CSC
data; ``numpy`` calls the terms' vectorised numpy methods and scatters their element blocks —
the readable reference. ``tiered`` starts on numpy and moves to the compiled kernels once the
process's numpy evaluations have cost, nominally (never by the clock), what loading the
kernels would (``rodsim.core.kernel_tier``; what ``rodsim run`` uses for ``auto``).
The last states evaluated are remembered (``ModelEvaluation.evaluate``).
"""

from __future__ import annotations

import sys
from typing import Any

import numpy as np
import scipy.sparse as sp

from rodsim.core.kernel_call import KernelCall
from rodsim.core.kernel_group import KernelGroup, kernel_units
from rodsim.core.kernel_tier import PROCESS_TIER, nominal_cost
from rodsim.core.model_manifold import ModelManifold
from rodsim.core.model_pattern import ModelPattern
from rodsim.core.terms import Term

__all__ = ["ModelEvaluation", "EVALUATION_PATHS", "KERNELS", "MEMO_STATES", "MEMO_ENTRIES",
           "REUSE_ENTRIES"]

#: The two evaluation paths.
EVALUATION_PATHS = ("compiled", "numpy")
#: What ``solver.kernels`` may ask a model for (``auto`` is ``compiled`` for a model).
KERNELS = (*EVALUATION_PATHS, "tiered")
#: States whose evaluation a model remembers (:meth:`ModelEvaluation.evaluate`).
MEMO_STATES = 2
#: Largest Jacobian (stored entries) a model remembers (:meth:`ModelEvaluation.evaluate`):
#: 8 MB each; above, one evaluation's time matters less than the memory (F is always kept).
MEMO_ENTRIES = 1 << 20
#: Jacobians (stored entries) from this size on are accumulated into the array of the last
#: such evaluation once no one holds it any more (:func:`_jacobian_zeros`).
REUSE_ENTRIES = 1 << 20

_KEPT_JACOBIAN: np.ndarray | None = None


def _jacobian_zeros(size: int) -> np.ndarray:
    """Zeros of ``size`` for a Jacobian evaluation to accumulate into. From
    ``REUSE_ENTRIES`` on, the array of the last such evaluation when nothing outside
    this function refers to it any more (its data, or any view of it, dropped by whoever
    got it): zeroing warm memory instead of faulting in fresh pages. On table1-50g at
    N = 100 000 (12.3 million entries, 98 MB) the first kernel writing into a fresh array
    took 25–267 ms in a static solve, where zeroing the kept one takes 14 ms and the kernel
    then 16 ms."""
    global _KEPT_JACOBIAN
    if size < REUSE_ENTRIES:
        return np.zeros(size)
    kept = _KEPT_JACOBIAN
    # References to a free array: the global, ``kept`` and getrefcount's argument. Any
    # other (a caller's array or view, another thread's ``kept``) means it is in use.
    if kept is not None and kept.size == size and sys.getrefcount(kept) == 3:
        kept.fill(0.0)
        return kept
    _KEPT_JACOBIAN = out = np.zeros(size)
    return out


class ModelEvaluation(ModelPattern, ModelManifold):
    """The evaluation part of ``rodsim.core.model.Model`` (module docstring)."""

    def _scale(self, index: int, term: Term, load: float) -> float:
        """Factor on one term's output: its continuation scale, times ``load`` for loads."""
        scale = self._scale_list[index]
        return scale * load if term.is_load else scale

    def energy(self, x: np.ndarray, load: float = 1.0) -> float:
        """Total potential energy [J] (raises if a term is not conservative): each term's
        energy times its scale, added in term order; on the compiled path a group of terms
        whose kernel has an ``energy_group`` (the string tendons of a catheter,
        rodsim/core/kernels/tendon_string_energy.py) gives its members' energies in one
        call, the numbers of one call per term, added in the same order."""
        full = self.full(x)
        offsets = self.offsets(x)
        tiered = self._tiered_numpy()
        units = (self._energy_units() if self._compiled()
                 else [(index, term, None) for index, term in enumerate(self.terms)])
        total = 0.0
        for unit in units:
            if isinstance(unit, KernelGroup):
                assert unit.energy is not None
                energies = np.empty(len(unit.calls))
                unit.energy(offsets if unit.offsets else full, *unit.arguments, energies)
                for member, share in zip(unit.calls, energies.tolist(), strict=True):
                    total += self._scale(member.term_index, member.term, load) * share
                continue
            index, term, call = unit
            if call is not None:
                value = call.energy(offsets if term.offsets else full, *call.arguments)
            else:
                value = term.energy(offsets if term.offsets else full)
            if value is None:
                raise ValueError(f"term {term.name!r} is not conservative: no energy")
            total += self._scale(index, term, load) * value
        if tiered:
            PROCESS_TIER.charge(nominal_cost(self.terms, force=True, jacobian=False))
        return total

    def _energy_units(self) -> list[KernelGroup | tuple[int, Term, KernelCall | None]]:
        """What the compiled ``energy`` calls, in term order: a ``KernelGroup`` whose
        kernel has an ``energy_group`` and whose members are all conservative, else per
        term (index, term, its ``KernelCall`` when the kernel has an ``energy`` and the
        term is conservative, else None: its numpy ``energy``); made again when the
        compiled path's units are others."""
        units = self._kernel_unit_list()
        known = self._energy_units_kept
        if known is not None and known[0] is units:
            return known[1]
        plan: list[KernelGroup | tuple[int, Term, KernelCall | None]] = []
        for unit in units:
            if isinstance(unit, KernelGroup) and unit.energy is not None and all(
                    call.term.conservative for call in unit.calls):
                plan.append(unit)
                continue
            for call in (unit.calls if isinstance(unit, KernelGroup) else (unit,)):
                compiled = call.energy is not None and call.term.conservative
                plan.append((call.term_index, call.term, call if compiled else None))
        self._energy_units_kept = units, plan
        return plan

    @property
    def keeps_jacobians(self) -> bool:
        """Whether ``evaluate``'s memo keeps ∂F/∂x (compiled kernels, at most
        ``MEMO_ENTRIES`` entries): a caller that will need J at a state where it asks for F
        can then ask for both in one pass and find J remembered."""
        return self.kernels == "compiled" and self.nnz <= MEMO_ENTRIES

    def force(self, x: np.ndarray, load: float = 1.0) -> np.ndarray:
        """Generalised force F(x) on the free coordinates; loads are scaled by ``load``."""
        return self.evaluate(x, load, jacobian=False)[0]

    def jacobian_data(self, x: np.ndarray, load: float = 1.0) -> np.ndarray:
        """∂F/∂x as the data array of a CSC matrix with the pattern ``pattern``."""
        return self.evaluate(x, load, force=False)[1]

    def evaluate(self, x: np.ndarray, load: float = 1.0, *, force: bool = True,
                 jacobian: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """F(x) and ∂F/∂x (CSC data in ``pattern`` order) in one pass; the one not asked
        for comes back empty.

        The last ``MEMO_STATES`` evaluated states are remembered (∂F/∂x up to
        ``MEMO_ENTRIES``): asked again at the same state and load — a solve's checks
        after it converged evaluate F at the state its last Newton step reached (before a
        rejected polishing trial), the correction residual and the stability verdict ∂F/∂x
        at the same state — it returns copies of the same numbers instead of evaluating
        again."""
        same = None
        x = np.asarray(x)
        for entry in self._memo:
            # np.array_equal's test without its Python wrapper (~2 µs of each call)
            if entry[1] == load and entry[0].shape == x.shape and bool((entry[0] == x).all()):
                known_f, known_j = entry[2], entry[3]
                if (known_f is not None or not force) and (known_j is not None or not jacobian):
                    return (known_f.copy() if known_f is not None and force else np.zeros(0),
                            known_j.copy() if known_j is not None and jacobian else np.zeros(0))
                same = entry  # this state, without the part asked for now
                break
        kept_f, kept_j = (same[2], same[3]) if same is not None else (None, None)
        if kept_f is not None and force and jacobian:  # F known here: J alone
            f, j = kept_f.copy(), self._evaluate(x, load, False, True)[1]
        else:
            f, j = self._evaluate(x, load, force, jacobian)
        entry = (np.array(x, dtype=float), load,
                 kept_f if kept_f is not None else (f.copy() if force else None),
                 j.copy() if jacobian and self.nnz <= MEMO_ENTRIES else kept_j)
        self._memo = [entry] + [e for e in self._memo if e is not same][:MEMO_STATES - 1]
        return f, j

    def evaluate_fresh(self, x: np.ndarray, load: float = 1.0, *, jacobian: bool = True
                       ) -> tuple[np.ndarray, np.ndarray]:
        """F(x) and, with ``jacobian``, ∂F/∂x (CSC data in ``pattern`` order; empty
        otherwise), the same numbers as ``evaluate`` but neither looked up in nor kept in
        its memo: for a caller whose states never repeat (a time step's Newton iterates,
        rodsim/solvers/physical/midpoint.py), for which the memo's comparisons and copies
        are pure cost."""
        return self._evaluate(np.asarray(x), load, True, jacobian)

    def _evaluate(self, x: np.ndarray, load: float, force: bool,
                  jacobian: bool) -> tuple[np.ndarray, np.ndarray]:
        """``evaluate`` without the memo."""
        full = self.full(x)
        offsets = self.offsets(x)
        if self._compiled():
            return self._evaluate_compiled(full, offsets, load, force, jacobian)
        tiered = self._tiered_numpy()
        f: np.ndarray = np.zeros(0)
        j: np.ndarray = np.zeros(0)
        if force:
            values = [self._scale(k, term, load)
                      * term.element_forces(offsets if term.offsets else full).ravel()
                      for k, term in enumerate(self.terms)]
            f = np.bincount(self._force_targets, weights=np.concatenate(values),
                            minlength=self.n + 1)[:-1]
        if jacobian:
            blocks = [self._scale(k, term, load)
                      * term.element_jacobians(offsets if term.offsets else full).ravel()
                      for k, term in enumerate(self.terms) if term.has_jacobian]
            j = (np.bincount(self._jac_targets, weights=np.concatenate(blocks),
                             minlength=self.nnz + 1)[:-1] if blocks else np.zeros(self.nnz))
        if tiered:
            PROCESS_TIER.charge(nominal_cost(self.terms, force=force, jacobian=jacobian))
        return f, j

    def _evaluate_compiled(self, full: np.ndarray, offsets: np.ndarray, load: float,
                           force: bool, jacobian: bool) -> tuple[np.ndarray, np.ndarray]:
        units = self._kernel_unit_list()
        f = np.zeros(self.n + 1 if force else 1)
        j = _jacobian_zeros(self.nnz + 1) if jacobian else np.zeros(1)
        for call, scale in zip(units, self._unit_scales(units, load), strict=True):
            if isinstance(call, KernelGroup):
                if scale is None:
                    continue  # every member scaled away
                call.evaluate(offsets if call.offsets else full, *call.arguments, scale,
                              force, f, call.force_target, jacobian, j, call.jacobian_target)
                continue
            if scale == 0.0:
                continue  # a load at load fraction 0 (or a term scaled away): adds only zeros
            call.kernel.evaluate(offsets if call.term.offsets else full, *call.arguments,
                                 scale, force, f, call.force_target, jacobian, j,
                                 call.jacobian_target)
        return (f[:-1] if force else np.zeros(0)), (j[:-1] if jacobian else np.zeros(0))

    def _unit_scales(self, units: list[KernelCall | KernelGroup], load: float
                     ) -> list[Any]:
        """The factor on each unit's output at ``load``: a call's ``_scale``, a group's
        array of its members' (None when all are 0); the last ones asked for kept while
        the units and the scales are the same objects and the load the same (a solve
        evaluates at one load many times: the group's array was rebuilt at each)."""
        known = self._unit_scales_kept
        if (known is not None and known[0] is units and known[1] is self._scale_list
                and known[2] == load):
            return known[3]
        scales: list[Any] = []
        for unit in units:
            if isinstance(unit, KernelGroup):
                members = unit.scales(lambda index, term: self._scale(index, term, load))
                scales.append(members if members.any() else None)
            else:
                scales.append(self._scale(unit.term_index, unit.term, load))
        self._unit_scales_kept = units, self._scale_list, load, scales
        return scales

    def _kernel_unit_list(self) -> list[KernelCall | KernelGroup]:
        """What the compiled path calls: the terms' ``KernelCall`` list with each run of
        groupable terms made one ``KernelGroup`` (rodsim/core/kernel_group.py), made again
        when the list of calls is another."""
        if self._kernel_calls is None:
            self._kernel_calls = self._build_kernel_calls()
        known = self._kernel_units
        if known is not None and known[0] is self._kernel_calls:
            return known[1]
        units = kernel_units(self._kernel_calls, known[1] if known is not None else ())
        self._kernel_units = (self._kernel_calls, units)
        return units

    def element_forces(self, index: int, full: np.ndarray) -> np.ndarray:
        """The forces on the elements of term ``index`` at the full state ``full``, shaped
        as its ``dofs`` (clamped coordinates included), with its continuation scale: by its
        compiled kernel on the compiled path, by its numpy reference otherwise (the same
        numbers to round-off, tests/test_kernels.py). A term evaluated on offsets
        (``Term.offsets``) gets ``full`` minus ``reference``."""
        term = self.terms[index]
        scale = self._scale(index, term, 1.0)
        if term.offsets:
            full = full - self.reference
        if not self._compiled():
            return scale * term.element_forces(full)
        if self._kernel_calls is None:
            self._kernel_calls = self._build_kernel_calls()
        call = self._kernel_calls[index]
        slots = np.arange(term.dofs.size, dtype=np.int64).reshape(term.dofs.shape)
        out = np.zeros(term.dofs.size + 1)
        call.kernel.evaluate(full, *call.arguments, scale, True, out, slots, False,
                             np.zeros(1), call.jacobian_target)
        return out[:-1].reshape(term.dofs.shape)

    def _build_kernel_calls(self) -> list[KernelCall]:
        """The ``KernelCall`` of every term: its kernel, its constants bound by name to
        the kernel's signature, and where each element's force and Jacobian entries land
        (slot n and nnz are dumps for clamped coordinates)."""
        from rodsim.core.kernels import load_kernel

        # A re-registered model (with_terms: the same index map) keeps the calls of the terms
        # that are the same objects, with the new pattern's targets.
        kept = None
        if self._kept_calls is not None and self._kept_calls[0] is self._free_of:
            kept = self._kept_calls[1]
        self._kept_calls = None
        calls = []
        targets = iter(self._term_targets)
        for index, term in enumerate(self.terms):
            elements, k = term.dofs.shape
            if term.has_jacobian:
                jacobian_target = np.ascontiguousarray(next(targets).reshape(elements, k, k))
            else:
                jacobian_target = np.zeros((0, 0, 0), dtype=np.int64)
            if kept is not None and kept[index].term is term:
                calls.append(kept[index]._replace(jacobian_target=jacobian_target))
                continue
            force_target = np.ascontiguousarray(self._free_of[term.dofs])
            kernel = load_kernel(term)
            calls.append(KernelCall(index, term, kernel, kernel.bind(term.kernel_arguments()),
                                    force_target, jacobian_target))
        return calls

    def jacobian(self, x: np.ndarray, load: float = 1.0) -> sp.csc_matrix:
        """∂F/∂x as a sparse CSC matrix (n × n)."""
        return self.pattern_matrix(self.jacobian_data(x, load))

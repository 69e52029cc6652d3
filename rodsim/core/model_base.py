"""What the parts of ``rodsim.core.model.Model`` share: the attributes that more than
one part reads, declared once with their meaning, and the questions every part asks (the
assembly's budget, which evaluation path runs now).

The model is split along its seams (docs/architecture.md, "The model"), each part a class
that the next one extends:

- rodsim/core/model_pattern.py: structure — the free-coordinate maps, the band order, the
  Jacobian pattern and where each term's entries land in it;
- rodsim/core/model_manifold.py: the state — free coordinates as offsets from the rest
  state, the full state, the retraction a Newton step takes;
- rodsim/core/model_evaluation.py: F(x), ∂F/∂x and E(x) through the compiled kernels or the
  numpy reference, with the memo of the last states;
- rodsim/core/model_scales.py: the force and length scales, the residual and its weights,
  the round-off floor;
- rodsim/core/model.py: the model of a scene (its rods, terms and tendons) and the models
  derived from a model (other values, scales, registration, anchors).
"""

from __future__ import annotations

import numpy as np

from rodsim.core.assembly_budget import AssemblyBudget
from rodsim.core.kernel_call import KernelCall
from rodsim.core.kernel_group import KernelGroup
from rodsim.core.kernel_tier import PROCESS_TIER
from rodsim.core.rod.rod import Rod
from rodsim.core.scene import Scene
from rodsim.core.tendon import Tendon
from rodsim.core.terms import Term

__all__ = ["ModelBase"]


class ModelBase:
    """The attributes the parts of a model share (module docstring); set by
    ``rodsim.core.model.Model._assemble`` and the builds of the parts."""

    #: The scene the model was built from.
    scene: Scene
    #: The evaluation path: ``"compiled"``, ``"numpy"`` or ``"tiered"``.
    kernels: str
    #: A wall-time budget of the assembly (None after it: :meth:`_tick`).
    _budget: AssemblyBudget | None
    #: The rods by name, in the scene's order.
    rods: dict[str, Rod]
    #: The scene's tendons (lumen geometry shared by their coupling terms).
    tendons: dict[str, Tendon]
    #: The terms, in evaluation order.
    terms: list[Term]
    #: (``"rods"``, ``"tendons"`` or a term's ``scene_table``, owner's name, term key) of
    #: each term, in order.
    term_keys: list[tuple[str, str, str]]
    #: The terms that are loads (scaled by the load fraction) and those with a Jacobian.
    _loads: list[Term]
    _jac_terms: list[Term]
    #: Factor on each term's output: 1, or a penalty continuation scale; and as floats.
    term_scales: np.ndarray
    _scale_list: list[float]
    #: Size of the full state (every coordinate of every rod).
    full_size: int
    #: Full-state index of every free coordinate, in the integrators' order; their count.
    free: np.ndarray
    n: int
    #: Free index of every full-state coordinate (n: a fixed coordinate's dump slot).
    _free_of: np.ndarray
    #: The full rest state, fixed coordinates at the values their supports hold.
    rest_full: np.ndarray
    #: The rest state the free coordinates are offsets from (docs/model.md, "The offset
    #: state and the residual floor"): every rod's rest positions and rest quaternions.
    reference: np.ndarray
    #: :attr:`rest_full` as offsets from :attr:`reference` (non-zero only where a node
    #: support holds its node away from its rest place).
    rest_offsets: np.ndarray
    #: How the compiled path calls each term's kernel; built at the first compiled call.
    _kernel_calls: list[KernelCall] | None
    #: The calls of the model a re-registration came from (:meth:`Model.with_terms`), with
    #: the index map they were built on, for :meth:`_build_kernel_calls` to keep.
    _kept_calls: tuple[np.ndarray, list[KernelCall]] | None
    #: The calls above with the groupable ones made one call each
    #: (rodsim/core/kernel_group.py), beside the list of calls they were made from.
    _kernel_units: tuple[list[KernelCall], list[KernelCall | KernelGroup]] | None
    #: The last evaluations, newest first: (state, load, F or None, ∂F/∂x data or None);
    #: see :meth:`rodsim.core.model_evaluation.ModelEvaluation.evaluate`.
    _memo: list[tuple[np.ndarray, float, np.ndarray | None, np.ndarray | None]]

    def _tick(self) -> None:
        """Check the assembly's wall-time budget, if any (see ``budget``)."""
        budget = getattr(self, "_budget", None)
        if budget is not None:
            budget.check()

    def _compiled(self) -> bool:
        """Whether evaluations run the compiled kernels now: always on the ``compiled``
        path, on the ``tiered`` path once the process has moved to them."""
        return self.kernels == "compiled" or (self.kernels == "tiered"
                                              and PROCESS_TIER.compiled)

    def _tiered_numpy(self) -> bool:
        """Whether this evaluation is a ``tiered`` model's numpy evaluation, whose CPU counts
        toward the move to the compiled kernels (``rodsim.core.kernel_tier``)."""
        return self.kernels == "tiered" and not PROCESS_TIER.compiled

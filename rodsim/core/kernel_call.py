"""How the compiled path calls one term's kernel: ``KernelCall``, built by
``rodsim.core.model_evaluation.ModelEvaluation._build_kernel_calls``."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from rodsim.core.terms import Term

if TYPE_CHECKING:
    from rodsim.core.kernels import Kernel

__all__ = ["KernelCall"]


class KernelCall(NamedTuple):
    """How the compiled path evaluates one term (``Model._build_kernel_calls``)."""

    #: The term's index in :attr:`Model.terms` (its continuation scale's index).
    term_index: int
    term: Term
    #: The compiled kernel (rodsim/core/kernels/), its ``evaluate`` and ``energy``.
    kernel: Kernel
    #: The term's constants in the kernel's signature order
    #: (:meth:`rodsim.core.kernels.Kernel.bind`).
    arguments: tuple[Any, ...]
    #: Free-coordinate index of each element's force entry, shape (n_elem, k); n: a dump.
    force_target: np.ndarray
    #: CSC data slot of each element's Jacobian entry, shape (n_elem, k, k); nnz: a dump.
    jacobian_target: np.ndarray

    @property
    def evaluate(self) -> Any:
        """The kernel's ``evaluate``."""
        return self.kernel.evaluate

    @property
    def energy(self) -> Any:
        """The kernel's ``energy``, or None when the module has none."""
        return self.kernel.energy

    def with_term(self, term: Term) -> KernelCall:
        """This call for another term of the same kind and elements (new constants)."""
        return self._replace(term=term, arguments=self.kernel.bind(term.kernel_arguments()))

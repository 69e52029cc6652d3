"""Shared geometry of the centerline segments ``e_j = r_{j+1} − r_j`` (used by Eqs. 6 and 9)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Segments:
    """Edge vectors, lengths and unit tangents of all segments of one rod.

    ``edge`` (n, 3), ``norm`` (n,), ``tangent`` (n, 3) and the projector
    ``P = I − t tᵀ`` (n, 3, 3) onto the plane normal to the tangent.
    """

    edge: np.ndarray
    norm: np.ndarray
    tangent: np.ndarray

    @classmethod
    def of(cls, positions: np.ndarray) -> Segments:
        edge = positions[1:] - positions[:-1]
        norm = np.linalg.norm(edge, axis=1)
        return cls(edge, norm, edge / norm[:, None])

    @property
    def projector(self) -> np.ndarray:
        return np.eye(3) - self.tangent[:, :, None] * self.tangent[:, None, :]


def two_node_block(h_edge: np.ndarray) -> np.ndarray:
    """Jacobian on (r_j, r_{j+1}) of a force −∂E/∂e with edge Hessian ``h_edge`` (n, 3, 3).

    With e = r_{j+1} − r_j: ∂F/∂(r_j, r_{j+1}) = −[[H, −H], [−H, H]].
    """
    n = h_edge.shape[0]
    block = np.empty((n, 6, 6))
    block[:, :3, :3] = -h_edge
    block[:, 3:, 3:] = -h_edge
    block[:, :3, 3:] = h_edge
    block[:, 3:, :3] = h_edge
    return block

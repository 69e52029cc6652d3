"""Shared geometry of the centerline segments ``e_j = r_{j+1} − r_j`` (used by Eqs. 6 and 9).

``Segments.about`` forms them from the offset state (docs/model.md, "The offset state
and the residual floor"): each edge is its rest edge E_j plus the difference Δ_j of its two
nodes' displacements, and its length change and tangent change are computed from Δ_j
without cancellation,

    |e| − |E| = (2 E·Δ + Δ·Δ) / (|e| + |E|),   t − T = (Δ − T (|e| − |E|)) / |e|,

so that their round-off is relative to the displacement, not to the rod's length.
"""

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

    @classmethod
    def about(cls, offsets: np.ndarray, rest_edges: np.ndarray,
              rest: np.ndarray) -> OffsetSegments:
        """The segments of a rod whose node displacements are ``offsets`` (N, 3) from a
        rest shape of edges ``rest_edges`` (N − 1, 3) of lengths ``rest``, with their length
        and tangent changes formed without cancellation (the module docstring)."""
        delta = offsets[1:] - offsets[:-1]
        edge = rest_edges + delta
        norm = np.linalg.norm(edge, axis=1)
        change = ((2.0 * np.einsum("ij,ij->i", rest_edges, delta)
                   + np.einsum("ij,ij->i", delta, delta)) / (norm + rest))
        turn = (delta - rest_edges * (change / rest)[:, None]) / norm[:, None]
        return OffsetSegments(edge, norm, edge / norm[:, None], change, turn)

    @property
    def projector(self) -> np.ndarray:
        return np.eye(3) - self.tangent[:, :, None] * self.tangent[:, None, :]


@dataclass(frozen=True)
class OffsetSegments(Segments):
    """``Segments`` formed about a rest shape: also ``change`` = |e| − |E| (n,) and
    ``turn`` = t − T (n, 3), each without cancellation (``Segments.about``)."""

    change: np.ndarray
    turn: np.ndarray


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

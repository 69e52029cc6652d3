"""A Newton step of a rod that turns its segments as rigid frames: the rotation retraction.

A Newton step (Δr, Δq) from (r, q) is linear: the quaternion goes to q + Δq, which is not a
rotation of q (|q + Δq|² = |q|² + |Δq|² for a pure turn Δq ⊥ q, and the directors of Eq. (2)
scale by |q|²), and each edge e_j = r_{j+1} − r_j to e_j + Δe_j, which turns by atan(θ)
instead of θ. Both are right to first order, but they disagree with each other at second
and third order (θ³/4 between the edge and d3 for a turn θ), and the stiff centerline
penalty Eq. (9) — K_P l² / (E I) = 139 on tdcr-two-segment — turns the disagreement into a
force far above the loads: the energy line search then cuts every other step and Newton
creeps (tens of iterations for one static solve of tdcr-two-segment; docs/benchmark-history.md,
"Measurements behind the core's constants").

Here, per segment j (frame R_j = D(q_j) / |q_j|², D of Eq. 2, rows d_k):

- the quaternion goes to q_j + Δq_j rescaled to the norm the linearisation predicts,
  |q_j| + q_j · Δq_j / |q_j|: a rotation of q_j (and the norm change the penalty sees);
- the edge keeps the body-frame components the linear step predicts,
  b_j = R_j (e_j + Δe_j) + ΔR_j e_j (ΔR_j the linear change of R_j), and is rebuilt in the
  new frame: e_j' = R_j'ᵀ b_j;
- the nodes are walked from the base, r_{j+1}' = r_j' + e_j', restarting at every node whose
  position is fixed (a support), which keeps its value.

To first order in the step this is r + Δr, q + Δq (R'ᵀ = Rᵀ + ΔRᵀ + O(Δ²) and
Δ(RᵀR) = 0), so Newton's local convergence is unchanged; a rigid turn of a segment by any
angle is reproduced with the edge still along d3, and the static solves of
tdcr-two-segment take a handful of Newton iterations (docs/benchmark-history.md, "Measurements
behind the core's constants").
"""

from __future__ import annotations

import numpy as np

from rodsim.core.rod.quaternion import DIRECTOR_FORMS, directors

__all__ = ["turn_segments"]


def turn_segments(r: np.ndarray, q: np.ndarray, dr: np.ndarray, dq: np.ndarray,
                  fixed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The retracted nodes (N, 3) and quaternions (N − 1, 4) of one rod after the linear
    step (dr, dq) from (r, q) (module docstring); ``fixed`` (N,) marks nodes whose position
    is held (their ``r + dr`` is kept, and the walk restarts there)."""
    norm2 = np.einsum("ij,ij->i", q, q)
    along = np.einsum("ij,ij->i", q, dq)
    frame = directors(q) / norm2[:, None, None]
    # ΔR: the linear change of D(q) / |q|², with ∂D[k, m] / ∂q = 2 A[k, m] q.
    change = (2.0 * np.einsum("ja,kmab,jb->jkm", q, DIRECTOR_FORMS, dq) / norm2[:, None, None]
              - 2.0 * frame * (along / norm2)[:, None, None])
    edges = np.diff(r, axis=0)
    body = (np.einsum("jkm,jm->jk", frame, edges + np.diff(dr, axis=0))
            + np.einsum("jkm,jm->jk", change, edges))
    turned = q + dq
    norm = np.sqrt(norm2)
    turned *= ((norm + along / norm) / np.linalg.norm(turned, axis=1))[:, None]
    new_frame = directors(turned) / np.einsum("ij,ij->i", turned, turned)[:, None, None]
    new_edges = np.einsum("jkm,jk->jm", new_frame, body)
    moved = r + dr
    # Walk from the last held node before each node (the base if none is held: it moves
    # with the linear step).
    walked = np.vstack([np.zeros(3), np.cumsum(new_edges, axis=0)])
    held = np.where(fixed, np.arange(len(r)), 0)
    held = np.maximum.accumulate(held)
    out = moved[held] + walked - walked[held]
    return out, turned

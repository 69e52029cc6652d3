"""A string tendon with friction as one element on the coordinates of its span
(rodsim/core/terms/tendon_string.py, "Friction"): the layout and the numpy reference of the
coupling of each chord's tension to every turn up to it (the compiled kernel:
rodsim/core/kernels/tendon_string_span.py).

Chord e's tension τ_e = clip(τ_old_e, T e^{−W_in,e}, T e^{+W_out,e}), W_e = Σ_{j≤e} μ_j θ_j,
has ∂τ_e/∂x = σ_e Σ_{j≤e} μ_j ∂θ_j/∂x where it slides (σ_e = −τ_e in, +τ_e out; 0 stuck),
each ∂θ_j/∂x on the coordinates of the chords around point j (rodsim/core/turn_gradient.py)
and, for the entry's turn, the entry frame's. The sum reaches every chord before e, so the
Jacobian needs the span's dense block (m² entries for the m coordinates of the span, 7 per
node), as the displacement-controlled string's does
(rodsim/core/terms/tendon_string_displacement.py); the running sums make it O(E m).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from rodsim.core.turn_gradient import WINDOW

__all__ = ["MAX_COUPLED_NODES", "SpanLayout", "coupled_span", "turn_coupling"]

#: Most catheter nodes a string tendon's span may hold for its Jacobian to take the upstream
#: coupling (a dense block of (7 n)² entries); beyond, the chords' own coupling alone.
MAX_COUPLED_NODES = 300

#: Relative spread of the points' μ_k below which they count as one μ (``coupled_span``).
VARIES = 1e-12


class SpanLayout:
    """The span's coordinates ``dofs`` (1, m), each chord coordinate's position in it
    ``chord_local`` (E, 28), and the flattened pairs ``chord_pairs`` (E, 28, 28)."""

    def __init__(self, chord_dofs: np.ndarray) -> None:
        span = np.unique(chord_dofs)
        self.size = len(span)
        self.dofs = span[None, :]
        self.chord_local = np.searchsorted(span, chord_dofs).astype(np.int64)
        self.chord_pairs = (self.chord_local[:, :, None] * self.size
                            + self.chord_local[:, None, :]).astype(np.int64)

    def arguments(self, chords: Mapping[str, Any]) -> dict[str, Any]:
        """The span kernel's constants (rodsim/core/kernels/tendon_string_span.py) from the
        chord kernel's ``chords``: their ``dofs`` as ``chord_dofs``, the span's as
        ``dofs``, the layout's maps."""
        return dict(chords) | {"dofs": self.dofs, "chord_dofs": chords["dofs"],
                               "chord_local": self.chord_local, "chord_pairs": self.chord_pairs}

    def jacobian(self, chords: np.ndarray, coupling: np.ndarray) -> np.ndarray:
        """The span's element Jacobian (1, m, m): the chords' (E, 28, 28) at frozen tension
        summed, and the coupling of the tensions to the turns (``turn_coupling``)."""
        return (self.jacobians(chords) + coupling)[None]

    def forces(self, chords: np.ndarray) -> np.ndarray:
        """The chords' element forces (E, 28) summed into the span's (1, m)."""
        out = np.zeros(self.size)
        np.add.at(out, self.chord_local, chords)
        return out[None, :]

    def jacobians(self, chords: np.ndarray) -> np.ndarray:
        """The chords' element Jacobians (E, 28, 28) summed into the span's (m, m)."""
        out = np.zeros((self.size, self.size))
        np.add.at(out, (self.chord_local[:, :, None], self.chord_local[:, None, :]), chords)
        return out


def coupled_span(term: Any) -> SpanLayout | None:
    """The span layout of a string tendon with friction (rodsim/core/terms/tendon_string.py)
    whose Jacobian takes the coupling of every chord's tension to every turn before it
    (``turn_coupling``), over at most ``MAX_COUPLED_NODES`` nodes: with ``exact_jacobian``
    on any path; without, as before that option, where μ varies between the points (per
    point or along the arc length, or stiction: μ_s and μ_k per state) on a routing that can
    lie in a plane (not a helix) from a held entry frame. None otherwise (one element per
    chord: the frozen-tension Jacobian plus each chord's own coupling on one-way planar
    paths, exact there with one μ, the band kept)."""
    if not term.rubs:
        return None
    if not term.options.exact_jacobian:
        # One μ given as a profile maps to per-point means equal to round-off: no coupling.
        varies = term.sticky or bool(np.ptp(term.kinetic) > VARIES * np.max(term.kinetic))
        if (not (term.weighted and varies) or np.any(term.points.weights[0, 2:])
                or term.routing.kind == "helix"):
            return None
    if len(np.unique(term.dofs)) > 7 * MAX_COUPLED_NODES:
        return None
    return SpanLayout(term.dofs)


def turn_coupling(layout: SpanLayout, slide: np.ndarray, mu_in: np.ndarray,
                  mu_out: np.ndarray, near: np.ndarray, entry: np.ndarray,
                  directions: np.ndarray, jd: np.ndarray, length: np.ndarray,
                  entry_jacobian: np.ndarray, unit_force: np.ndarray) -> np.ndarray:
    """Σ_e f_e ⊗ σ_e Σ_{j≤e} μ_j ∂θ_j/∂x (m, m) in span coordinates (module docstring):
    ``slide`` σ_e = ∂τ_e/∂W_e (−τ_e sliding in, with μ_in; +τ_e sliding out, with μ_out; 0
    stuck), ``near`` and ``entry`` the turns' gradients by the chords' directions u_i
    (``directions``, (E, 3)) and by d3, t_in (rodsim/core/turn_gradient.py), ``jd`` the
    chords' Jd (E, 3, 28), ``length`` |d_e|, ``entry_jacobian`` ∂d3/∂x and ∂t_in/∂x on
    chord 0's coordinates (2, 3, 28), ``unit_force`` f_e = −Jd_eᵀ u_e (E, 28)."""
    chords = len(slide)
    m = layout.size
    # ∂u_i/∂x = (I − u_i u_iᵀ) Jd_i / |d_i| on chord i's coordinates, (E, 3, 28).
    along = np.einsum("em,emk->ek", directions, jd)
    moves = (jd - directions[:, :, None] * along[:, None, :]) / length[:, None, None]
    running_in, running_out = np.zeros(m), np.zeros(m)
    out = np.zeros((m, m))
    for e in range(chords):
        turn = np.zeros(m)
        for r in range(WINDOW):
            i = e - 3 + r
            if 0 <= i < chords and np.any(near[e, r]):
                np.add.at(turn, layout.chord_local[i], near[e, r] @ moves[i])
        if e == 0:
            np.add.at(turn, layout.chord_local[0], entry[0] @ entry_jacobian[0]
                      + entry[1] @ entry_jacobian[1])
        running_in += mu_in[e] * turn
        running_out += mu_out[e] * turn
        if slide[e] != 0.0:
            row = running_in if slide[e] < 0.0 else running_out
            np.add.at(out, layout.chord_local[e], slide[e] * np.outer(unit_force[e], row))
    return out

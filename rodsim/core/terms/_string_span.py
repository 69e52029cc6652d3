"""A string tendon with friction that varies between its routing points, as one element on
the coordinates of its span (rodsim/core/terms/tendon_string.py, "Friction"): the layout
and the numpy reference of the coupling of each chord's tension to the turns upstream of
it (the compiled kernel: rodsim/core/kernels/tendon_string_span.py, whose docstring
derives it).

Chord e's tension τ_e = T e^{∓W_e}, W_e = Σ_{j≤e} μ_j θ_j, on a path turning one way in one
plane from a held entry frame has ∂W_e/∂x = μ_e ∂ψ_e/∂x + Σ_{j<e} (μ_j − μ_{j+1}) ∂ψ_j/∂x,
ψ_j = ∠(d3, u_j). The first term lies on chord e's coordinates (the chord elements' own
coupling); the sum reaches every chord before it, so the Jacobian needs the span's dense
block (m² entries for the m coordinates of the span, 7 per node), as the
displacement-controlled string's does (rodsim/core/terms/tendon_string_displacement.py).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["MAX_COUPLED_NODES", "SpanLayout", "coupled_span", "upstream_coupling"]

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
        ``dofs``, the layout's maps; ``weighted`` dropped (always)."""
        out = {key: value for key, value in chords.items() if key != "weighted"}
        return out | {"dofs": self.dofs, "chord_dofs": chords["dofs"],
                      "chord_local": self.chord_local, "chord_pairs": self.chord_pairs}

    def jacobian(self, chords: np.ndarray, one_way: np.ndarray, slide: np.ndarray,
                 slope: np.ndarray, unit_force: np.ndarray, mu_in: np.ndarray,
                 mu_out: np.ndarray) -> np.ndarray:
        """The span's element Jacobian (1, m, m): the chords' (E, 28, 28) summed and the
        upstream coupling (``upstream_coupling``) on the chords up to which the path turns
        one way in one plane (``one_way``)."""
        return (self.jacobians(chords) + upstream_coupling(
            self, np.where(one_way, slide, 0.0), np.where(one_way[:, None], slope, 0.0),
            unit_force, mu_in, mu_out))[None]

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
    """The span layout of a string tendon (rodsim/core/terms/tendon_string.py) whose
    Jacobian needs the upstream coupling: with friction whose μ varies between its points
    (per point or along the arc length, or stiction: μ_s and μ_k per state), a held entry
    frame (the coupling is exact only from one), a routing that can lie in a plane (not a
    helix) and at most ``MAX_COUPLED_NODES`` nodes; None otherwise (one element per chord,
    as with one μ)."""
    # One μ given as a profile maps to per-point means equal to round-off: no coupling.
    varies = term.sticky or bool(np.ptp(term.kinetic) > VARIES * np.max(term.kinetic))
    if not (term.weighted and term.rubs and varies) or np.any(term.points.weights[0, 2:]):
        return None
    if term.routing.kind == "helix":
        return None  # never one way in one plane: no coupling to carry
    if len(np.unique(term.dofs)) > 7 * MAX_COUPLED_NODES:
        return None
    return SpanLayout(term.dofs)


def upstream_coupling(layout: SpanLayout, slide: np.ndarray, slope: np.ndarray,
                      unit_force: np.ndarray, mu_in: np.ndarray, mu_out: np.ndarray
                      ) -> np.ndarray:
    """Σ_e f_e ⊗ σ_e Σ_{j<e} (μ_j − μ_{j+1}) ∂ψ_j/∂x (m, m) in span coordinates: ``slide``
    σ_e = ∂τ_e/∂W_e (−τ_e sliding in, taking μ_in; +τ_e sliding out, μ_out; 0 stuck or
    off a one-way path), ``slope`` ∂ψ_j/∂x on chord j's coordinates (E, 28; zero where
    ψ_j = 0), ``unit_force`` f_e = −Jd_eᵀ u_e (E, 28)."""
    chords = len(slide)
    m = layout.size
    running = {side: np.zeros((chords, m)) for side in ("in", "out")}
    for side, mu in (("in", mu_in), ("out", mu_out)):
        steps = np.zeros((chords, m))
        for j in range(chords - 1):
            np.add.at(steps[j + 1], layout.chord_local[j], (mu[j] - mu[j + 1]) * slope[j])
        running[side] = np.cumsum(steps, axis=0)  # row e: Σ_{j<e}
    out = np.zeros((m, m))
    for e in np.flatnonzero(slide):
        row = running["in" if slide[e] < 0.0 else "out"][e]
        np.add.at(out, layout.chord_local[e], slide[e] * np.outer(unit_force[e], row))
    return out

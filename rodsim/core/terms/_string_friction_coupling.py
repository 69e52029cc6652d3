"""The friction string tendon's Jacobian coupling Σ_e f_e ⊗ ∂τ_e/∂x (numpy reference of the
compiled kernels; docs/tendon.md, "Friction"): each chord's force per unit tension f_e by
the gradient of its tension τ_e, which depends on every turn up to chord e.

Two forms, chosen by ``TendonString.element_jacobians``:
- on a path that turns one way in one plane from a held entry frame, the wrap Θ_e is
  ψ_e = ∠(d3, u_e), whose gradient lies on chord e's own coordinates (``one_way_coupling``,
  the chord elements keep their band);
- on the span element, every chord's tension by every turn up to it
  (``span_turn_coupling``; rodsim/core/terms/_string_span.py, ``turn_coupling``).

f_e = −Jd_eᵀ u_e, Jd_e = [−J_A, J_B] the chord's point Jacobians, u_e its direction. ``term``
is a rodsim.core.terms.tendon_string.TendonString (typed ``Any``: that module imports this
one, and the package has no import circle, type-only ones included).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rodsim.core.tendon_friction import (
    ONE_WAY,
    slide_rates,
    turning_angles,
    weighted_slide_factors,
    weighted_slide_rates,
)
from rodsim.core.terms._string_points import entry_jacobian
from rodsim.core.terms._string_span import turn_coupling
from rodsim.core.turn_gradient import turn_gradients

__all__ = ["one_way_coupling", "one_way_parts", "span_turn_coupling"]


def span_turn_coupling(term: Any, x: np.ndarray, u: np.ndarray,
                       length: np.ndarray, jd: np.ndarray) -> np.ndarray:
    """Σ_e f_e ⊗ ∂τ_e/∂x on the term's span: every chord's tension by every turn up to it
    (the turns' 3-D gradients: rodsim/core/turn_gradient.py)."""
    assert term.span is not None
    axis, tangent = term.entry_directions(x)
    near, entry = turn_gradients(axis, tangent, u, term.split)
    slide = weighted_slide_factors(term.tension, term._mu_in, term._mu_out,
                                   term.turning_angles(x), term.profile)
    return turn_coupling(term.span, slide, term._mu_in, term._mu_out, near, entry, u, jd,
                         length, entry_jacobian(term.points, term._entry_slope, x),
                         -np.einsum("emk,em->ek", jd, u))


def one_way_coupling(term: Any, x: np.ndarray, u: np.ndarray, length: np.ndarray,
                     jd: np.ndarray) -> np.ndarray:
    """Σ_e f_e ⊗ ∂τ_e/∂x on the chords up to which the path turns one way in one plane from
    a held entry frame: there Θ_e = ψ_e = ∠(d3, u_e), whose gradient
    −(d3 − (d3·u_e) u_e)ᵀ Jd_e / (|d3 × u_e| |d_e|) lies on the chord's own coordinates."""
    theta, one_way, slope, unit_force = one_way_parts(term, x, u, length, jd)
    rate = (weighted_slide_rates(term.tension, term._mu_in, term._mu_out, theta,
                                 term.profile) if term.weighted
            else slide_rates(term.tension, term.friction, theta, term.profile))
    gradient = np.where(one_way, rate, 0.0)[:, None] * slope
    return unit_force[:, :, None] * gradient[:, None, :]


def one_way_parts(term: Any, x: np.ndarray, u: np.ndarray, length: np.ndarray,
                  jd: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(θ_e, whether the path up to chord e turns one way in one plane, ∂ψ_e/∂x there
    (E, 28), f_e (E, 28))."""
    theta = term.turning_angles(x)
    axis, tangent = term.entry_directions(x)
    # One way in one plane: the plain turns (no split) sum to ψ_e.
    wrap = np.cumsum(turning_angles(axis, tangent, term.path(x)))
    sine = np.linalg.norm(np.cross(axis[None, :], u), axis=1)
    cosine = u @ axis
    psi = np.arctan2(sine, cosine)
    one_way = (np.abs(wrap - psi) <= ONE_WAY * np.maximum(1.0, wrap)) & (sine > 0.0)
    slope = -(axis[None, :] - cosine[:, None] * u) / np.where(
        one_way, sine * length, 1.0)[:, None]
    return (theta, one_way, np.einsum("em,emk->ek", slope, jd),
            -np.einsum("emk,em->ek", jd, u))

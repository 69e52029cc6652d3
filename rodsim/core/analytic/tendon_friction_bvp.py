"""Rucker–Webster reference with the capstan law: tendons that slide with Coulomb friction.

The independent check of friction on the string tendon (rodsim/core/tendon_friction.py,
docs/tendon.md "Friction") in 3-D. It extends the frictionless shooting reference
(rodsim/core/analytic/tendon_bvp.py, whose notation this follows) by one state per tendon,
its tension T_i(s), written from the continuum equations of Rucker & Webster (IEEE T-RO
27(6), 2011) and the capstan law, not from rodsim's discrete model.

Section wrench. Friction is a force between tendon and catheter, internal to the section
cut at s through both: the section wrench N = n + Σ T_i t_i, M = m + Σ (R ρ_i) × T_i t_i
still obeys N ≡ F, M′ = −p′ × F, now with each tendon's tension at the cut, T_i(s). The
strains (u, v) solve the same algebraic system g(u, v; Rᵀ M, Rᵀ F, T) = 0 at each s.

Capstan law. A tendon sliding along its lumen loses tension as dT_i/ds = −σ μ_i |f_n| with
|f_n| = T_i |t_i′| the normal load per unit length (the tendon's balance, (T t)′ + f = 0,
split along and across t): dT_i/ds = −σ μ_i T_i |t_i′|, σ = +1 while the tendon is pulled
in (slides toward the actuator), −1 while it is let out. The tangent t_i = R τ_i,
τ_i = a_i/|a_i|, a_i = v + u × ρ_i + ρ_i′ gives t_i′ = R (u × τ_i + P_i a_i′), P_i =
(I − τ_i τ_iᵀ)/|a_i|, a_i′ = v′ + u′ × ρ_i + u × ρ_i′ + ρ_i″. The strains' rates come from
differentiating g along s: J (u′, v′) = −∂g/∂s − Σ ∂g/∂T_i T_i′ (J = ∂g/∂(u, v)), with
(Rᵀ M)′ = −u × Rᵀ M − v × Rᵀ F and (Rᵀ F)′ = −u × Rᵀ F; u′, v′ and T′ depend on each
other, and are solved together by fixed-point iteration (a contraction of rate O(μ)) to
round-off.

Kinks. Where the strains jump (a tendon ending, a change of section) the tendons passing
on turn by a finite angle θ from t_i(s⁻) to t_i(s⁺), and across it T(s⁺) = T(s⁻) e^{−σμθ}
(the capstan law over the kink). At its entry a tendon comes in from the actuator along the
catheter's axis d3, follows the lumen's rest tangent t_in ∝ e3 + ρ′ (body frame) and turns
on to t_i(s⁺): θ = ∠(d3, t_in) + ∠(t_in, t_i), rodsim's convention for the entry
(rodsim/core/tendon_friction.py). T(s⁺) depends on t_i(s⁺), which depends on T(s⁺): solved
by fixed-point iteration. One sliding direction σ for every tendon and every s: the states
of a cold solve (pulled in from slack, σ = +1) or of a release from slack-free sliding
(σ = −1); a stuck zone is not described.

Shooting on the base moment M(0) as in tendon_bvp (Newton, finite-difference Jacobian,
DOP853 at rtol 1e-12, piecewise between entries, terminations and span ends).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.integrate import solve_ivp

from rodsim.core.analytic.tendon_bvp import (
    _ATOL,
    _EYE3,
    _RTOL,
    BASE_FRAME,
    BVPTendon,
    Section,
    TendonRodSolution,
    _cross,
    _skew,
    _Strains,
    _with_zero,
    base_moment_newton,
    scene_problem,
)

__all__ = ["FrictionTendon", "friction_tendon_rod", "scene_friction_reference"]

#: Fixed-point iterations allowed for the coupled (u′, v′, T′) and for a kink's tension.
_FIXED_POINT = 200
_E3 = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class FrictionTendon:
    """A ``BVPTendon`` (its ``tension`` is the actuator's T_0) with Coulomb friction
    ``friction`` (μ ≥ 0) and its routing's ``curvature(s)`` = ρ″(s), shape (len(s), 2)."""

    tendon: BVPTendon
    friction: float
    curvature: Callable[[np.ndarray], np.ndarray]


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """∠(a, b) [rad] as atan2(|a × b|, a·b)."""
    return math.atan2(float(np.linalg.norm(_cross(a, b))), float(a @ b))


def _routing(tendon: FrictionTendon, s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ρ, ρ′, ρ″ at ``s`` as body-frame 3-vectors."""
    at = np.array([s])
    return (_with_zero(tendon.tendon.offset(at)[0]), _with_zero(tendon.tendon.slope(at)[0]),
            _with_zero(tendon.curvature(at)[0]))


def _tangents(tendons: Sequence[FrictionTendon], s: float, u: np.ndarray,
              v: np.ndarray) -> list[np.ndarray]:
    """τ_i (body frame) of ``tendons`` at ``s`` for strains (u, v)."""
    out = []
    for tendon in tendons:
        rho, slope, _ = _routing(tendon, s)
        a = v + _cross(u, rho) + slope
        out.append(a / np.linalg.norm(a))
    return out


class _Segment:
    """One interval between breaks: its section's strains and its active tendons."""

    def __init__(self, section: Section, tendons: Sequence[FrictionTendon],
                 sliding: float) -> None:
        self.tendons = tendons
        self.strains = _Strains(section, [t.tendon for t in tendons], 1.0)
        self.mask = np.array([0.0, 0.0, 1.0]) if math.isinf(section.shear) else np.ones(3)
        self.sliding = sliding

    def strains_at(self, s: float, rot: np.ndarray, moment: np.ndarray, force: np.ndarray,
                   tensions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.strains.solve(s, rot.T @ moment, rot.T @ force, tensions)

    def rates(self, s: float, rot: np.ndarray, moment: np.ndarray, force: np.ndarray,
              tensions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(u, v, T′) at ``s`` (module docstring: the coupled rates by fixed point)."""
        m_b, n_b = rot.T @ moment, rot.T @ force
        u, v = self.strains.solve(s, m_b, n_b, tensions)
        jac = self.strains.jacobian
        # ∂g/∂s along the solution without the tensions' rates, and each ∂g/∂T_i; the
        # section wrench's rates are (Rᵀ M)′ = −u × Rᵀ M − v × Rᵀ F, (Rᵀ F)′ = −u × Rᵀ F.
        explicit = np.concatenate((_cross(u, m_b) + _cross(v, n_b), _cross(u, n_b) * self.mask))
        columns, geometry = [], []
        for tendon, tension in zip(self.tendons, tensions, strict=True):
            rho, slope, curve = _routing(tendon, s)
            a = v + _cross(u, rho) + slope
            norm = float(np.linalg.norm(a))
            tau = a / norm
            proj = (_EYE3 - np.outer(tau, tau)) / norm
            a_s = _cross(u, slope) + curve
            explicit = explicit + tension * np.concatenate((
                _cross(slope, tau) + _cross(rho, proj @ a_s), (proj @ a_s) * self.mask))
            columns.append(np.concatenate((_cross(rho, tau), tau * self.mask)))
            geometry.append((rho, tau, proj, a_s))
        base = -np.linalg.solve(jac, explicit)
        per_tension = [-np.linalg.solve(jac, c) for c in columns]
        rate = np.zeros(len(self.tendons))
        for _ in range(_FIXED_POINT):
            dz = base + sum((r * w for r, w in zip(rate, per_tension, strict=True)),
                            np.zeros(6))
            new = np.empty_like(rate)
            for k, (tendon, (rho, tau, proj, a_s)) in enumerate(zip(self.tendons, geometry,
                                                                    strict=True)):
                a_rate = dz[3:] + _cross(dz[:3], rho) + a_s
                turn = _cross(u, tau) + proj @ a_rate
                new[k] = -self.sliding * tendon.friction * tensions[k] * np.linalg.norm(turn)
            done = np.max(np.abs(new - rate), initial=0.0) <= 1e-15 * (
                np.max(np.abs(new), initial=0.0) + 1e-300)
            rate = new
            if done:
                break
        else:
            raise RuntimeError("friction reference: the tension rates did not converge")
        return u, v, rate


def _kink(segment: _Segment, s: float, rot: np.ndarray, moment: np.ndarray,
          force: np.ndarray, before: np.ndarray, paths: list[list[np.ndarray]]) -> np.ndarray:
    """The tensions just past ``s`` of the segment's tendons, whose tensions just before
    are ``before`` and whose directions before the turn are ``paths`` (world frame; the
    turn runs through them in order and on to the tangent past ``s``)."""
    tensions = before.copy()
    for _ in range(_FIXED_POINT):
        u, v = segment.strains_at(s, rot, moment, force, tensions)
        tangents = [rot @ t for t in _tangents(segment.tendons, s, u, v)]
        new = np.empty_like(tensions)
        for k, (tendon, path, t) in enumerate(zip(segment.tendons, paths, tangents,
                                                  strict=True)):
            chain = [*path, t]
            theta = sum(_angle(a, b) for a, b in zip(chain[:-1], chain[1:], strict=True))
            new[k] = before[k] * math.exp(-segment.sliding * tendon.friction * theta)
        done = np.max(np.abs(new - tensions)) <= 1e-15 * np.max(np.abs(new))
        tensions = new
        if done:
            return tensions
    raise RuntimeError("friction reference: a kink's tension did not converge")


def _shoot(m_start: np.ndarray, force: np.ndarray, breaks: list[float],
           sections: Sequence[Section], tendons: Sequence[FrictionTendon], load: float,
           sliding: float, s_out: np.ndarray, dense: bool):
    """Integrate from the clamp with M(0) = ``m_start``: M(L), or with ``dense`` the
    positions, frames and tensions (NaN where a tendon is absent) at ``s_out``."""
    count = len(tendons)
    y = np.r_[np.zeros(3), BASE_FRAME.ravel(), m_start, np.zeros(count)]
    positions = np.zeros((len(s_out), 3))
    frames = np.zeros((len(s_out), 3, 3))
    tension_out = np.full((len(s_out), count), np.nan)
    leaving: dict[int, np.ndarray] = {}  # tendon → its world tangent at the last break
    for a, b in zip(breaks[:-1], breaks[1:], strict=True):
        middle = 0.5 * (a + b)
        section = next(sec for sec in sections if sec.end >= middle)
        active = [k for k, t in enumerate(tendons) if t.tendon.start <= middle <= t.tendon.end]
        segment = _Segment(section, [tendons[k] for k in active], sliding)
        rot, moment = y[3:12].reshape(3, 3), y[12:15]
        before, paths = np.empty(len(active)), []
        for i, k in enumerate(active):
            if k in leaving:
                before[i], path = y[15 + k], [leaving[k]]
            else:  # the entry: along d3, then the lumen's rest tangent
                _, slope, _ = _routing(tendons[k], a)
                before[i] = load * tendons[k].tendon.tension
                path = [rot @ _E3, rot @ ((_E3 + slope) / np.linalg.norm(_E3 + slope))]
            paths.append(path)
        if active:
            y = y.copy()
            y[[15 + k for k in active]] = _kink(segment, a, rot, moment, force, before, paths)

        def rhs(s: float, y: np.ndarray, segment: _Segment = segment,
                active: list[int] = active) -> np.ndarray:
            rot = y[3:12].reshape(3, 3)
            u, v, rate = segment.rates(s, rot, y[12:15], force, y[[15 + k for k in active]])
            dp = rot @ v
            out = np.zeros_like(y)
            out[:3], out[3:12], out[12:15] = dp, (rot @ _skew(u)).ravel(), -_cross(dp, force)
            out[[15 + k for k in active]] = rate
            return out

        solution = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=_RTOL, atol=_ATOL,
                             dense_output=dense)
        if not solution.success:
            raise RuntimeError(f"friction reference: integration failed: {solution.message}")
        inside = (s_out >= a) & (s_out <= b)
        if dense and np.any(inside):
            values = solution.sol(s_out[inside])
            positions[inside] = values[:3].T
            frames[inside] = values[3:12].T.reshape(-1, 3, 3)
            for k in active:
                tension_out[inside, k] = values[15 + k]
        y = solution.y[:, -1]
        rot = y[3:12].reshape(3, 3)
        u, v = segment.strains_at(b, rot, y[12:15], force, y[[15 + k for k in active]])
        leaving = {k: rot @ t for k, t in zip(active, _tangents(segment.tendons, b, u, v),
                                              strict=True)}
    if dense:
        return positions, frames, tension_out
    return y[12:15]


def friction_tendon_rod(length: float, sections: Sequence[Section],
                        tendons: Sequence[FrictionTendon],
                        tip_force: ArrayLike = (0.0, 0.0, 0.0),
                        tip_moment: ArrayLike = (0.0, 0.0, 0.0),
                        s: np.ndarray | None = None, origin: ArrayLike = (0.0, 0.0, 0.0),
                        tolerance: float = 1e-12, load_steps: int = 1,
                        sliding: float = 1.0) -> TendonRodSolution:
    """The equilibrium of a clamped rod under ``tendons`` sliding with friction (``sliding``
    = +1: every tendon pulled in, −1: let out) and a tip wrench, as
    ``rodsim.core.analytic.tendon_bvp.tendon_rod``; ``extra["tension"]`` holds each
    tendon's T(s) at ``s`` (len(s), len(tendons)), NaN where the tendon is absent."""
    force = np.asarray(tip_force, dtype=float)
    moment = np.asarray(tip_moment, dtype=float)
    if abs(sections[-1].end - length) > 1e-12 * length:
        raise ValueError("the sections must end at the rod's length")
    if sliding not in (1.0, -1.0):
        raise ValueError(f"sliding must be +1 or -1, not {sliding!r}")
    for tendon in tendons:
        if not 0.0 <= tendon.tendon.start < tendon.tendon.end <= length * (1 + 1e-12):
            raise ValueError("a tendon's span is not within [0, L] or empty")
        if not tendon.friction >= 0.0:
            raise ValueError(f"friction must be >= 0, not {tendon.friction!r}")
    s_out = np.linspace(0.0, length, 2) if s is None else np.asarray(s, dtype=float)
    breaks = sorted({0.0, length, *(min(t.tendon.end, length) for t in tendons),
                     *(t.tendon.start for t in tendons),
                     *(min(sec.end, length) for sec in sections)})
    scale = sections[0].bending / length
    m0 = moment + np.cross(length * BASE_FRAME[:, 2], force)
    iterations, residual = 0, math.inf
    for step in range(1, load_steps + 1):
        load = step / load_steps

        def shoot(m_start: np.ndarray, load: float = load) -> np.ndarray:
            return _shoot(m_start, force * load, breaks, sections, tendons, load, sliding,
                          s_out, False)

        m0, residual, taken = base_moment_newton(shoot, m0, moment * load, scale, tolerance,
                                                 f"friction reference at load {load:g}")
        iterations += taken
    positions, frames, tension = _shoot(m0, force, breaks, sections, tendons, 1.0, sliding,
                                        s_out, True)
    return TendonRodSolution(s_out, positions + np.asarray(origin, dtype=float), frames,
                             residual, iterations, {"tension": tension})


def scene_friction_reference(scene, s: np.ndarray | None = None, shear: bool = True,
                             load_steps: int = 1, sliding: float = 1.0) -> TendonRodSolution:
    """The reference of a scene as ``rodsim.core.analytic.tendon_bvp.scene_reference``
    reads it, each tendon sliding with its own ``tendon_string.friction`` (a cold solve's
    history: ``sliding = +1``, pulled in from slack)."""
    problem = scene_problem(scene, shear)
    tendons = [FrictionTendon(t, mu, routing.second_derivatives)
               for t, mu, routing in zip(problem.tendons, problem.frictions, problem.routings,
                                         strict=True)]
    return friction_tendon_rod(problem.length, problem.sections, tendons, problem.force,
                               problem.moment, s=s, origin=problem.origin,
                               load_steps=load_steps, sliding=sliding)

"""Rucker–Webster reference: a Cosserat rod driven by frictionless tendons, solved by shooting.

The independent check of the string tendon (rodsim/core/terms/tendon_string.py); written
from the continuum equations of Rucker & Webster, "Statics and dynamics of continuum robots
with general tendon routing and external loading", IEEE T-RO 27(6), 2011, in a different
form from theirs (docs/analytic.md, "Tendon-driven rod").

Model (SI units, s the rest arc length, world frame as rodsim's: the unloaded rod along +x
with d1 = +y, d2 = +z). The backbone: p′ = R v, R′ = R û, bending and twist
m = R K u, K = diag(EI, EI, GJ) per span (piecewise-constant sections), and the rod's
own axial and shear law with the strain energy of rodsim's stretch term and centerline
penalty, W = ½ EA (|v| − 1)² + ½ K_P |v/|v| − e3|² (force n = R ∂W/∂v); ``shear = inf``
makes the rod unshearable (v = λ e3). Tendon i (tension T_i, body-frame routing ρ_i(s),
i active on [0, e_i], frictionless and inextensible) runs along p_i = p + R ρ_i with unit
tangent t_i = R τ_i, τ_i = a_i / |a_i|, a_i = v + u × ρ_i + ρ_i′.

Instead of the distributed tendon loads and the point wrenches at each termination, the
equations are written for the *section wrench* of backbone and tendons together: the force
N = n + Σ T_i t_i and the moment M = m + Σ (R ρ_i) × T_i t_i about p, summed over the
tendons crossing the section. The tendons then carry no external load but the tip wrench
(F, L_tip), so

    N ≡ F,   M′ = −p′ × F,   M(L) = L_tip,

continuous across every termination (where a tendon ends, its tension passes to the
backbone: the point force and moment on the backbone and the kink in the path of the
tendons that pass on are implied) and every entry past the base (where the pull's reaction
acts on the rod: a Bowden sheath ending there, or an actuator the rod carries — the
potential T ℓ of rodsim's string tendon). At each s, the strains (u, v) solve the algebraic
system K u + Σ T_i ρ_i × τ_i = Rᵀ M and ∂W/∂v + Σ T_i τ_i = Rᵀ F (Newton, analytic
Jacobian). Shooting: the unknown M(0) (3 values) is found by Newton on M(L) − L_tip with
a finite-difference Jacobian; each shot integrates p, R, M with DOP853 at rtol 1e-12 from
the clamp p(0) = origin, R(0) = the base frame, piecewise between entries, terminations and
span ends. Assumes: routing C¹ on each tendon's span, a straight unstressed rod, no
gravity.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike
from scipy.integrate import solve_ivp

__all__ = ["BVPTendon", "SceneProblem", "Section", "TendonRodSolution", "base_moment_newton",
           "scene_problem",
           "scene_reference", "tendon_rod"]

_RTOL = 1e-12
_ATOL = 1e-14
#: The base frame of an unloaded rodsim rod: columns d1 = +y, d2 = +z, d3 = +x.
BASE_FRAME = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


@dataclass(frozen=True)
class Section:
    """One span of constant section, from the previous span's end to ``end`` [m]."""

    end: float
    #: E I [N m²], G J [N m²], E A [N], shear stiffness K_P [N] (``inf``: unshearable).
    bending: float
    twist: float
    axial: float
    shear: float = math.inf


@dataclass(frozen=True)
class BVPTendon:
    """A tendon from its entry ``start`` to its termination ``end`` [m], pulled with
    ``tension`` [N]; ``offset(s)`` and ``slope(s)`` give ρ(s) and ρ′(s) as arrays
    (len(s), 2). Past the base, the entry is where the pull's reaction acts on the rod (a
    Bowden sheath ending there, or an actuator the rod carries): the tension leaves the
    section wrench there as it does at the termination."""

    tension: float
    end: float
    offset: Callable[[np.ndarray], np.ndarray]
    slope: Callable[[np.ndarray], np.ndarray]
    start: float = 0.0


@dataclass(frozen=True)
class TendonRodSolution:
    """The equilibrium: positions (len(s), 3) and frames (len(s), 3, 3) at rest arc lengths s."""

    s: np.ndarray
    positions: np.ndarray
    frames: np.ndarray
    #: |M(L) − L_tip| / (EI / L) at the solution, and the Newton iterations it took.
    residual: float
    iterations: int
    extra: dict = field(default_factory=dict)

    @property
    def tip(self) -> np.ndarray:
        return self.positions[-1]


def _skew(a: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b of two 3-vectors: numpy.cross's products and differences, in its order (the
    same numbers), without its per-call cost (most of the shooting's time)."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def _with_zero(a: np.ndarray) -> np.ndarray:
    """(a₁, a₂, 0) of a 2-vector (np.r_[a, 0.0])."""
    return np.array([a[0], a[1], 0.0])


_EYE3 = np.eye(3)


class _Strains:
    """Solves the local system for (u, v) given the section wrench in the body frame."""

    def __init__(self, section: Section, tendons: Sequence[BVPTendon], load: float) -> None:
        self.k = np.array([section.bending, section.bending, section.twist])
        self.axial, self.shear = section.axial, section.shear
        self.tendons = tendons
        self.load = load
        self.z = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0])
        self.jacobian = np.eye(6)

    def _axial_shear(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """∂W/∂v and its Jacobian."""
        if math.isinf(self.shear):
            force = np.array([v[0], v[1], self.axial * (v[2] - 1.0)])
            return force, np.diag([1.0, 1.0, self.axial])
        r = float(np.linalg.norm(v))
        h = v / r
        q = _EYE3 - np.outer(h, h)
        e3 = np.array([0.0, 0.0, 1.0])
        c = h[2]
        f = e3 - c * h
        force = self.axial * (r - 1.0) * h - self.shear * f / r
        d_f = -np.outer(h, q[2]) / r - c * q / r
        jac = (self.axial * np.outer(h, h) + self.axial * (r - 1.0) * q / r
               - self.shear * (d_f / r - np.outer(f, h) / r**2))
        return force, jac

    def solve(self, s: float, m_body: np.ndarray, n_body: np.ndarray,
              tensions: ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(u, v) at ``s``; ``tensions`` [N] replace ``load`` × each tendon's own (a
        tension that varies along the tendon: rodsim/core/analytic/tendon_friction_bvp.py).
        The system's Jacobian at the solution is kept in ``jacobian``."""
        at = np.array([s])
        rho = [_with_zero(t.offset(at)[0]) for t in self.tendons]
        slope = [_with_zero(t.slope(at)[0]) for t in self.tendons]
        skews = [_skew(r) for r in rho]
        z = self.z.copy()
        for _ in range(50):
            u, v = z[:3], z[3:]
            g1 = self.k * u - m_body
            g2, d2v = self._axial_shear(v)
            g2 = g2 - _unshearable_rhs(n_body, self.shear)
            jac = np.zeros((6, 6))
            jac[:3, :3] = np.diag(self.k)
            jac[3:, 3:] = d2v
            for k, (tendon, r, rs, dr) in enumerate(zip(self.tendons, rho, skews, slope,
                                                         strict=True)):
                tension = (self.load * tendon.tension if tensions is None
                           else float(np.asarray(tensions)[k]))
                a = v + _cross(u, r) + dr
                norm = float(np.linalg.norm(a))
                tau = a / norm
                proj = (_EYE3 - np.outer(tau, tau)) / norm
                g1 += tension * (rs @ tau)
                contribution = tension * tau
                if math.isinf(self.shear):
                    contribution[:2] = 0.0
                    proj_rows = proj.copy()
                    proj_rows[:2] = 0.0
                else:
                    proj_rows = proj
                g2 = g2 + contribution
                jac[:3, :3] -= tension * rs @ proj @ rs
                jac[:3, 3:] += tension * rs @ proj
                jac[3:, :3] -= tension * proj_rows @ rs
                jac[3:, 3:] += tension * proj_rows
            g = np.concatenate((g1, g2))
            self.jacobian = jac
            step = np.linalg.solve(jac, g)
            z = z - step
            if np.max(np.abs(step)) < 1e-15 * (1.0 + np.max(np.abs(z))):
                break
        self.z = z
        return z[:3], z[3:]


def _unshearable_rhs(n_body: np.ndarray, shear: float) -> np.ndarray:
    """The body-frame section force the axial/shear law balances (its shear rows dropped for
    an unshearable rod, whose v1 = v2 = 0 rows stand in their place)."""
    if math.isinf(shear):
        return np.array([0.0, 0.0, n_body[2]])
    return n_body


def base_moment_newton(shoot: Callable[[np.ndarray], np.ndarray], m0: np.ndarray,
                       target: np.ndarray, scale: float, tolerance: float, what: str
                       ) -> tuple[np.ndarray, float, int]:
    """Newton on the base moment ``m0`` until the tip moment ``shoot(m0)`` is ``target``
    within ``tolerance`` · ``scale`` (finite-difference Jacobian, steps of 1e-6 · scale):
    the shooting of both references (this module's and the friction one's). Returns the
    base moment, the scaled residual and the iterations taken; RuntimeError naming ``what``
    after 60."""
    residual = math.inf
    for iteration in range(60):
        end_moment = shoot(m0)
        r = (end_moment - target) / scale
        residual = float(np.max(np.abs(r)))
        if residual < tolerance:
            return m0, residual, iteration
        jac = np.empty((3, 3))
        h = 1e-6 * scale
        for k in range(3):
            dm = np.zeros(3)
            dm[k] = h
            jac[:, k] = (shoot(m0 + dm) - end_moment) / h
        m0 = m0 - np.linalg.solve(jac, r * scale)
    raise RuntimeError(f"{what}: Newton did not converge (residual {residual:.3g}); raise "
                       "load_steps")


def tendon_rod(length: float, sections: Sequence[Section], tendons: Sequence[BVPTendon],
               tip_force: ArrayLike = (0.0, 0.0, 0.0),
               tip_moment: ArrayLike = (0.0, 0.0, 0.0),
               s: np.ndarray | None = None, origin: ArrayLike = (0.0, 0.0, 0.0),
               tolerance: float = 1e-12, load_steps: int = 1) -> TendonRodSolution:
    """The equilibrium of a clamped rod (base at ``origin``, frame ``BASE_FRAME``) under
    the ``tendons`` and a tip wrench (world frame); ``sections`` cover [0, length] in order.

    Newton on the base moment stops when |M(L) − L_tip| < ``tolerance`` · EI/L; the tensions
    and the wrench are ramped in ``load_steps`` equal steps (more for large deflections).
    """
    force = np.asarray(tip_force, dtype=float)
    moment = np.asarray(tip_moment, dtype=float)
    if abs(sections[-1].end - length) > 1e-12 * length:
        raise ValueError("the sections must end at the rod's length")
    for tendon in tendons:
        if not 0.0 <= tendon.start < tendon.end <= length * (1 + 1e-12):
            raise ValueError(f"tendon span [{tendon.start!r}, {tendon.end!r}] not within "
                             "[0, L] or empty")
    s_out = np.linspace(0.0, length, 2) if s is None else np.asarray(s, dtype=float)
    breaks = sorted({0.0, length, *(min(t.end, length) for t in tendons),
                     *(t.start for t in tendons), *(min(sec.end, length) for sec in sections)})
    scale = sections[0].bending / length
    m0 = moment + np.cross(length * BASE_FRAME[:, 2], force)
    iterations = 0
    residual = math.inf
    for step in range(1, load_steps + 1):
        load = step / load_steps

        def shoot(m_start: np.ndarray, load: float = load) -> np.ndarray:
            return _shoot(m_start, force * load, breaks, sections, tendons, load, s_out,
                          False)

        m0, residual, taken = base_moment_newton(shoot, m0, moment * load, scale, tolerance,
                                                 f"tendon_rod at load {load:g}")
        iterations += taken
    positions, frames = _shoot(m0, force, breaks, sections, tendons, 1.0, s_out, True)
    return TendonRodSolution(s_out, positions + np.asarray(origin, dtype=float), frames,
                             residual, iterations)


def _shoot(m_start: np.ndarray, force: np.ndarray, breaks: list[float],
           sections: Sequence[Section], tendons: Sequence[BVPTendon], load: float,
           s_out: np.ndarray, dense: bool):
    """Integrate from the clamp with M(0) = ``m_start``: M(L), or with ``dense`` the
    positions and frames at ``s_out``."""
    y = np.r_[np.zeros(3), BASE_FRAME.ravel(), m_start]
    positions = np.zeros((len(s_out), 3))
    frames = np.zeros((len(s_out), 3, 3))
    for a, b in zip(breaks[:-1], breaks[1:], strict=True):
        middle = 0.5 * (a + b)
        section = next(sec for sec in sections if sec.end >= middle)
        active = [t for t in tendons if t.start <= middle <= t.end]
        strains = _Strains(section, active, load)

        def rhs(s: float, y: np.ndarray, strains: _Strains = strains) -> np.ndarray:
            rot = y[3:12].reshape(3, 3)
            u, v = strains.solve(s, rot.T @ y[12:15], rot.T @ force)
            dp = rot @ v
            dr = rot @ _skew(u)
            return np.concatenate((dp, dr.ravel(), -_cross(dp, force)))

        inside = (s_out >= a) & (s_out <= b)
        solution = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=_RTOL, atol=_ATOL,
                             dense_output=dense)
        if not solution.success:
            raise RuntimeError(f"tendon_rod: integration failed: {solution.message}")
        if dense and np.any(inside):
            values = solution.sol(s_out[inside])
            positions[inside] = values[:3].T
            frames[inside] = values[3:12].T.reshape(-1, 3, 3)
        y = solution.y[:, -1]
    if dense:
        return positions, frames
    return y[12:15]


@dataclass(frozen=True)
class SceneProblem:
    """What the reference reads from a scene (``scene_problem``): the catheter's
    length, spans and base position, its string tendons (with each one's routing and
    friction coefficient μ, in the scene's order) and the tip wrench (world frame)."""

    length: float
    sections: list[Section]
    tendons: list[BVPTendon]
    routings: list
    frictions: list[float]
    force: np.ndarray
    moment: np.ndarray
    origin: np.ndarray


def scene_reference(scene, s: np.ndarray | None = None, shear: bool = True,
                    load_steps: int = 1) -> TendonRodSolution:
    """The reference of a rodsim scene whose string tendons all act on one catheter rod:
    its E I, G J, E_s A per span of its sections (or of the uniform rod) and K_P
    (``shear = False``: unshearable), its tip load's force (mass included, along its
    gravity), its world-frame point_loads at s = L (force and moment) and each tendon's
    tension, termination and routing (frictionless: each tendon's μ is ignored).
    ``scene`` is a ``rodsim.core.scene.Scene``. Raises ValueError for a scene the
    reference does not describe (other couplings, several catheters, gravity, a base other
    than the 'frame' clamp)."""
    problem = scene_problem(scene, shear)
    return tendon_rod(problem.length, problem.sections, problem.tendons, problem.force,
                      problem.moment, s=s, origin=problem.origin, load_steps=load_steps)


def scene_problem(scene, shear: bool = True) -> SceneProblem:
    """The problem ``scene_reference`` solves, read from ``scene`` (same arguments and
    errors)."""
    from rodsim.core.model import Model
    from rodsim.core.routing import Routing, string_span
    from rodsim.core.terms.bend_twist import stiffness_tensor
    from rodsim.core.terms.centerline import penalty_constant

    model = Model(scene)
    catheters = {options.catheter for options in scene.tendons.values()}
    if len(catheters) != 1 or any(o.coupling != "string" for o in scene.tendons.values()):
        raise ValueError("the reference needs string tendons on one catheter")
    name = catheters.pop()
    rod = model.rods[name]
    if rod.options.clamp != "frame":
        raise ValueError("the reference clamps position and frame at s = 0")
    terms = rod.options.terms
    if "gravity" in terms or not {"stretch", "bend_twist", "centerline"} <= set(terms):
        raise ValueError("the reference needs stretch, bend_twist and centerline, no gravity")
    bend = scene.term_options("rods", name, "bend_twist")
    k_p = penalty_constant(scene.term_options("rods", name, "centerline"), rod)
    shear_stiffness = float(k_p) if shear else math.inf
    profile = rod.profile
    if profile is None:
        k = stiffness_tensor(rod, bend.stiffness, bend.twist_stiffness)
        sections = [Section(rod.length, float(k[0]), float(k[2]), rod.stretch_stiffness,
                            shear_stiffness)]
    else:  # [[rods.<rod>.sections]]: one reference span per span (E I, G J, E_s A each)
        if bend.stiffness != "corrected" or bend.twist_stiffness > 0.0:
            raise ValueError("the reference reads sections with the 'corrected' tensor only")
        sections = [Section(float(end), float(e * i), float(g * j), float(es * a),
                            shear_stiffness)
                    for end, e, i, g, j, es, a in zip(
                        profile.end, profile.youngs_modulus, profile.second_moment,
                        profile.shear_modulus, profile.polar_moment, profile.stretch_modulus,
                        profile.area, strict=True)]
    tendons, routings, frictions = [], [], []
    for tendon_name, options in scene.tendons.items():
        string = scene.term_options("tendons", tendon_name, "tendon_string")
        start, end = string_span(string, rod.length)
        routing = Routing.of(options.offset, options.direction, string)
        tendons.append(BVPTendon(string.tension, end, routing.offsets, routing.derivatives,
                                 start))
        routings.append(routing)
        frictions.append(float(string.friction))
    force, moment = np.zeros(3), np.zeros(3)
    load = scene.term_options("rods", name, "tip_load")
    if load is not None:
        force = np.asarray(load.force, dtype=float) + np.array([0.0, -load.mass * load.gravity,
                                                                 0.0])
    if "distributed_load" in terms:
        raise ValueError("the reference takes no distributed load")
    points = scene.term_options("rods", name, "point_loads")
    for point in points.loads if points is not None and "point_loads" in terms else ():
        if point["frame"] != "world" or abs(point["s"] - rod.length) > 1e-12 * rod.length:
            raise ValueError("the reference takes world-frame point loads at the tip only")
        force = force + np.asarray(point["force"], dtype=float)
        moment = moment + np.asarray(point["moment"], dtype=float)
    return SceneProblem(rod.length, sections, tendons, routings, frictions, force, moment,
                        np.asarray(rod.origin, dtype=float))

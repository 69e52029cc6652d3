"""The friction reference (rodsim/core/analytic/tendon_friction_bvp.py: Rucker–Webster with
the capstan law, shooting at 1e-12) against closed forms, and rodsim's discrete friction
(rodsim/core/tendon_friction.py) against it in 3-D and on spacer disks (docs/tendon.md,
"Friction", "Against the continuum").

Closed forms (docs/tendon.md): a catheter bent by its own tendon (planar, constant offset ρ)
pulled in from slack has T(s) = T0/(1 + μ T0 ρ s/EI), Θ(s) = ln(1 + μ T0 ρ s/EI)/μ; let out
everywhere (every chord sliding toward the tip), T(s) = T0/(1 − μ T0 ρ s/EI),
Θ(s) = −ln(1 − μ T0 ρ s/EI)/μ; the tip is the quadrature of (1 − T/EA)(cos Θ, sin Θ).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from test_tendon_friction import EA, EI, LENGTH, OFFSET, catheter

import rodsim
from rodsim.core.analytic.tendon_bvp import scene_reference
from rodsim.core.analytic.tendon_friction_bvp import scene_friction_reference
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.core.tendon_friction import turning_angles
from rodsim.core.terms.tendon_string import TendonString

TDCR = "tdcr-two-segment"


def closed_form(mu: float, t0: float, sliding: float, s: np.ndarray):
    """(T(s), tip (lateral, axial)) of the self-bent catheter, every chord sliding in
    (``sliding`` = +1) or out (−1)."""
    c = sliding * mu * t0 * OFFSET / EI
    tension = lambda v: t0 / (1 + c * v)  # noqa: E731
    theta = lambda v: sliding * math.log1p(c * v) / mu  # noqa: E731
    tip = [quad(lambda v, f=f: (1 - tension(v) / EA) * f(theta(v)), 0.0, LENGTH,
                epsabs=1e-15, epsrel=1e-13)[0] for f in (math.sin, math.cos)]
    return np.array([tension(v) for v in s]), np.array(tip)


@pytest.mark.parametrize("sliding", [1.0, -1.0])
def test_the_reference_meets_the_closed_form_pulled_in_and_let_out(sliding):
    """μ = 0.25, 2.5 N: the reference's tip within 1e-10 L and its T(s) within 1e-10 T0 of
    the closed forms, pulled in from slack and let out along the whole tendon."""
    mu, t0 = 0.25, 2.5
    s = np.linspace(0.0, LENGTH, 9)
    solution = scene_friction_reference(Scene.from_dict(catheter(11, mu, t0)), s=s,
                                        sliding=sliding)
    tension, tip = closed_form(mu, t0, sliding, s)
    assert np.max(np.abs(solution.extra["tension"][:, 0] - tension)) < 1e-10 * t0
    got = np.array([solution.tip[1], solution.tip[0]])
    assert np.linalg.norm(got - tip) < 1e-10 * LENGTH
    assert abs(solution.tip[2]) < 1e-12 * LENGTH


def helix_catheter(nodes: int, friction: float) -> Scene:
    """The nitinol catheter of test_tendon_friction, 3 N on a tendon wound once around it
    on spacer disks (radius 10 mm, pitch 0.3 m): a 3-D bend."""
    return Scene.from_dict(catheter(nodes, friction, 3.0, routing="helix",
                                    helix_radius=0.01, helix_pitch=0.3, spacers=True))


def test_the_reference_without_friction_is_the_frictionless_reference():
    """μ = 0: the friction reference's equilibrium equals tendon_bvp's (1e-12 L), on a
    helical tendon bending its catheter in 3-D; with μ = 0.2 the tip moves by 1 % of L."""
    s = np.linspace(0.0, LENGTH, 5)
    plain = scene_reference(helix_catheter(11, 0.0), s=s)
    same = scene_friction_reference(helix_catheter(11, 0.0), s=s)
    assert np.max(np.abs(same.positions - plain.positions)) < 1e-12 * LENGTH
    np.testing.assert_array_equal(same.extra["tension"][:, 0], 3.0)
    rubbed = scene_friction_reference(helix_catheter(11, 0.2), s=s)
    assert np.linalg.norm(rubbed.tip - plain.tip) > 5e-3 * LENGTH


def _errors(scene_of, reference: np.ndarray, nodes, length: float) -> dict[int, float]:
    errors = {}
    for n in nodes:
        result = rodsim.solve(scene_of(n))
        assert result.success, result.message
        errors[n] = float(np.linalg.norm(result.positions()[-1] - reference)) / length
    return errors


def _orders(errors: dict[int, float]) -> list[float]:
    n = sorted(errors)
    return [math.log2(errors[a] / errors[b]) for a, b in zip(n[:-1], n[1:], strict=True)]


def test_a_helical_tendon_on_a_bent_catheter_against_the_reference():
    """3-D (μ = 0.2): the tip converges to the reference at order 2 (measured 3.5e-4,
    8.7e-5, 2.2e-5 L at N = 21, 41, 81; with the entry's plain angle it stalled near
    2e-5 L). The entry's kink t_in → t(0⁺) (the catheter's curvature across the offset,
    u × ρ) is out of the plane of the wrap that follows; the entry's turn runs through t⁺
    extrapolated from the first two chords (rodsim/core/tendon_friction.py, "Split
    turns"), and its part up to t⁺, ∠(d3, t_in) + ∠(t_in, t⁺), tends to the continuum's
    (d3 → the lumen's rest tangent → t(0⁺), from ln(T0/T(0⁺))/μ) at second order."""
    mu = 0.2
    reference = scene_friction_reference(helix_catheter(11, mu), s=np.array([0.0, LENGTH]))
    errors = _errors(lambda n: helix_catheter(n, mu), reference.positions[-1], (21, 41, 81),
                     LENGTH)
    assert errors[41] < 1e-4 and min(_orders(errors)) > 1.8, errors
    entry = math.log(3.0 / reference.extra["tension"][0, 0]) / mu
    gaps = []
    for n in (41, 81, 161):
        scene = helix_catheter(n, mu)
        model = Model(scene)
        full = model.full(rodsim.solve(scene).state)
        term = next(t for t in model.terms if isinstance(t, TendonString))
        axis, tangent = term.entry_directions(full)
        u = np.diff(term.path(full), axis=0)
        u /= np.linalg.norm(u, axis=1)[:, None]
        ahead = 1.5 * u[0] - 0.5 * u[1]
        ahead /= np.linalg.norm(ahead)
        # ∠(d3, t_in) + ∠(t_in, t⁺): the entry's plain turn onto a one-chord path along t⁺
        turn = float(turning_angles(axis, tangent, np.array([np.zeros(3), ahead]))[0])
        gaps.append(abs(turn - entry))
    assert min(_orders(dict(zip((41, 81, 161), gaps, strict=True)))) > 1.8, gaps


def tdcr(nodes: int, mu: float, planar: bool, one_way: bool = False) -> Scene:
    """tdcr-two-segment with every tendon's μ; ``planar``: no tip force and a shear
    stiffness 1000 times the backbone's (no shear kink at the entry); ``one_way``:
    segment 2's tendon s2b moved to segment 1's side (the path turns one way)."""
    values: dict = {f"tendons.{t}.tendon_string.friction": mu
                    for t in ("s1a", "s1b", "s1c", "s2a", "s2b", "s2c")}
    values["rods.backbone.nodes"] = nodes
    if planar:
        values |= {"rods.backbone.tip_load.force": [0.0, 0.0, 0.0],
                   "rods.backbone.centerline.K_P": 3.2e7}
    if one_way:
        values["tendons.s2b.direction"] = [1.0, 0.0]
    return rodsim.load_scene(TDCR).with_values(values)


@pytest.mark.slow
def test_spacer_disks_turning_one_way_converge_at_second_order():
    """tdcr-two-segment's spacer routing, both segments bent the same way (s1a 3 N, s2b
    2 N beside it, pretensions 0.5 N), μ = 0.3: the tip converges to the reference at
    order 2 (measured 7.3e-5, 1.9e-5, 4.8e-6 L at N = 31, 61, 121; the turns split at
    s = 0.2, where segment 1's tendons end, add 2e-5 L at N = 31 to the plain angles')."""
    reference = scene_friction_reference(tdcr(11, 0.3, True, True), s=np.array([0.4]))
    errors = _errors(lambda n: tdcr(n, 0.3, True, True), reference.positions[-1],
                     (31, 61, 121), 0.4)
    assert errors[61] < 1e-4 and min(_orders(errors)) > 1.8, errors


def test_spacer_disks_on_an_s_shape_converge_at_second_order():
    """tdcr-two-segment's S-shape (planar, μ = 0.3): segment 2's tendons wrap one way in
    segment 1 and the other way in segment 2. At s = 0.2, where segment 1's tendons end,
    their turns are split through tangents carried from two chords away on each side
    (rodsim/core/tendon_friction.py, "Split turns"): order 2 (measured 1.14e-5, 2.85e-6,
    7.12e-7 L at N = 31, 61, 121; with plain angles 2.4e-4, 1.2e-4, 6.1e-5, order 1.00)."""
    reference = scene_friction_reference(tdcr(11, 0.3, True), s=np.array([0.4]))
    errors = _errors(lambda n: tdcr(n, 0.3, True), reference.positions[-1], (31, 61, 121),
                     0.4)
    assert errors[61] < 1e-5 and min(_orders(errors)) > 1.8, errors


@pytest.mark.slow
def test_the_shipped_tdcr_with_friction_against_the_reference():
    """tdcr-two-segment as shipped (3-D: its tip force out of plane, its shear) with
    μ = 0.1: the entry's shear kink leaves the wrap's plane and segment 2's tendons turn
    back at s = 0.2; with the split turns the tip converges at order 2 (measured 5.7e-5,
    1.5e-5, 3.8e-6 L at N = 31, 61, 121; with plain angles 1.3e-4, 7.5e-5, 5.4e-5)."""
    reference = scene_friction_reference(tdcr(11, 0.1, False), s=np.array([0.4]))
    errors = _errors(lambda n: tdcr(n, 0.1, False), reference.positions[-1], (31, 61, 121),
                     0.4)
    assert errors[61] < 1e-4 and min(_orders(errors)) > 1.8, errors


def test_turns_are_split_where_another_tendon_ends_and_the_kernel_agrees():
    """On tdcr-two-segment (μ = 0.3) the turns of segment 2's tendons are split at the
    routing point at s = 0.2 only (segment 1's tendons end there), segment 1's nowhere;
    near the 3-D equilibrium the compiled kernel's force equals the numpy reference's, and
    at it the split wrap of s2b exceeds its plain angles' sum (the path turns back at s = 0.2)."""
    scene = tdcr(21, 0.3, False)
    result = rodsim.solve(scene)
    assert result.success, result.message
    models = {k: Model(scene.with_values({"solver.kernels": k})) for k in ("numpy",
                                                                           "compiled")}
    model = models["numpy"]
    terms = {t.tendon.name: t for t in model.terms if isinstance(t, TendonString)}
    for name, term in terms.items():
        marked = term.points.s[term.split]
        if name.startswith("s2"):
            np.testing.assert_allclose(marked, [0.2], rtol=0, atol=1e-12)
        else:
            assert not np.any(term.split)
    x = result.state + 1e-4 * np.random.default_rng(5).standard_normal(len(result.state))
    force = model.force(x)
    assert np.max(np.abs(models["compiled"].force(x) - force)) < 1e-12 * np.max(np.abs(force))
    full = model.full(result.state)
    term = terms["s2b"]
    split = float(np.sum(term.turning_angles(full)))
    plain = float(np.sum(turning_angles(*term.entry_directions(full), term.path(full))))
    assert split > plain + 0.01, (split, plain)  # measured 0.016 rad at N = 21

"""Tests of the continuum references in rodsim.core.analytic (paper Eqs. 21-23, docs/design.md,
erratum 9)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rodsim.core.analytic import (
    exact_elastica,
    extensible_elastica,
    load_parameter,
    paper_model,
    paper_model_as_printed,
    tip_angle_from_load,
)

# Table 1 catheter: E = 5.9 MPa, r = 6 mm, L = 0.12 m; hanging masses of Fig. 6 with g = 9.81.
E_MODULUS = 5.9e6
RADIUS = 0.006
LENGTH = 0.12
EI = E_MODULUS * math.pi * RADIUS**4 / 4
EA = E_MODULUS * math.pi * RADIUS**2
GRAVITY = 9.81


def force_for(alpha: float) -> float:
    """Tip load [N] giving load parameter alpha on the Table 1 catheter."""
    return 2.0 * EI * alpha / LENGTH**2


def max_distance(a, b) -> float:
    return float(max(np.max(np.abs(a.x - b.x)), np.max(np.abs(a.y - b.y))))


def test_load_parameter_of_the_50_g_case():
    # alpha = F L^2 / (2 EI), not the printed F L^2 / (2 E L)
    assert load_parameter(0.05 * GRAVITY, EI, LENGTH) == pytest.approx(0.588064, abs=1e-6)


@pytest.mark.parametrize(
    "force",
    [
        force_for(0.01),
        force_for(0.2),
        0.05 * GRAVITY,  # 50 g, alpha = 0.588
        0.10 * GRAVITY,  # 100 g, alpha = 1.176
        force_for(1.2),
        force_for(5.0),
        force_for(20.0),
    ],
)
def test_corrected_paper_model_matches_exact_elastica(force):
    model = paper_model(force, EI, LENGTH)
    exact = exact_elastica(force, EI, LENGTH, s=model.s)
    assert model.s[0] == 0.0
    assert model.s[-1] == pytest.approx(LENGTH, rel=1e-12)
    assert max_distance(model, exact) <= 1e-8 * LENGTH
    assert model.tip_angle == pytest.approx(exact.tip_angle, rel=1e-12)
    assert np.all(model.y <= 0.0) and model.tip[1] < 0.0


def test_printed_eq22_puts_the_clamp_at_the_tip_x():
    force = 0.05 * GRAVITY
    printed = paper_model_as_printed(force, EI, LENGTH)
    exact = exact_elastica(force, EI, LENGTH, s=printed.s)
    tip_x, tip_y = exact.tip
    # the clamp (phi = 0) lands at the tip's x and the tip at x = 0 ...
    assert printed.x[0] == pytest.approx(tip_x, rel=1e-12)
    assert printed.x[-1] == pytest.approx(0.0, abs=1e-12 * LENGTH)
    # ... so span and tip deflection are right while the curve in between is not
    assert abs(printed.x[0] - printed.x[-1]) == pytest.approx(tip_x, rel=1e-12)
    assert printed.y[-1] == pytest.approx(tip_y, rel=1e-12)
    assert np.max(np.abs(printed.x - exact.x)) > 0.9 * LENGTH


def test_small_load_limit_is_linear_beam_theory_at_second_order():
    # delta / L = (2 alpha / 3) (1 - 16 alpha^2 / 35 + O(alpha^4)) from a perturbation
    # expansion of EI phi'' = -F cos(phi) in alpha; linear theory is delta = F L^3 / (3 EI).
    alphas = np.array([1e-3, 2e-3, 4e-3, 8e-3, 1.6e-2])
    errors = []
    for alpha in alphas:
        force = force_for(alpha)
        deflection = -exact_elastica(force, EI, LENGTH).tip[1]
        errors.append(deflection / (force * LENGTH**3 / (3.0 * EI)) - 1.0)
    errors = np.array(errors)
    assert np.all(errors < 0.0)
    slope = np.polyfit(np.log(alphas), np.log(-errors), 1)[0]
    assert slope == pytest.approx(2.0, abs=1e-3)
    assert errors[0] / alphas[0] ** 2 == pytest.approx(-16.0 / 35.0, rel=1e-4)


def test_tip_angle_tends_to_alpha_for_small_loads():
    # linear beam theory: phi0 = F L^2 / (2 EI) = alpha
    assert tip_angle_from_load(1e-4) == pytest.approx(1e-4, rel=1e-7)
    assert tip_angle_from_load(0.0) == 0.0


@pytest.mark.parametrize("axial_stiffness", [np.inf, 1e12])
@pytest.mark.parametrize("force", [force_for(0.2), 0.05 * GRAVITY, force_for(5.0)])
def test_extensible_elastica_reduces_to_the_exact_elastica(axial_stiffness, force):
    rod = extensible_elastica((0.0, -force), EI, axial_stiffness, LENGTH)
    exact = exact_elastica(force, EI, LENGTH, s=rod.s)
    assert max_distance(rod, exact) <= 1e-9 * LENGTH
    assert rod.tip_angle == pytest.approx(exact.tip_angle, rel=1e-9)


def test_axial_tension_stretches_the_rod_by_f_l_over_ea():
    tension = 20.0  # [N], strain 0.03 on the Table 1 catheter
    rod = extensible_elastica((tension, 0.0), EI, EA, LENGTH)
    assert rod.tip[0] - LENGTH == pytest.approx(tension * LENGTH / EA, rel=1e-10)
    np.testing.assert_allclose(rod.x, rod.s * (1.0 + tension / EA), rtol=1e-12, atol=0.0)
    np.testing.assert_array_equal(rod.y, 0.0)
    assert rod.tip_angle == 0.0


@pytest.mark.parametrize(
    "force_xy",
    [(0.0, -2.0), (-1.5, -1.0), (3.0, -3.0), (0.0, 4.0), (-4.0, 0.3)],
)
def test_extensible_elastica_is_in_global_equilibrium(force_xy):
    axial_stiffness = 50.0  # soft enough that the stretch (up to 8 %) matters
    rod = extensible_elastica(force_xy, EI, axial_stiffness, LENGTH)
    fx, fy = force_xy
    tip_x, tip_y = rod.tip
    # m' + (r' x F)_z = 0 integrated over [0, L] with m(L) = 0: m(0) = (r(L) x F)_z
    clamp_moment = EI * rod.curvature[0]
    assert clamp_moment == pytest.approx(
        tip_x * fy - tip_y * fx, abs=1e-11 * math.hypot(*force_xy) * LENGTH
    )
    # boundary conditions: clamp at the origin along +x, no moment at the tip
    assert rod.x[0] == rod.y[0] == 0.0
    assert abs(rod.theta[0]) < 1e-11
    assert abs(rod.curvature[-1]) < 1e-12 / LENGTH
    # the load is dead: the tip turns towards it but never past it
    assert 0.0 < -np.sign(fy) * rod.tip_angle < abs(math.atan2(fy, fx))


def test_extensible_elastica_mirrors_with_the_transverse_force():
    down = extensible_elastica((-1.0, -2.0), EI, 50.0, LENGTH)
    up = extensible_elastica((-1.0, 2.0), EI, 50.0, LENGTH)
    np.testing.assert_allclose(up.x, down.x, rtol=0.0, atol=1e-12 * LENGTH)
    np.testing.assert_allclose(up.y, -down.y, rtol=0.0, atol=1e-12 * LENGTH)
    assert up.tip_angle == pytest.approx(-down.tip_angle, rel=1e-10)


@pytest.mark.parametrize("reference", [exact_elastica, paper_model])
def test_zero_load_gives_the_straight_rod(reference):
    rod = reference(0.0, EI, LENGTH)
    np.testing.assert_array_equal(rod.x, rod.s)
    np.testing.assert_array_equal(rod.y, 0.0)
    assert rod.tip_angle == 0.0
    assert rod.tip == pytest.approx([LENGTH, 0.0])


@pytest.mark.parametrize("reference", [exact_elastica, paper_model, paper_model_as_printed])
@pytest.mark.parametrize(
    ("force", "stiffness", "length"),
    [(-1.0, EI, LENGTH), (1.0, EI, 0.0), (math.nan, EI, LENGTH), (1.0, math.inf, LENGTH)],
)
def test_cantilever_references_reject_bad_input(reference, force, stiffness, length):
    with pytest.raises(ValueError):
        reference(force, stiffness, length)


@pytest.mark.parametrize(
    ("force_xy", "axial_stiffness", "length", "s"),
    [
        ((math.nan, -1.0), EA, LENGTH, None),
        ((0.0, -1.0), EA, 0.0, None),
        ((0.0, -1.0), -EA, LENGTH, None),
        ((0.0, -1.0), math.nan, LENGTH, None),
        ((0.0, -1.0, 0.0), EA, LENGTH, None),
        ((0.0, -1.0), EA, LENGTH, [0.0, 2.0 * LENGTH]),
    ],
)
def test_extensible_elastica_rejects_bad_input(force_xy, axial_stiffness, length, s):
    with pytest.raises(ValueError):
        extensible_elastica(force_xy, EI, axial_stiffness, length, s=s)


def test_load_parameter_and_tip_angle_reject_bad_input():
    with pytest.raises(ValueError):
        load_parameter(1.0, 0.0, LENGTH)
    with pytest.raises(ValueError):
        tip_angle_from_load(-1.0)
    with pytest.raises(ValueError):
        tip_angle_from_load(math.nan)
    with pytest.raises(ValueError):
        exact_elastica(1.0, EI, LENGTH, s=[-0.01, 0.05])

"""Discretisation error of the model against continuum references (docs/design.md §4).

Only the ``static`` integrator is used: it returns the exact discrete equilibrium, so the
errors below are the model's, not a solver's. Run with ``pytest -s`` to see the tables.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

import rodsim
from rodsim.core.analytic import exact_elastica, extensible_elastica

TABLE1 = ("table1-20g", "table1-50g", "table1-100g")
NODES = (10, 20, 40, 80)
LENGTH = 0.12  # m, Table 1 (checked in test_tip_error_against_the_exact_elastica_at_40_nodes)
# A penalty K_P this stiff needs more Newton iterations per load step than the default 30
# (the result does not depend on this budget, only the number of load steps does).
STIFF = ("K_P=1e8", "static.max_newton=200")


def catheter(scene) -> dict:
    return next(iter(scene.data["rods"].values()))


def tip_force(rod: dict) -> float:
    """Hanging mass × g [N], pulling along −y."""
    return rod["tip_load"]["mass"] * rod["tip_load"]["gravity"]


def bending_stiffness(rod: dict) -> float:
    """E I = E π r⁴ / 4 [N m²], from the scene values (Eq. 8)."""
    return rod["youngs_modulus"] * math.pi * rod["radius"] ** 4 / 4.0


def stretch_stiffness(rod: dict) -> float:
    """E_s A = E_s π r² [N] (Eq. 6)."""
    return rod["stretch_modulus"] * math.pi * rod["radius"] ** 2


@functools.cache
def static_tip(scene_name: str, overrides: tuple[str, ...]) -> tuple[np.ndarray, dict]:
    result = rodsim.solve(scene_name, "static", overrides=list(overrides))
    assert result.success, result.message
    return result.tip(), catheter(result.scene)


@pytest.mark.parametrize("scene_name", TABLE1)
def test_tip_error_against_the_exact_elastica_at_40_nodes(scene_name):
    """Fig. 6/7: N = 40 and the default K_P = 1e4 put the tip within 0.5 % of L."""
    tip, rod = static_tip(scene_name, ())
    assert rod["nodes"] == 40 and rod["centerline"]["K_P"] == 1e4
    length = rod["length"]
    assert length == LENGTH
    exact = exact_elastica(tip_force(rod), bending_stiffness(rod), length)
    error = math.hypot(tip[0] - exact.x[-1], tip[1] - exact.y[-1]) / length
    print(f"\n{scene_name}: tip error vs exact elastica {100 * error:.4f} % of L "
          f"(tip deflection {-exact.y[-1] / length:.3f} L)")
    assert error < 5e-3
    # The load is not negligible: the error is small compared with the deflection.
    assert -exact.y[-1] > 0.1 * length


def convergence(clamp: str, penalty: tuple[str, ...]) -> np.ndarray:
    """Tip errors [m] against the extensible elastica for N = 10, 20, 40, 80."""
    errors = []
    for nodes in NODES:
        tip, rod = static_tip("table1-50g", (*penalty, f"nodes={nodes}", f"clamp={clamp!r}"))
        ref = extensible_elastica((0.0, -tip_force(rod)), bending_stiffness(rod),
                                  stretch_stiffness(rod), rod["length"])
        errors.append(math.hypot(tip[0] - ref.x[-1], tip[1] - ref.y[-1]))
    return np.array(errors)


@pytest.mark.parametrize(("clamp", "order_range"),
                         [("frame", (1.8, 2.2)), ("first_segment", (0.8, 1.2))])
def test_convergence_order_in_n(clamp, order_range):
    """Observed order log2(e_N / e_2N) of the tip error, 50 g.

    The reference is the extensible (E_s A), unshearable elastica: the continuum limit of
    the discrete model. The centerline penalty K_P lets the directors deviate from the
    tangent like a shear compliance, by ≈ F / K_P, which moves the tip by ≈ L F / K_P
    whatever N: 6e-6 m at K_P = 1e4 — more than the N = 80 discretisation error (4e-6 m)
    — but 6e-10 m at K_P = 1e8, which leaves the discretisation error alone to measure.
    The 'frame' clamp (a fixed frame at s = 0, half a segment before q_0) is second order;
    'first_segment' (q_0 itself fixed, PyElastica's clamp) stiffens the first half segment
    and is first order.
    """
    errors = convergence(clamp, STIFF)
    orders = np.log2(errors[:-1] / errors[1:])
    print(f"\nclamp {clamp!r}, K_P = 1e8, tip error vs extensible elastica:")
    for nodes, error in zip(NODES, errors, strict=True):
        print(f"  N = {nodes:3d}: {error:.4e} m = {error / LENGTH:.3e} L")
    print("  observed orders: " + ", ".join(f"{p:.3f}" for p in orders))
    low, high = order_range
    assert np.all(orders > low) and np.all(orders < high), orders


def test_penalty_error_floor_at_default_k_p():
    """At K_P = 1e4 the penalty's compliance, not N, limits the accuracy at N = 80."""
    stiff = convergence("frame", STIFF)
    default = convergence("frame", ("K_P=1e4",))
    print(f"\nN = 80 tip error: K_P = 1e4 {default[-1]:.3e} m, K_P = 1e8 {stiff[-1]:.3e} m")
    print("K_P = 1e4 observed orders: "
          + ", ".join(f"{p:.3f}" for p in np.log2(default[:-1] / default[1:])))
    assert default[-1] > stiff[-1]
    # At coarse N the discretisation error dominates and the penalty hardly matters.
    assert abs(default[0] - stiff[0]) < 0.1 * stiff[0]

"""The stability verdict along a sequence of steps (rodsim/core/stability_tracking.py): the
eigenvalues of a non-symmetric K nearest zero by an Arnoldi process started from the last
step's, against the verdict of each K alone (ARPACK from its fixed start, what every
verdict was before: ``NearestModes`` switched off) and against dense eigenvalues of K.
The compiled Arnoldi steps against numpy's and LAPACK's band solve."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as la
from band_storage import band_lu

import rodsim
import rodsim.core.stability as stability
import rodsim.core.stability_tracking as tracking
from rodsim.app.inverse.parameter_keys import numeric_keys, scene_with
from rodsim.app.inverse.sensitivity import registered_model
from rodsim.core.model import Model
from rodsim.core.stability_band import BandLU


class _Cold(tracking.NearestModes):
    """Nothing remembered, ever: every verdict ARPACK's from its fixed start (the verdict
    of each K alone)."""

    def nearest(self, *args, **kwargs):
        return None

    def seed(self, *args, **kwargs):
        return None


def _tracked(scene, key: str, values: np.ndarray, cold: bool) -> tuple[list, rodsim.Tracker]:
    keys = numeric_keys(scene, [key])
    tracker = rodsim.Tracker(scene_with(scene, keys, values[:1]), [key])
    if cold:
        tracker._modes = _Cold()
    steps = [tracker.step([value]) for value in values[1:]]
    assert all(step.success for step in steps), [step.message for step in steps]
    return steps, tracker


def _compare(scene, key: str, values: np.ndarray, rel: float = 1e-9
             ) -> tuple[list, list, rodsim.Tracker]:
    """The Tracker along ``values`` with and without the remembered eigenvectors: the same
    states bit for bit (the verdict does not steer the path), the same verdicts, the same
    NaNs, and the smallest real parts within ``rel`` (relative)."""
    warm, tracker = _tracked(scene, key, values, cold=False)
    cold, _ = _tracked(scene, key, values, cold=True)
    for a, b in zip(warm, cold, strict=True):
        assert np.array_equal(a.state, b.state)
        assert a.stability.stable == b.stability.stable
        assert a.stability.neutral_modes == b.stability.neutral_modes
        assert np.isnan(a.stability.min_eigenvalue) == np.isnan(b.stability.min_eigenvalue)
        if not np.isnan(b.stability.min_eigenvalue):
            assert a.stability.min_eigenvalue == pytest.approx(
                b.stability.min_eigenvalue, rel=rel, abs=0.0)
    return warm, cold, tracker


def test_table3_catheter1_tendon_ramp_gives_the_verdicts_of_each_stiffness_alone():
    """table3-catheter1, tendon force 0 → 4 N in 200 Tracker steps (a non-symmetric K whose
    symmetric part is indefinite at every step: each verdict from the eigenvalues nearest
    zero): the same verdicts as each K alone, the smallest real parts within 1e-9 (measured
    1.8e-11), the first step's bit for bit (nothing remembered yet: ARPACK's). The warm
    starts are taken (fewer than ARPACK's 21 back-solves a verdict on average: measured
    15.6), and the smallest real part is that of the dense eigenvalues of K⁻¹ nearest zero
    (to 1e-7, every 40th step)."""
    scene = rodsim.load_scene("table3-catheter1")
    key = "tendons.tendon.tendon_actuation.force"
    values = np.linspace(0.0, 4.0, 201)
    warm, cold, tracker = _compare(scene, key, values)
    assert warm[0].stability.min_eigenvalue == cold[0].stability.min_eigenvalue
    assert all(step.stability.stable for step in warm)
    modes = tracker._modes
    assert 0 < modes.solves < 20 * len(warm)
    for index in range(0, len(warm), 40):
        model = Model(scene_with(scene, numeric_keys(scene, [key]), values[index + 1:index + 2]))
        x = warm[index].state
        model = registered_model(model, x)
        inverse = np.linalg.inv(-model.jacobian(x).toarray())
        nearest = 1.0 / np.linalg.eigvals(inverse)
        nearest = nearest[np.argsort(np.abs(nearest))[:stability.NEAREST]]
        assert warm[index].stability.min_eigenvalue == pytest.approx(
            float(np.min(nearest.real)), rel=1e-7)


def test_tdcr_two_segment_ramp_gives_the_same_verdicts():
    """tdcr-two-segment, segment 1's tendon s1a 0 → 3 N (string tendons: a conservative,
    certified K): nothing to remember, the same verdicts."""
    scene = rodsim.load_scene("tdcr-two-segment")
    warm, _, tracker = _compare(scene, "tendons.s1a.tendon_string.tension",
                                np.linspace(0.0, 3.0, 201))
    assert all(step.stability.stable for step in warm)
    assert tracker._modes.solves == 0


def follower_robot(seed: int, follower: float) -> tuple[dict, float]:
    """A seeded robot with a follower tip force of ``follower`` Euler loads (``point_loads``
    in the body frame, along its tangent d3: Beck's load, K non-symmetric, its symmetric
    part indefinite from ~1 Euler load of compression on): even seeds a nitinol wire (E
    50–80 GPa, radius 0.2–0.35 mm), odd ones a soft polymer catheter (E 5–40 MPa, radius
    1–2 mm); 32 to 44 nodes (more than ``DENSE_NONSYMMETRIC_LIMIT`` coordinates: the
    eigenvalues nearest zero judge). Returns the scene and its Euler load π² E I / (4 L²)
    [N], in which the ramps of ``tip_load.force[0]`` (a dead load along the rod's axis, +x)
    are set."""
    rng = np.random.default_rng(seed)
    if seed % 2 == 0:
        modulus, radius, length = rng.uniform(5e10, 8e10), rng.uniform(2e-4, 3.5e-4), 0.15
    else:
        modulus, radius, length = rng.uniform(5e6, 4e7), rng.uniform(1e-3, 2e-3), 0.2
    length *= rng.uniform(0.8, 1.2)
    euler = math.pi**2 * modulus * math.pi * radius**4 / 4 / (4 * length**2)
    rod = {"length": length, "radius": radius, "youngs_modulus": modulus,
           "density": 1100.0, "nodes": int(rng.integers(32, 45)),
           "terms": ["stretch", "bend_twist", "centerline", "tip_load", "point_loads"],
           "tip_load": {"force": [0.0, 0.0, 0.0]},
           "point_loads": {"loads": [{"s": length, "force": [0.0, 0.0, follower * euler],
                                      "frame": "body"}]}}
    return {"name": f"follower-robot-{seed}", "rods": {"rod": rod},
            "solver": {"integrator": "static", "max_wall_time": 60.0}}, euler


KEY = "rods.rod.tip_load.force[0]"


@pytest.mark.parametrize("seed", range(4))
def test_follower_robots_get_the_verdicts_of_each_stiffness_alone(seed):
    """A seeded family of robots pushed by a follower tip force of 3 Euler loads (short of
    Beck's flutter load, ~8; no divergence) and by a dead load along the axis, 0 → 2.5 Euler
    loads in 30 steps (its divergence, measured, at ~3.2): stable all the way, the
    symmetric part certified at first and then not (the eigenvalues nearest zero judge);
    the same verdicts as each K alone, and the same smallest real parts to 1e-7: these K
    are ill-conditioned (the wire's stretch against a smallest eigenvalue 3e-4), and the
    dense eigenvalues of K⁻¹ nearest zero differ from ARPACK's and from the warm start's
    alike, by up to 3.4e-8 and 2.9e-8 (seed 0; the two from each other 1.1e-8)."""
    scene, euler = follower_robot(seed, -3.0)
    scene = rodsim.load_scene(scene)
    warm, _, tracker = _compare(scene, KEY, -np.linspace(0.0, 2.5, 31) * euler, rel=1e-7)
    assert all(step.stability.stable for step in warm)
    judged = [not np.isnan(step.stability.min_eigenvalue) for step in warm]
    assert judged.count(True) > 10
    assert tracker._modes.solves > 0


@pytest.mark.parametrize("seed", [0, 1])
def test_a_follower_robot_pushed_past_its_divergence_flips_at_the_same_step(seed):
    """A robot of the family with a follower tip force of 1.5 Euler loads, pushed by a dead
    load along its axis to 3 Euler loads (the straight branch, which Newton keeps; a real
    eigenvalue of the non-symmetric K crosses zero, measured at ~1.6): the verdict flips
    at the same step as each K alone's and as the dense eigenvalues of K say (the smallest
    real part of all of them, at the steps either side), and stays unstable."""
    scene, euler = follower_robot(seed, -1.5)
    scene = rodsim.load_scene(scene)
    values = -np.linspace(0.0, 3.0, 31) * euler
    warm, _, _ = _compare(scene, KEY, values, rel=1e-7)
    flags = [step.stability.stable for step in warm]
    flip = flags.index(False)
    assert 0 < flip and not any(flags[flip:])
    dense = []
    for index in (flip - 1, flip):
        model = registered_model(Model(scene_with(scene, numeric_keys(scene, [KEY]),
                                                  values[index + 1:index + 2])),
                                 warm[index].state)
        dense.append(float(np.min(np.linalg.eigvals(
            -model.jacobian(warm[index].state).toarray()).real)))
    assert dense[0] > 0.0 > dense[1]


def _banded(seed: int, n: int = 240, lower: int = 5, upper: int = 7
            ) -> tuple[np.ndarray, BandLU]:
    """A random non-symmetric band matrix (well conditioned) and its band LU."""
    rng = np.random.default_rng(seed)
    dense = np.diag(2.0 + rng.uniform(0.0, 1.0, n))
    for k in range(-lower, upper + 1):
        if k:
            dense += np.diag(0.1 * rng.standard_normal(n - abs(k)), k)
    return dense, band_lu(dense, lower, upper)


@pytest.mark.parametrize("seed", range(3))
def test_the_compiled_steps_are_lapacks_solve_and_numpys_arnoldi(seed):
    """The compiled band solve against LAPACK's dgbtrs (1e-13 of the solution), and twelve
    compiled Arnoldi steps against numpy's: the same Krylov basis and Hessenberg matrix to
    1e-11, an orthonormal basis and the Arnoldi relation A⁻¹ V_m = V_{m+1} H_m."""
    from rodsim.core.kernels._arnoldi import band_lu_solve

    dense, factors = _banded(seed)
    n = dense.shape[0]
    rhs = np.random.default_rng(seed + 10).standard_normal(n)
    solved = rhs.copy()
    band_lu_solve(*factors.factors, solved)
    assert np.abs(solved - factors(rhs)).max() <= 1e-13 * np.abs(solved).max()
    bases, matrices = [], []
    for steps in (tracking._band_steps(factors, -1.0),
                  tracking._numpy_steps(lambda v: -factors(v))):
        basis, hessenberg = np.zeros((13, n)), np.zeros((13, 12))
        basis[0] = rhs / np.linalg.norm(rhs)
        assert steps(basis, hessenberg, 0, 5) == 5
        assert steps(basis, hessenberg, 5, 12) == 12
        bases.append(basis)
        matrices.append(hessenberg)
    assert np.abs(bases[0] - bases[1]).max() <= 1e-11
    assert np.abs(matrices[0] - matrices[1]).max() <= 1e-11 * np.abs(matrices[1]).max()
    basis, hessenberg = bases[0], matrices[0]
    assert np.abs(basis @ basis.T - np.eye(13)).max() <= 1e-13
    applied = -la.solve(dense, basis[:12].T)
    assert np.abs(applied - basis.T @ hessenberg).max() <= 1e-12 * np.abs(applied).max()


def test_a_warm_start_that_does_not_converge_leaves_the_verdict_to_arpack(monkeypatch):
    """A Krylov space too small to converge (``WARM_DIMENSION`` 7): every verdict after the
    first is ARPACK's, bit for bit those of each K alone, and the start is made again."""
    monkeypatch.setattr(tracking, "WARM_DIMENSION", 7)
    scene = rodsim.load_scene("table3-catheter1")
    values = np.linspace(0.0, 1.0, 6)
    key = "tendons.tendon.tendon_actuation.force"
    warm, _ = _tracked(scene, key, values, cold=False)
    cold, _ = _tracked(scene, key, values, cold=True)
    assert [s.stability for s in warm] == [s.stability for s in cold]


def test_a_track_through_buckling_gives_the_verdicts_of_each_stiffness_alone(monkeypatch):
    """``track`` takes the same path: table3-catheter1 pushed along its axis past buckling
    (a double real eigenvalue of the non-symmetric K crossing zero), 0 → −1.5 N in 30
    steps: the same stable flags, unstable steps and their eigenvalues (1e-9) as with
    every verdict of each K alone, and its states bit for bit."""
    import rodsim.app.inverse.track as track_module

    scene = rodsim.load_scene("table3-catheter1", [
        "tendons.tendon.tendon_actuation.force=0",
        'rods.catheter.terms=["stretch", "bend_twist", "centerline", "tip_load"]',
        "rods.catheter.tip_load.force=[0, 0, 0]"])
    ramps = {"rods.catheter.tip_load.force[0]": np.linspace(0.0, -1.5, 31)}
    warm = rodsim.track(scene, ramps, allow_unstable=True, estimates=False)
    monkeypatch.setattr(track_module, "NearestModes", _Cold)
    cold = rodsim.track(scene, ramps, allow_unstable=True, estimates=False)
    assert warm.success and cold.success
    assert warm.stable == cold.stable and warm.unstable_steps == cold.unstable_steps
    assert warm.unstable_steps and warm.stable[:5] == [True] * 5
    assert np.allclose(warm.min_eigenvalues, cold.min_eigenvalues, rtol=1e-9, atol=0.0,
                       equal_nan=True)
    assert all(np.array_equal(a, b) for a, b in zip(warm.states, cold.states, strict=True))


def test_rodsim_compile_compiles_the_signature_a_tracker_uses():
    """``rodsim compile``'s call of the compiled Arnoldi steps (no solve calls them) has the
    argument types a Tracker's verdict gives them: after both, one signature."""
    from rodsim.app.precompile import _compile_verdict_steps
    from rodsim.core.kernels._arnoldi import arnoldi_steps

    key = "tendons.tendon.tendon_actuation.force"
    _tracked(rodsim.load_scene("table3-catheter1"), key, np.linspace(0.0, 0.04, 4), cold=False)
    _compile_verdict_steps()
    assert len(arnoldi_steps.signatures) == 1

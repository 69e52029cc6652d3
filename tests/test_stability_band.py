"""The stability verdict's band factorisations (rodsim/core/stability_band.py) against dense
linear algebra, and the verdict of a track on a non-symmetric stiffness where a double
eigenvalue crosses zero (issue 24: the verdict a track step gets must stay the full one)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from band_storage import band_lu

import rodsim
from rodsim.app.inverse.sensitivity import registered_model
from rodsim.app.inverse.track import track
from rodsim.core.model import Model
from rodsim.core.stability import assess, stiffness_stability
from rodsim.core.stability_band import BandStiffness


def _banded(rng: np.random.Generator, n: int, lower: int, upper: int,
            symmetric: bool) -> np.ndarray:
    a = np.zeros((n, n))
    for i in range(n):
        for j in range(max(0, i - lower), min(n, i + upper + 1)):
            a[i, j] = rng.normal()
    a += np.diag(rng.normal(size=n) * rng.choice([0.3, 4.0]))
    return 0.5 * (a + a.T) if symmetric else a


def _csc_entries(k: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows, columns and data of J = −K in CSC order (every entry of the band stored)."""
    rows, cols = np.nonzero(k != 0.0)
    order = np.lexsort((rows, cols))
    rows, cols = rows[order], cols[order]
    return rows, cols, -k[rows, cols]


@pytest.mark.parametrize("seed", range(40))
def test_band_factorisations_match_dense_linear_algebra(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(4, 40))
    lower, upper = int(rng.integers(0, 4)), int(rng.integers(0, 4))
    k = _banded(rng, n, lower, upper, symmetric=seed % 2 == 0)
    rows, cols, data = _csc_entries(k)
    band = BandStiffness(rows, cols, n, int(np.max(rows - cols, initial=0)),
                         int(np.max(cols - rows, initial=0)))
    s = 0.5 * (k + k.T)
    d = np.diag(s)
    positive = bool(np.all(d > 0)) and np.linalg.eigvalsh(s / np.sqrt(np.outer(d, d)))[0] > 0
    assert band.certified(data) == positive
    asymmetry = np.max(np.abs(k - k.T)) / np.max(np.abs(k))
    assert band.asymmetry(data) == pytest.approx(asymmetry, abs=1e-15)
    inverse = band.inverse(data)
    v = rng.normal(size=n)
    assert np.allclose(inverse(v), np.linalg.solve(k, v), rtol=1e-8, atol=1e-10)


def _both_paths(rows, cols, n, lower, upper) -> tuple[BandStiffness, BandStiffness]:
    """The numpy verdict and the compiled one (forced: it runs from COMPILED_SIZE on)."""
    made = []
    for compiled in (False, True):
        band = BandStiffness(rows, cols, n, lower, upper)
        band.compiled = compiled
        made.append(band)
    return made[0], made[1]


@pytest.mark.parametrize("seed", range(20))
def test_the_compiled_verdict_band_is_the_numpy_one(seed):
    """The compiled pass (rodsim/core/kernels/_band.py) writes the same scaled band as the
    numpy offsets, bit for bit, and so gives the same verdict (certified or not, random band
    matrices, symmetric and not, some with a non-positive diagonal)."""
    rng = np.random.default_rng(100 + seed)
    n = int(rng.integers(4, 40))
    lower, upper = int(rng.integers(0, 4)), int(rng.integers(0, 4))
    k = _banded(rng, n, lower, upper, symmetric=seed % 2 == 0)
    k += [0.0, 3.0, 8.0, 30.0][seed % 4] * np.eye(n)  # some certified, some not
    rows, cols, data = _csc_entries(k)
    numpy_band, compiled = _both_paths(rows, cols, n, int(np.max(rows - cols, initial=0)),
                                       int(np.max(cols - rows, initial=0)))
    expected = numpy_band._scaled_band(data)
    got = compiled._scaled_band(data)
    assert (got is None) == (expected is None)
    if expected is not None:
        assert got.flags.f_contiguous
        assert np.array_equal(got, expected)
    assert compiled.certified(data) == numpy_band.certified(data)


def test_the_compiled_verdict_on_a_rod_and_on_non_finite_data():
    scene = rodsim.load_scene("table1-50g")
    result = rodsim.solve(scene, "static")
    model = Model(scene)
    data = model.jacobian_data(result.state)
    numpy_band, compiled = _both_paths(model.pattern_rows, model.pattern_cols, model.n,
                                       model.band.lower, model.band.upper)
    assert np.array_equal(compiled._scaled_band(data), numpy_band._scaled_band(data))
    assert compiled.certified(data) and numpy_band.certified(data)
    data[7] = np.nan
    assert compiled._scaled_band(data) is None and not compiled.certified(data)


def test_a_non_finite_or_singular_stiffness_is_not_certified():
    k = np.diag([1.0, 2.0, 0.0])
    rows, cols, data = _csc_entries(k + np.diag([0.0, 0.0, 1e-300]))
    band = BandStiffness(rows, cols, 3, 0, 0)
    assert not band.certified(np.array([-1.0, -2.0, np.nan]))
    assert band.inverse(np.array([-1.0, -2.0, 0.0])) is None


def test_assess_agrees_with_the_sparse_verdict_on_the_paper_coupling():
    """table3-catheter1 (non-symmetric K, indefinite symmetric part): the band path's
    smallest real part is the sparse path's (SuperLU shift-invert), and both call it
    stable."""
    scene = rodsim.load_scene("table3-catheter1")
    result = rodsim.solve(scene, "static")
    model = registered_model(Model(scene), result.state)
    band = assess(model, result.state)
    sparse = stiffness_stability(-model.jacobian(result.state),
                                 max(model.band.lower, model.band.upper))
    assert band.stable and sparse.stable
    assert band.min_eigenvalue == pytest.approx(sparse.min_eigenvalue, rel=1e-8)


def test_a_track_flags_a_double_eigenvalue_crossing_zero_on_a_non_symmetric_stiffness():
    """table3-catheter1 with the tendon slack and the catheter pushed along its axis: the
    straight catheter buckles in two planes at once, a double real eigenvalue of the
    non-symmetric K crossing zero — which the sign of det K does not see (it stayed +1 over
    this whole track: the screen measured and rejected, rodsim/core/stability_band.py).
    Every step's flag must match the dense eigenvalues of K at that step."""
    scene = rodsim.load_scene("table3-catheter1", [
        "tendons.tendon.tendon_actuation.force=0",
        'rods.catheter.terms=["stretch", "bend_twist", "centerline", "tip_load"]',
        "rods.catheter.tip_load.force=[0, 0, 0]"])
    forces = np.linspace(0.0, -1.5, 8)
    path = track(scene, {"rods.catheter.tip_load.force[0]": forces}, allow_unstable=True)
    assert path.success and path.steps == len(forces)
    smallest = []
    for step, state in enumerate(path.states):
        model = Model(rodsim.load_scene("table3-catheter1", [
            "tendons.tendon.tendon_actuation.force=0",
            'rods.catheter.terms=["stretch", "bend_twist", "centerline", "tip_load"]',
            f"rods.catheter.tip_load.force=[{float(forces[step])!r}, 0, 0]"]))
        x = model.state_of(state)
        model = registered_model(model, x)
        eigenvalues = np.linalg.eigvals(-model.jacobian(x).toarray())
        smallest.append(float(np.min(eigenvalues.real)))
        negative = np.sort(eigenvalues.real[eigenvalues.real < 0])
        if negative.size:  # the crossing is a double one: det K keeps its sign
            assert negative.size % 2 == 0
    assert path.stable == [value > 0 for value in smallest]
    assert 0 < len(path.unstable_steps) < len(forces) - 1
    flagged = np.array(path.min_eigenvalues)[path.unstable_steps]
    assert np.allclose(flagged, np.array(smallest)[path.unstable_steps], rtol=1e-6)


def test_a_sparse_stiffness_keeps_its_verdict():
    """stiffness_stability on a plain sparse matrix (no model) is the same as before."""
    k = sp.diags([[2.0, 2.0, 2.0], [-1.0, -1.0], [-1.0, -1.0]], [0, 1, -1])
    assert stiffness_stability(k).stable
    assert not stiffness_stability(-k).stable


@pytest.mark.parametrize("name", ["table3-catheter1", "tdcr-two-segment"])
def test_the_verdict_reuses_the_verification_of_the_same_state_only(name):
    """A run's verification factors J at the state it returns; the verdict of that state
    takes it (the same verdict and smallest real part as computed afresh) and no other
    state's or model's."""
    from rodsim.solvers import integrator_named

    scene = rodsim.load_scene(name)
    kind = integrator_named("static")
    integrator = kind.for_scene(scene)
    result, state = integrator.run(integrator.init(Model(scene)))
    assert result.success
    factored = state.factorisation_at(state.model, result.state)
    assert factored is not None
    data, solve = factored
    assert np.array_equal(data, state.model.jacobian_data(result.state))
    reused, fresh = assess(state.model, result.state, factored), assess(state.model,
                                                                        result.state)
    assert reused.stable == fresh.stable
    assert reused.min_eigenvalue == pytest.approx(fresh.min_eigenvalue, rel=1e-9,
                                                  nan_ok=True)
    moved = result.state + 1e-9
    assert state.factorisation_at(state.model, moved) is None
    assert state.factorisation_at(Model(scene), result.state) is None


def test_the_verdict_of_a_non_symmetric_stiffness_is_reproducible():
    """ARPACK starts from a fixed vector: the same state's verdict twice gives the same
    smallest real part bit for bit (its random start made it differ by ~1e-11 relative),
    and it is the smallest real part of the six eigenvalues nearest zero by dense ones
    (those of K⁻¹: the dense eigenvalues of K itself carry an error of order ε‖K‖)."""
    scene = rodsim.load_scene("table3-catheter1")
    result = rodsim.solve(scene, "static")
    model = registered_model(Model(scene), result.state)
    first, second = assess(model, result.state), assess(model, result.state)
    assert not np.isnan(first.min_eigenvalue)  # the ARPACK path, not the certificate
    assert first.min_eigenvalue == second.min_eigenvalue
    inverse = np.linalg.inv(-model.jacobian(result.state).toarray())
    values = 1.0 / np.linalg.eigvals(inverse)
    nearest = values[np.argsort(np.abs(values))[:6]]
    assert first.min_eigenvalue == pytest.approx(float(np.min(nearest.real)), rel=1e-7)


def _tracks_both_orders(monkeypatch, scene, ramps, **options):
    """The track of ``ramps`` as it runs (a step's verdict tries the eigenvalues nearest
    zero first after a step that was not certified) and with every verdict in the default
    order (the certificate first), with the certificates each made."""
    import rodsim.core.stability as stability

    calls = []
    certified = BandStiffness.certified

    def counted(self, jacobian, shift=0.0):
        if not shift:  # the certificate (a shifted one screens for a hidden left eigenvalue)
            calls.append(1)
        return certified(self, jacobian, shift)

    monkeypatch.setattr(BandStiffness, "certified", counted)
    fast = track(scene, ramps, **options)
    fast_calls = len(calls)
    original = stability.assess
    monkeypatch.setattr(stability, "assess",
                        lambda model, x, factored=None, certify_first=True, modes=None:
                        original(model, x, factored, True, modes))
    calls.clear()
    default = track(scene, ramps, **options)
    return fast, fast_calls, default, len(calls)


def test_a_track_that_is_never_certified_skips_the_certificate_with_the_same_verdicts(
        monkeypatch):
    """table3-catheter1's tendon ramp (never certified: the paper coupling's symmetric
    part is indefinite) and that catheter pushed past buckling (stable, then unstable
    steps): the track's verdicts, smallest eigenvalues and states are those of the default
    order, bit for bit, with the certificate tried at no step of the first after step 1."""
    scene = rodsim.load_scene("table3-catheter1")
    ramps = {"tendons.tendon.tendon_actuation.force": np.linspace(0.0, 4.0, 41)}
    fast, fast_calls, default, default_calls = _tracks_both_orders(monkeypatch, scene, ramps)
    assert fast.success and fast.steps == 41 and all(fast.stable)
    assert default_calls >= 40 and fast_calls <= 2
    assert fast.stable == default.stable
    assert np.array_equal(np.array(fast.states), np.array(default.states))
    monkeypatch.undo()
    pushed = rodsim.load_scene("table3-catheter1", [
        "tendons.tendon.tendon_actuation.force=0",
        'rods.catheter.terms=["stretch", "bend_twist", "centerline", "tip_load"]',
        "rods.catheter.tip_load.force=[0, 0, 0]"])
    ramps = {"rods.catheter.tip_load.force[0]": np.linspace(0.0, -1.5, 8)}
    fast, _, default, _ = _tracks_both_orders(monkeypatch, pushed, ramps,
                                              allow_unstable=True)
    assert fast.unstable_steps and fast.stable == default.stable
    assert np.array_equal(np.array(fast.min_eigenvalues), np.array(default.min_eigenvalues),
                          equal_nan=True)
    assert np.array_equal(np.array(fast.states), np.array(default.states))


def _verdicts_of_both_factorisations(model: Model, x: np.ndarray) -> tuple[bool, bool, float]:
    """(−J's band Cholesky from the Newton solver exists, the verdict's own certificate of
    the scaled symmetric part succeeds, K's smallest eigenvalue relative to its largest)."""
    from rodsim.solvers.linear import BandCholeskySolve
    from rodsim.solvers.run_state import linear_solver_of

    data = model.jacobian_data(x)
    band = model.band
    own = BandStiffness(model.pattern_rows, model.pattern_cols, model.n, band.lower,
                        band.upper).certified(data)
    reused = isinstance(linear_solver_of(model).factorized(data), BandCholeskySolve)
    stiffness = -model.pattern_matrix(data).toarray()
    eigenvalues = np.linalg.eigvalsh(0.5 * (stiffness + stiffness.T))
    return reused, own, float(eigenvalues[0] / np.max(np.abs(eigenvalues)))


def test_the_newton_cholesky_proves_stability_exactly_when_the_certificate_does():
    """A run's verification factors −J by band Cholesky for a conservative model; the
    verdict takes that factorisation's existence as its certificate instead of factoring
    the scaled symmetric part again (rodsim/solvers/linear.py, BandCholeskySolve). The two
    must agree with each other and with K's dense eigenvalues: on a column near and past
    its Euler load (the straight equilibrium, stable below, unstable above) and on robots
    of the seeded user family at their equilibria and at random states around them."""
    from tests.test_stability import euler_load
    from tests.test_user_robot import family

    cases = []
    base = rodsim.load_scene("table1-50g", ["nodes=20", "mass=0"])
    for fraction in (0.9, 0.99, 0.999, 1.001, 1.01, 1.1):
        force = fraction * euler_load(base)
        scene = base.with_overrides([f"tip_load.force=[{-force!r}, 0, 0]"])
        model = Model(scene)
        result = rodsim.solve(scene, "static", model=model)
        assert result.success, result.message
        cases.append((model, result.state, fraction < 1.0))
    rng = np.random.default_rng(20261126)
    for robot, _ in family()[:8]:
        model = Model(rodsim.load_scene(robot))
        if not model.conservative:
            continue
        result = rodsim.solve(robot, "static", model=model)
        assert result.success, result.message
        cases.append((model, result.state, True))
        for size in (1e-3, 3e-2, 3e-1):
            cases.append((model, result.state + size * rng.standard_normal(model.n), None))
    outcomes = set()
    for model, x, expected in cases:
        reused, own, smallest = _verdicts_of_both_factorisations(model, x)
        assert reused == own == (smallest > 0.0), (model.scene.name, smallest)
        if expected is not None:
            assert reused == expected
        outcomes.add(reused)
    assert outcomes == {True, False}  # both verdicts exercised


#: A robot of an exploratory seeded family (sections, moved supports, loads anywhere, string
#: tendons): a slender soft rod clamped at a mid-span node moved by ~1 cm, with a small
#: world-frame moment (non-conservative: K is non-symmetric by 6.5e-6 in norm).
HIDDEN_INSTABILITY = {
    "name": "x-22", "rods": {"catheter": {
        "length": 0.3537989455516114, "radius": 0.0009608756272768658,
        "youngs_modulus": 8620958.773082646, "density": 2041.6727705787778, "nodes": 31,
        "poisson_ratio": 0.43649882965394643,
        "base": {"insertion": 0.04133163824601087, "rotation": -2.1862434385819833},
        "point_loads": {"loads": [{
            "s": 0.2482276366404817,
            "force": [-2.936030590722053e-05, 7.5460727457907546e-06, -6.277471422085773e-06],
            "moment": [4.2632871913010255e-06, -1.4477374505801013e-06,
                       -3.892958627305463e-06], "frame": "world"}]},
        "distributed_load": {"force_per_length": [
            -4.168094191743899e-05, 0.0001785453930839591, 3.4170342689734296e-05]},
        "supports": {"mid": {"s": 0.08255308729537598, "displacement": [
            -0.005792582686392314, 0.00717538367170596, -0.0035251533947665377],
            "orientation": True}},
        "terms": ["stretch", "bend_twist", "centerline", "point_loads", "distributed_load"]}},
    "tendons": {
        "t0": {"catheter": "catheter", "coupling": "string", "offset": 0.0003869999881766995,
               "direction": [-0.9212706753527229, 0.38892202654920144],
               "tendon_string": {"tension": 0.018787995463272804, "routing": "helix",
                                 "helix_radius": 0.0003869999881766995,
                                 "helix_pitch": 0.39248576040854805,
                                 "helix_phase": 2.7421314444662657}},
        "t1": {"catheter": "catheter", "coupling": "string", "offset": 0.0005041045017365489,
               "direction": [0.883642275947422, -0.4681627154723668],
               "tendon_string": {"tension": 0.04861420979788958}}},
    "solver": {"max_wall_time": 30.0}}


def test_an_eigenvalue_left_of_zero_behind_many_small_ones_is_found():
    """The verdict of a non-symmetric K above 200 coordinates came from its six eigenvalues
    nearest zero. On HIDDEN_INSTABILITY static's equilibrium has a double eigenvalue −0.067
    behind 87 smaller positive ones (soft modes), and was reported stable. Now a K whose
    skew part is small enough for its symmetric part to prove a left eigenvalue
    (rodsim/core/stability.py, _proven_left_eigenvalue) is unstable, with that eigenvalue
    within ‖A‖₂ of one of K's (dense eigenvalues here, numpy)."""
    model = Model(rodsim.load_scene(HIDDEN_INSTABILITY))
    result = rodsim.solve(HIDDEN_INSTABILITY, "static", model=model)
    assert result.success, result.message
    stiffness = -model.pattern_matrix(model.jacobian_data(result.state)).toarray()
    eigenvalues = np.linalg.eigvals(stiffness)
    assert eigenvalues.real.min() < -0.05
    assert np.sum(np.abs(eigenvalues) < 0.05) > 6  # the nearest six are all right of zero
    assert not result.stability.stable
    skew = np.linalg.norm(0.5 * (stiffness - stiffness.T), 2)
    assert np.min(np.abs(eigenvalues - result.stability.min_eigenvalue)) <= skew


def _near_symmetric(rng: np.random.Generator, n: int, skew: float) -> np.ndarray:
    """A banded K = S + A: S with the eigenvalue −1 behind 30 in (1e-4, 1e-2) and the rest
    in (1, 10) (a random banded orthogonal similarity), A skew and banded of norm ~skew."""
    values = np.concatenate([[-1.0], rng.uniform(1e-4, 1e-2, 30), rng.uniform(1.0, 10.0,
                                                                               n - 31)])
    symmetric = np.diag(values)
    for start in range(0, n - 1):  # Givens rotations of neighbours keep a narrow band
        angle = rng.uniform(0, 2 * np.pi)
        c, s = np.cos(angle), np.sin(angle)
        rotation = np.array([[c, -s], [s, c]])
        block = slice(start, start + 2)
        symmetric[block, :] = rotation @ symmetric[block, :]
        symmetric[:, block] = symmetric[:, block] @ rotation.T
    symmetric = 0.5 * (symmetric + symmetric.T)
    upper = np.triu(rng.standard_normal((n, n)), 1) * (np.abs(np.subtract.outer(
        np.arange(n), np.arange(n))) <= 3)
    antisymmetric = upper - upper.T
    antisymmetric *= skew / np.linalg.norm(antisymmetric, 2)
    return symmetric + antisymmetric


@pytest.mark.parametrize(("skew", "provable"), [(1e-6, True), (1e-3, True), (30.0, False)])
def test_the_symmetric_part_proves_a_hidden_left_eigenvalue_only_when_it_can(skew, provable):
    """stiffness_stability on a banded K of 300 coordinates whose one left eigenvalue hides
    behind 30 small positive ones: with a small skew part the symmetric part proves it
    (unstable, the reported value within ‖A‖₂ of K's dense eigenvalue); with a skew part
    large enough to move eigenvalues across zero (ρ = 30) it proves nothing and the verdict
    stays that of the nearest eigenvalues, whatever K's true spectrum — never a made-up
    instability."""
    rng = np.random.default_rng(11)
    k = _near_symmetric(rng, 300, skew)
    eigenvalues = np.linalg.eigvals(k)
    verdict = stiffness_stability(sp.csc_matrix(k))
    if provable:
        assert eigenvalues.real.min() < 0.0
        assert not verdict.stable
        assert np.min(np.abs(eigenvalues - verdict.min_eigenvalue)) <= 1.01 * skew
    else:
        from rodsim.core.stability import _proven_left_eigenvalue
        norm = float(np.abs(0.5 * (k - k.T)).sum(axis=0).max())
        assert _proven_left_eigenvalue(sp.csc_matrix(k), norm) is None


@pytest.mark.parametrize("seed", range(12))
def test_the_band_lu_gives_the_sign_of_the_determinant(seed):
    """BandLU.determinant_sign (the U diagonal's signs and the row swaps of dgbtrf) against
    numpy's slogdet of the same banded matrix, with pivoting and both signs."""
    rng = np.random.default_rng(seed)
    n, lower, upper = int(rng.integers(5, 40)), int(rng.integers(1, 4)), int(rng.integers(1, 4))
    dense = _banded(rng, n, lower, upper, symmetric=False)
    factored = band_lu(dense, lower, upper)
    assert factored.determinant_sign == np.linalg.slogdet(dense)[0]
    rhs = rng.standard_normal(n)
    assert np.allclose(dense @ factored(rhs), rhs)


#: A catheter with two rod tendons (momentum-conserving coupling, pulled at their distal
#: ends by F_A: a follower load, so K is non-symmetric) of an exploratory seeded family.
THREE_NEGATIVE = {
    "name": "rod-robot-8", "rods": {
        "catheter": {"length": 0.3896911456523936, "radius": 0.005719553832135435,
                     "youngs_modulus": 4089311.92735279, "density": 1200.0, "nodes": 24,
                     "terms": ["stretch", "bend_twist", "centerline"],
                     "base": {"insertion": 0.020919700335167518,
                              "rotation": -2.4785033991134795}},
        "tendon0": {"length": 0.3896911456523936, "radius": 0.00014825004198148518,
                    "youngs_modulus": 2e11, "density": 7800.0, "nodes": 20},
        "tendon1": {"length": 0.3896911456523936, "radius": 0.00024210111712328367,
                    "youngs_modulus": 2e11, "density": 7800.0, "nodes": 12}},
    "tendons": {
        "tendon0": {"catheter": "catheter", "offset": 0.004072227844598891,
                    "direction": [-0.3517375660309667, -0.9360986511274393],
                    "coupling": "conserving",
                    "tendon_actuation": {"force": 0.6811114243778422}},
        "tendon1": {"catheter": "catheter", "offset": 0.003426526657033803,
                    "direction": [-0.7729384499246924, 0.6344810104550125],
                    "coupling": "conserving",
                    "tendon_actuation": {"force": 2.9184887557330983}}},
    "solver": {"max_wall_time": 60.0}}


def test_an_odd_number_of_negative_real_eigenvalues_is_found_by_the_determinant():
    """static's equilibrium of THREE_NEGATIVE has three negative real eigenvalues (−0.078,
    −0.066, −0.016) behind dozens of smaller positive ones and a skew part far too large for
    the symmetric part to prove anything: the six nearest zero said stable. det K < 0, read
    off the band LU the verdict makes anyway, proves an odd number of them: unstable (the
    eigenvalue not located: NaN). Checked against the eigenvalues of K⁻¹ (dense, numpy),
    accurate for the small ones where those of K are not."""
    from rodsim.solvers import integrator_named

    scene = rodsim.load_scene(THREE_NEGATIVE)
    integrator = integrator_named("static").for_scene(scene)
    result, state = integrator.run(integrator.init(Model(scene)))
    assert result.success, result.message
    model = state.model
    stiffness = -model.pattern_matrix(model.jacobian_data(result.state)).toarray()
    eigenvalues = 1.0 / np.linalg.eigvals(np.linalg.inv(stiffness))
    real = eigenvalues[np.abs(eigenvalues.imag) <= 1e-6 * np.abs(eigenvalues)].real
    assert np.count_nonzero(real < 0.0) % 2 == 1
    assert np.count_nonzero(np.abs(eigenvalues) < np.abs(real[real < 0.0]).min()) > 6
    assert not result.stability.stable and np.isnan(result.stability.min_eigenvalue)
    assert not assess(model, result.state).stable  # the same without the run's factors


def test_an_unlocated_negative_eigenvalue_is_said_so_not_printed_as_nan():
    """A verdict proven unstable by det K < 0 has no eigenvalue value (NaN): the messages of
    run, track and reach say it was not located instead of printing 'nan'."""
    from rodsim.app.cli.common import stability_text
    from rodsim.core.stability import Stability, eigenvalue_text

    assert "smallest eigenvalue not located: det K < 0" in stability_text(Stability(False))
    assert "nan" not in stability_text(Stability(False))
    assert eigenvalue_text(-0.0825) == "smallest eigenvalue -0.0825"
    assert "smallest eigenvalue -0.0825" in stability_text(Stability(False, -0.0825))

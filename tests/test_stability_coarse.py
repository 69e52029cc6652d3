"""The coarse first pass of the non-symmetric verdict (rodsim/core/stability.py,
``_smallest_real_part``): ARPACK to ``COARSE_TOLERANCE`` first, its "stable" kept only by a
wide margin; an unstable or near-neutral stiffness hands over to the full pass, whose
verdict is then the one computed without the coarse pass, bit for bit. References: the
dense eigenvalues of K (or of K⁻¹ for those nearest zero)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import rodsim
import rodsim.core.stability as stability
from rodsim.app.inverse.sensitivity import registered_model
from rodsim.app.inverse.track import track
from rodsim.core.model import Model
from rodsim.core.stability import assess

PUSHED = ["tendons.tendon.tendon_actuation.force=0",
          'rods.catheter.terms=["stretch", "bend_twist", "centerline", "tip_load"]']


@pytest.fixture
def tolerances(monkeypatch) -> list[float]:
    """The tolerance of every ARPACK call the verdicts make."""
    asked: list[float] = []
    eigs = spla.eigs

    def counted(*args, **kwargs):
        asked.append(kwargs["tol"])
        return eigs(*args, **kwargs)

    monkeypatch.setattr(stability.spla, "eigs", counted)
    return asked


def _nearest_real_part(stiffness: np.ndarray) -> float:
    """The smallest real part of the six eigenvalues of K nearest zero (those of K⁻¹,
    dense)."""
    values = 1.0 / np.linalg.eigvals(np.linalg.inv(stiffness))
    return float(np.min(values[np.argsort(np.abs(values))[:6]].real))


def test_a_stable_catheter_is_judged_by_the_coarse_pass_alone(tolerances, monkeypatch):
    """table3-catheter1 at its tendon force (a non-symmetric K with an indefinite symmetric
    part): one ARPACK call, the coarse one, and the smallest real part of the full pass to
    within 1e-12 (relative) and of the dense eigenvalues nearest zero to 1e-7."""
    scene = rodsim.load_scene("table3-catheter1")
    result = rodsim.solve(scene, "static")
    model = registered_model(Model(scene), result.state)
    tolerances.clear()
    coarse = assess(model, result.state)
    assert tolerances == [stability.COARSE_TOLERANCE]
    monkeypatch.setattr(stability, "COARSE_MARGIN", np.inf)  # never kept: the full pass
    tolerances.clear()
    full = assess(model, result.state)
    assert tolerances == [stability.COARSE_TOLERANCE, stability.ARPACK_TOLERANCE]
    assert coarse.stable and full.stable
    assert coarse.min_eigenvalue == pytest.approx(full.min_eigenvalue, rel=1e-12, abs=0.0)
    dense = _nearest_real_part(-model.jacobian(result.state).toarray())
    assert coarse.min_eigenvalue == pytest.approx(dense, rel=1e-7)


def test_a_buckled_catheter_hands_over_to_the_full_verdict(tolerances, monkeypatch):
    """The catheter pushed along its axis past its buckling load (a double real eigenvalue
    of the non-symmetric K left of zero, det K > 0): the coarse pass sees an eigenvalue left
    of zero and the full pass judges, the verdict that of the full pass alone bit for bit,
    unstable as the dense eigenvalues of K say, its eigenvalue theirs to 1e-6."""
    forces = np.linspace(0.0, -1.5, 8)
    key = "rods.catheter.tip_load.force[0]"
    scene = rodsim.load_scene("table3-catheter1",
                              [*PUSHED, "rods.catheter.tip_load.force=[0, 0, 0]"])
    path = track(scene, {key: forces}, allow_unstable=True)
    assert path.success and path.unstable_steps
    last = path.unstable_steps[-1]
    model = Model(rodsim.load_scene("table3-catheter1", [
        *PUSHED, f"rods.catheter.tip_load.force=[{float(forces[last])!r}, 0, 0]"]))
    x = model.state_of(path.states[last])
    model = registered_model(model, x)
    tolerances.clear()
    verdict = assess(model, x)
    assert tolerances == [stability.COARSE_TOLERANCE, stability.ARPACK_TOLERANCE]
    monkeypatch.setattr(stability, "COARSE_MARGIN", np.inf)
    assert assess(model, x) == verdict
    smallest = float(np.min(np.linalg.eigvals(-model.jacobian(x).toarray()).real))
    assert smallest < 0.0 and verdict.unstable
    assert verdict.min_eigenvalue == pytest.approx(smallest, rel=1e-6)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("offset", [1e-7, -1e-7])
def test_a_near_neutral_stiffness_hands_over_to_the_full_pass(tolerances, seed, offset):
    """A non-symmetric banded K (240 coordinates: a diagonal with one isolated small entry,
    plus a random band) shifted so that its isolated real eigenvalue, the nearest zero,
    lies ±1e-7 of the nearest eigenvalues' size from zero, within the coarse margin: the
    full pass judges (two ARPACK calls), the same number as without the coarse pass, of
    the right sign, and the dense reference's to 1e-6 of that size."""
    rng = np.random.default_rng(seed)
    n, width = 240, 6
    dense = np.diag(2.0 + 0.2 * np.arange(n))
    dense[0, 0] = 0.5
    for k in range(-width, width + 1):
        dense += np.diag(0.02 * rng.normal(size=n - abs(k)), k)
    values = np.linalg.eigvals(dense)
    isolated = values[np.argmin(np.abs(values - 0.5))]
    assert isolated.imag == 0.0
    size = float(np.sort(np.abs(values - isolated.real))[5])
    dense -= (isolated.real - offset * size) * np.eye(n)
    stiffness = sp.csc_matrix(dense)
    tolerances.clear()
    coarse = stability._smallest_real_part(stiffness, coarse=True)
    assert tolerances == [stability.COARSE_TOLERANCE, stability.ARPACK_TOLERANCE]
    assert coarse == stability._smallest_real_part(stiffness)
    reference = _nearest_real_part(dense)
    assert np.sign(reference) == np.sign(offset)
    assert abs(coarse - reference) <= 1e-6 * size


def test_the_verdict_flips_where_the_dense_eigenvalues_cross_zero(monkeypatch):
    """The straight catheter pushed 0 → −1.5 N (8 loads, static from rest: the straight
    column, stable and then past its buckling load), each load's
    verdict with the coarse pass is that without it (the flag, and the smallest real part
    bit for bit once unstable, to 1e-12 while stable), and its flag is the sign of the
    smallest real part of all the dense eigenvalues of K; the ramp holds both."""
    forces = np.linspace(0.0, -1.5, 8)
    flags, references = [], []
    for force in forces:
        model = Model(rodsim.load_scene("table3-catheter1", [
            *PUSHED, f"rods.catheter.tip_load.force=[{float(force)!r}, 0, 0]"]))
        x = rodsim.solve(model.scene, "static").state  # the straight column
        model = registered_model(model, x)
        monkeypatch.setattr(stability, "COARSE_MARGIN", 1e-3)
        coarse = assess(model, x)
        monkeypatch.setattr(stability, "COARSE_MARGIN", np.inf)
        full = assess(model, x)
        assert coarse.stable == full.stable
        if full.stable:
            assert coarse.min_eigenvalue == pytest.approx(full.min_eigenvalue, rel=1e-12)
        else:
            assert coarse == full
        smallest = float(np.min(np.linalg.eigvals(-model.jacobian(x).toarray()).real))
        flags.append(coarse.stable)
        references.append(smallest > 0.0)
    assert flags == references
    assert flags[0] and not flags[-1]

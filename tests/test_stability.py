"""The stability verdict of an equilibrium (issue 15, item 12; rodsim/core/stability.py).

A straight rod compressed beyond its Euler load is an equilibrium every integrator may
return from the straight rest state; its stiffness K = −∂F/∂x is indefinite and the verdict
must say so. The reference values here are independent of rodsim/core/stability.py: dense
eigenvalues of K computed with NumPy, and Euler's critical load π² E I / (4 L²) of a
clamped–free column.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse as sp

import rodsim
from rodsim.core.model import Model
from rodsim.core.stability import DENSE_LIMIT, stiffness_stability
from rodsim.io.archive import read_dataset

COMPRESSED = ["mass=0", "tip_load.force=[-5, 0, 0]"]  # about 5× the Euler load


def euler_load(scene) -> float:
    """Critical load [N] of the scene's first rod as a clamped–free column."""
    rod = next(iter(scene.data["rods"].values()))
    ei = rod["youngs_modulus"] * math.pi * rod["radius"] ** 4 / 4
    return math.pi**2 * ei / (4 * rod["length"] ** 2)


def dense_stiffness(model: Model, x: np.ndarray) -> np.ndarray:
    return -model.jacobian(x).toarray()


@pytest.mark.parametrize("integrator", ["static", "cvode", "ida", "paper"])
def test_the_default_scene_is_stable_with_every_integrator(integrator):
    """No direction is null at the Table 1 equilibrium (the quaternion norm is held by the
    centerline penalty), so every integrator's equilibrium is reported stable, and K's
    eigenvalues confirm it."""
    scene = rodsim.load_scene("table1-50g")
    model = Model(scene)
    result = rodsim.solve(scene, integrator, model=model)
    assert result.success, result.message
    assert result.stability.stable
    stiffness = dense_stiffness(model, result.state)
    assert np.min(np.linalg.eigvalsh(0.5 * (stiffness + stiffness.T))) > 0.0


@pytest.mark.parametrize("integrator", ["static", "cvode", "ida", "paper"])
def test_a_straight_rod_past_its_euler_load_is_unstable(integrator):
    """Every integrator returns the straight compressed rod (symmetric from rest) and calls
    it success: the verdict is unstable, with K's smallest eigenvalue."""
    scene = rodsim.load_scene("table1-50g", ["nodes=12", *COMPRESSED])
    assert 4.0 < 5.0 / euler_load(scene) < 6.0
    model = Model(scene)
    result = rodsim.solve(scene, integrator, model=model)
    assert result.success, result.message
    assert np.allclose(result.positions()[:, 1:], 0.0, atol=1e-12)  # straight
    assert not result.stability.stable
    smallest = np.min(np.linalg.eigvalsh(dense_stiffness(model, result.state)))
    assert smallest < 0.0
    assert result.stability.min_eigenvalue == pytest.approx(smallest, rel=1e-6)


@pytest.mark.parametrize(("integrator", "lateral"), [("ida", 1e-6), ("static", 1e-2)])
def test_a_buckled_rod_is_stable(integrator, lateral):
    """With a lateral perturbation of the tip force the rod leaves the straight branch and
    buckles (IDA with a tiny one; static, from rest, with a larger one): stable."""
    scene = rodsim.load_scene("table1-50g", ["mass=0", f"tip_load.force=[-5, {lateral}, 0]"])
    result = rodsim.solve(scene, integrator)
    assert result.success, result.message
    assert result.tip()[0] < 0.5 * 0.12  # far from the straight rod's tip at x ≈ L
    assert result.stability.stable


@pytest.mark.parametrize(("fraction", "stable"), [(0.7, True), (1.3, False)])
def test_the_verdict_flips_at_the_euler_load(fraction, stable):
    """Below Euler's load the straight column is stable, above it is not."""
    base = rodsim.load_scene("table1-50g", ["nodes=20", "mass=0"])
    force = fraction * euler_load(base)
    scene = base.with_overrides([f"tip_load.force=[{-force!r}, 0, 0]"])
    result = rodsim.solve(scene, "static")
    assert result.success, result.message
    assert result.stability.stable is stable


def test_a_non_conservative_tendon_scene_is_judged_by_the_eigenvalues_of_k():
    """The paper's tendon coupling makes K non-symmetric, with an indefinite symmetric part
    at an equilibrium where every eigenvalue of K has a positive real part: stable."""
    scene = rodsim.load_scene("table3-catheter1")
    model = Model(scene)
    assert not model.conservative
    result = rodsim.solve(scene, "static", model=model)
    assert result.success, result.message
    # K of the registration the run ended with (settled: the exact rule at the equilibrium).
    final = model.reregistered(result.state, exact=True) or model
    stiffness = dense_stiffness(final, result.state)
    assert np.min(np.linalg.eigvalsh(0.5 * (stiffness + stiffness.T))) < 0.0
    smallest_real = np.min(np.linalg.eigvals(stiffness).real)
    assert smallest_real > 0.0
    assert result.stability.stable
    assert result.stability.min_eigenvalue == pytest.approx(smallest_real, rel=1e-6)


def test_stiffness_stability_on_small_matrices():
    """Definite, indefinite and non-symmetric 2 × 2 cases with known eigenvalues."""
    assert stiffness_stability(sp.csc_matrix(np.diag([2.0, 3.0]))).stable
    verdict = stiffness_stability(sp.csc_matrix(np.array([[1.0, 2.0], [2.0, 1.0]])))
    assert not verdict.stable and verdict.min_eigenvalue == pytest.approx(-1.0)
    # Eigenvalues 1 ± 2i (positive real part), symmetric part diag(1, 1) − fine either way;
    # [[1, 4], [-1, 1]]: eigenvalues 1 ± 2i, symmetric part [[1, 1.5], [1.5, 1]] indefinite.
    rotating = stiffness_stability(sp.csc_matrix(np.array([[1.0, 4.0], [-1.0, 1.0]])))
    assert rotating.stable and rotating.min_eigenvalue == pytest.approx(1.0)


def test_large_systems_use_bisection_and_shift_invert():
    """Above DENSE_LIMIT coordinates: the smallest eigenvalue of a symmetric matrix comes
    from bisection on Cholesky factorisations — checked on a tridiagonal Toeplitz matrix,
    whose eigenvalues are a + 2 b cos(k π / (n + 1)) — and a non-symmetric one's smallest
    real part from the eigenvalues nearest zero — checked on 2 × 2 blocks with eigenvalues
    1 ± 2i, one block replaced by diag(-1, 1)."""
    n = DENSE_LIMIT + 1001
    a, b = 1.0, -0.6
    toeplitz = sp.diags([b * np.ones(n - 1), a * np.ones(n), b * np.ones(n - 1)], [-1, 0, 1])
    verdict = stiffness_stability(toeplitz, 1)
    assert not verdict.stable
    assert verdict.min_eigenvalue == pytest.approx(a + 2 * b * math.cos(math.pi / (n + 1)),
                                                   rel=1e-5)
    blocks = [np.array([[1.0, 4.0], [-1.0, 1.0]])] * (n // 2)
    rotating = stiffness_stability(sp.block_diag(blocks, format="csc"))
    assert rotating.stable and rotating.min_eigenvalue == pytest.approx(1.0)
    blocks[7] = np.diag([-1.0, 1.0])
    diverging = stiffness_stability(sp.block_diag(blocks, format="csc"))
    assert not diverging.stable and diverging.min_eigenvalue == pytest.approx(-1.0)


def test_cli_warns_stores_and_can_require_stability(tmp_path, cli, capsys):
    """`rodsim run` prints a warning for an unstable success, stores the verdict in the
    archive, and `--require-stable` makes it exit 1 (the archive is still written)."""
    unstable = tmp_path / "unstable.nc"
    argv = ["run", "--integrator", "static", "--set", "nodes=12", *sum(
        (["--set", item] for item in COMPRESSED), []), "-o", str(unstable)]
    assert cli(argv) == 0
    out = capsys.readouterr().out
    assert "UNSTABLE equilibrium" in out
    stored = read_dataset(unstable).attrs
    assert stored["stable"] == 0 and stored["stiffness_min_eigenvalue"] < 0.0
    unstable.unlink()
    assert cli([*argv, "--require-stable"]) == 1
    captured = capsys.readouterr()
    assert "unstable" in captured.err and unstable.exists()
    stable = tmp_path / "stable.nc"
    assert cli(["run", "--integrator", "static", "--set", "nodes=12", "-o", str(stable),
                "--require-stable"]) == 0
    assert "stable (" in capsys.readouterr().out
    assert read_dataset(stable).attrs["stable"] == 1


def _sum_band(stiffness: sp.csc_matrix, width: int) -> np.ndarray:
    """The scaled lower band of (K + Kᵀ)/2 built through the sparse sum (the construction
    the verdict used before its direct band; the reference here)."""
    symmetric = (0.5 * (stiffness + stiffness.T)).tocoo()
    scale = 1.0 / np.sqrt(symmetric.diagonal())
    data = symmetric.data * scale[symmetric.row] * scale[symmetric.col]
    ab = np.zeros((width + 1, stiffness.shape[0]))
    lower = symmetric.row >= symmetric.col
    np.add.at(ab, (symmetric.row[lower] - symmetric.col[lower], symmetric.col[lower]),
              data[lower])
    return ab


@pytest.mark.parametrize("scene", ["tdcr-two-segment", "table3-catheter1", "table1-50g"])
def test_the_direct_band_of_the_symmetric_part_equals_the_sparse_sum(scene, monkeypatch):
    """The verdict factors the same band, bit for bit, as the sparse sum gave (K of a
    non-symmetric model included: table3's paper coupling), and so gives the same verdict;
    also on a shifted K that is not positive definite."""
    from rodsim.core import stability

    model = Model(rodsim.load_scene(scene))
    x = model.x0 + 1e-6 * np.random.default_rng(8).normal(size=model.n)
    stiffness = sp.csc_matrix(-model.jacobian(x))  # (all its diagonal positive)
    width = max(model.band.lower, model.band.upper)
    factored = []
    real = stability._cholesky_succeeds
    monkeypatch.setattr(stability, "_cholesky_succeeds",
                        lambda ab: factored.append(ab.copy()) or real(ab))
    verdict = stiffness_stability(stiffness, width)
    assert np.array_equal(factored[0], _sum_band(stiffness, width))
    assert verdict.stable == real(_sum_band(stiffness, width))
    shifted = sp.csc_matrix(stiffness - 0.5 * sp.diags(stiffness.diagonal()) * 3.0)
    factored.clear()
    stability._symmetric_part_positive_definite(shifted.tocoo(), width)
    assert not factored  # a negative diagonal: refused before factoring

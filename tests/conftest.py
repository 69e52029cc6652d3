"""Shared fixtures: scene loading with overrides, random non-trivial states, finite differences.

BLAS/OpenMP threads are pinned to one (rodsim/app/threads.py) before numpy is imported, and
figures use matplotlib's file backend, as the command line does.
"""

from __future__ import annotations

import os

from rodsim.app.threads import pin_threads

pin_threads()
os.environ.setdefault("MPLBACKEND", "Agg")

from collections.abc import Callable  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import rodsim  # noqa: E402
from rodsim.core.model import Model  # noqa: E402
from rodsim.core.scene import Scene  # noqa: E402

#: Seed of the fuzz suite's varying examples (tests/test_fuzz.py): a new one each session
#: unless RODSIM_FUZZ_SEED is set (to replay a run); set here, before any xdist worker
#: starts, so that every worker uses the same one.
os.environ.setdefault("RODSIM_FUZZ_SEED", str(int.from_bytes(os.urandom(4), "little")))


def pytest_report_header(config: pytest.Config) -> str:
    seed = os.environ["RODSIM_FUZZ_SEED"]
    return f"rodsim fuzz seed: {seed} (RODSIM_FUZZ_SEED={seed} replays this run's examples)"


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--runslow", action="store_true", default=False,
                     help="also run the tests marked slow (left out by default; .ci/run "
                          "runs them after the README's command)")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Tests marked ``slow`` (more than ~10 s of CPU each: discretisation convergence,
    N = 1000, the kernel cache, …; and the heaviest smoke tests, more than ~2 s: the
    benchmarks', studies', examples' and notebooks' runs, the fuzz suite, commands that draw
    a figure) are skipped, with that reason, unless ``--runslow`` is given: the README's
    command stays within five minutes on two cores, and ``.ci/run`` runs them after it
    (``python -m pytest -m slow --runslow``). They run first (in their collected order,
    the others after them): with ``-n`` workers the long ones then overlap each other and
    the short ones fill the gaps, instead of one long test starting last and running
    alone. Every worker sorts the same way, as pytest-xdist requires.

    Tests marked ``nightly`` (minutes each: the large-N cases) run only with
    ``RODSIM_NIGHTLY=1``; the default run reports them as skipped with that reason, and a
    cheaper test of the same promise runs every time (docs/reliability.md)."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)
    if not config.getoption("--runslow"):
        slow = pytest.mark.skip(reason="slow: left out of the README's command; --runslow "
                                       "runs it (.ci/run does)")
        for item in items:
            if item.get_closest_marker("slow") is not None:
                item.add_marker(slow)
    if os.environ.get("RODSIM_NIGHTLY") != "1":
        nightly = pytest.mark.skip(reason="nightly: minutes long; RODSIM_NIGHTLY=1 runs it")
        for item in items:
            if item.get_closest_marker("nightly") is not None:
                item.add_marker(nightly)


@pytest.fixture
def load() -> Callable[..., Scene]:
    """``load(name_or_path, *overrides)``: a validated scene with ``--set``-style overrides."""

    def _load(scene, *overrides: str) -> Scene:
        return rodsim.load_scene(scene, list(overrides))

    return _load


def _quaternion_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product in the paper's order (q1, q2, q3 imaginary, q4 real)."""
    av, aw = a[..., :3], a[..., 3:]
    bv, bw = b[..., :3], b[..., 3:]
    vector = aw * bv + bw * av + np.cross(av, bv)
    scalar = aw * bw - np.sum(av * bv, axis=-1, keepdims=True)
    return np.concatenate([vector, scalar], axis=-1)


def perturbed_state(model: Model, rng: np.random.Generator) -> np.ndarray:
    """A random, non-trivial state of the free coordinates of ``model``.

    Positions: a smooth random 3-D deflection of 1–5 % of L per mode (so the rod bends and
    twists out of plane without folding a segment onto itself), plus node noise of 5 % of a
    segment so every element is strained differently. Quaternions: each rest quaternion is
    turned by a random rotation of 0.05–0.3 rad about a random axis and its norm changed by
    up to ±3 %, so the terms that hold |q| = 1 (the centerline penalty) are exercised.
    """
    full = model.rest_full.copy()
    for rod in model.rods.values():
        s = rod.geometry.node_s / rod.length
        positions = full[rod.layout.position_index]
        for mode in (1, 2, 3):
            amplitude = rng.uniform(0.01, 0.05, 3) * rng.choice([-1.0, 1.0], 3) * rod.length
            positions += np.sin(0.5 * np.pi * mode * s)[:, None] * amplitude
        positions += 0.05 * rod.geometry.segment_length * rng.standard_normal(positions.shape)
        full[rod.layout.position_index] = positions

        quats = full[rod.layout.quaternion_index]
        axis = rng.standard_normal((len(quats), 3))
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        angle = rng.uniform(0.05, 0.3, len(quats))
        turn = np.concatenate([np.sin(angle / 2)[:, None] * axis, np.cos(angle / 2)[:, None]],
                              axis=1)
        quats = _quaternion_product(turn, quats)
        quats *= rng.uniform(0.97, 1.03, len(quats))[:, None]
        full[rod.layout.quaternion_index] = quats
    # The clamped coordinates are dropped here; model.full() puts back their fixed values.
    # The free coordinates are offsets from the rest state (Model.x0 is zero).
    return model.state_of(full)


@pytest.fixture
def random_state() -> Callable[[Model, np.random.Generator], np.ndarray]:
    """``random_state(model, rng)``: see :func:`perturbed_state`."""
    return perturbed_state


def fd_steps(model: Model, relative: float = 1e-6) -> np.ndarray:
    """Finite-difference step per free coordinate: ``relative`` × (L, or 1 for quaternions)."""
    return relative * np.where(model.is_quaternion, 1.0, model.length_scale)


def central_jacobian(function: Callable[[np.ndarray], np.ndarray], x: np.ndarray,
                     steps: np.ndarray) -> np.ndarray:
    """Dense ∂f/∂x by central differences, column by column."""
    columns = []
    for i, h in enumerate(steps):
        plus, minus = x.copy(), x.copy()
        plus[i] += h
        minus[i] -= h
        columns.append((np.asarray(function(plus)) - np.asarray(function(minus))) / (2 * h))
    return np.array(columns).T


def central_gradient(function: Callable[[np.ndarray], float], x: np.ndarray,
                     steps: np.ndarray) -> np.ndarray:
    """∂f/∂x of a scalar function by central differences."""
    return central_jacobian(lambda y: np.array([function(y)]), x, steps)[0]


@pytest.fixture
def cli() -> Callable[[list[str]], int]:
    """``cli(argv)``: ``rodsim.app.cli.main(argv)``, in process (its exit code)."""
    from rodsim.app.cli import main

    return main


@pytest.fixture
def fd() -> dict[str, Callable]:
    """Finite-difference helpers: ``steps(model)``, ``jacobian(f, x, h)``, ``gradient(f, x, h)``."""
    return {"steps": fd_steps, "jacobian": central_jacobian, "gradient": central_gradient}


@pytest.fixture
def least_squares_starts(monkeypatch) -> list:
    """The start x0 of every ``scipy.optimize.least_squares`` call (fit and reach import it
    when they run), recorded in call order."""
    import scipy.optimize

    starts = []
    solver = scipy.optimize.least_squares

    def recorded(function, x0, **options):
        starts.append(np.array(x0, dtype=float))
        return solver(function, x0, **options)

    monkeypatch.setattr(scipy.optimize, "least_squares", recorded)
    return starts

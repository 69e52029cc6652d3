"""The Jacobian of a string tendon with friction on 3-D and S-shaped paths (issue 34, "the
Jacobian stays exact"): every sliding chord's tension τ_e = T e^{∓W_e} moves with every turn
θ_j, j ≤ e, taken in 3-D (rodsim/core/turn_gradient.py), and with
``tendon_string.exact_jacobian`` the span element holds that coupling
(rodsim/core/terms/_string_span.py), so the Jacobian is the derivative of the force there
too and Newton converges quadratically.

The robots are our own, drawn from a seed: a steel wire (E 200 GPa, 1–4 N), a nitinol
backbone (60 GPa, 2–6 N) and a soft polymer catheter (10–50 MPa, 20–60 mN), each either
bent out of its tendon's plane by a follower force at the tip (3-D) or bent into an S by
two tendons on opposite sides, one ending at a node half-way (whose turn the other splits
there); μ between 0.05 and 0.5. Without the option (the frozen-tension Jacobian plus each
chord's own coupling on one-way planar paths) the same robots measured 0.37 to 0.70 of the
largest entry off their finite differences, and Newton took 7–131 iterations cold where
with it it takes 5–46 (docs/tendon.md, "Jacobian").
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from conftest import central_jacobian, fd_steps, perturbed_state
from test_term_contract import contract_model

import rodsim
from rodsim.app.inverse.track import Track
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.core.terms.tendon_string import TendonString

TENSION = "tendons.a.tendon_string.tension"
#: The release after the pull, as a share of the tension.
RELEASE = 0.9

#: (name, Young's modulus range [Pa], radius range [m], tension range [N]).
MATERIALS = (("steel", (200e9, 200e9), (0.3e-3, 0.5e-3), (1.0, 4.0)),
             ("nitinol", (60e9, 60e9), (0.4e-3, 0.6e-3), (2.0, 6.0)),
             ("polymer", (10e6, 50e6), (0.8e-3, 1.5e-3), (20e-3, 60e-3)))
SEEDS = range(6)


def robot(seed: int, kernels: str = "compiled", exact: bool = True) -> dict:
    """Robot ``seed`` (module docstring): material ``seed % 3`` of ``MATERIALS``, a 3-D path
    for even seeds and an S-shaped one for odd seeds."""
    rng = np.random.default_rng(100 + seed)
    _, moduli, radii, tensions = MATERIALS[seed % 3]
    modulus, radius = rng.uniform(*moduli), rng.uniform(*radii)
    length = rng.uniform(0.1, 0.25)
    offset = rng.uniform(1.5, 3.0) * radius
    tension = rng.uniform(*tensions)
    nodes = int(rng.integers(11, 16))
    area = math.pi * radius**2
    rod = {"length": length, "radius": radius, "youngs_modulus": modulus,
           "stretch_modulus": modulus, "poisson_ratio": 0.3, "density": 6450.0,
           "nodes": nodes, "clamp": "frame", "terms": ["stretch", "bend_twist", "centerline"],
           "centerline": {"K_P": modulus / 2.6 * area}}
    string = {"tension": tension, "spacers": True, "friction": rng.uniform(0.05, 0.5),
              "exact_jacobian": exact}
    tendons = {"a": {"catheter": "backbone", "coupling": "string", "offset": offset,
                     "direction": [1.0, 0.0], "tendon_string": string}}
    if seed % 2 == 0:
        # A follower force along d2 at the tip: the tendon bends in d1–d3, the force in d2–d3.
        side = rng.uniform(0.2, 0.5) * tension * offset / length
        rod["terms"].append("point_loads")
        rod["point_loads"] = {"loads": [{"s": length, "force": [0.0, side, 0.0],
                                         "frame": "body"}]}
    else:
        half = (nodes - 1) // 2
        string["end"] = length * half / (nodes - 1)
        tendons["b"] = {"catheter": "backbone", "coupling": "string", "offset": offset,
                        "direction": [-1.0, 0.0], "tendon_string": {
                            "tension": rng.uniform(0.3, 0.6) * tension, "spacers": True,
                            "friction": rng.uniform(0.05, 0.5), "exact_jacobian": exact}}
    return {"name": f"friction-3d-robot-{seed}", "rods": {"backbone": rod},
            "tendons": tendons, "solver": {"integrator": "static", "kernels": kernels}}


def tendons_only(model: Model) -> Model:
    return model.with_terms([t for t in model.terms if isinstance(t, TendonString)])


def off_one_way(model: Model, x: np.ndarray) -> float:
    """The largest |Θ_e − ψ_e| over the string tendons at the free state x: how far the
    paths are from turning one way in one plane (where the wrap is ∠(d3, u_e))."""
    full = model.full(x)
    worst = 0.0
    for term in model.terms:
        if isinstance(term, TendonString):
            d = np.diff(term.path(full), axis=0)
            u = d / np.linalg.norm(d, axis=1)[:, None]
            axis, _ = term.entry_directions(full)
            psi = np.arctan2(np.linalg.norm(np.cross(axis, u), axis=1), u @ axis)
            worst = max(worst, float(np.max(np.abs(np.cumsum(term.turning_angles(full))
                                                    - psi))))
    return worst


def pulled_and_released(seed: int, kernels: str = "compiled") -> Track:
    data = robot(seed, kernels)
    tension = data["tendons"]["a"]["tendon_string"]["tension"]
    track = rodsim.track(Scene.from_dict(data), {TENSION: [tension, RELEASE * tension]})
    assert track.success
    return track


@pytest.mark.parametrize("seed", SEEDS)
def test_the_jacobian_is_the_derivative_of_the_force_on_3d_and_s_paths(seed):
    """Pulled (every chord sliding in) and released to 90 % (sliding out near the base,
    stuck beyond): the tendons' Jacobian against central differences (steps 1e-8 L and 1e-8
    per quaternion component), relative to its largest entry, below 2e-7: measured 3.6e-10
    to 5.2e-8 (the same robots without friction 2.7e-10 to 8.8e-10). The larger values, on
    the steel and nitinol 3-D robots, are the differences' truncation, not the Jacobian's
    error: they fall as h² (steel: 5.2e-6, 5.2e-8, 4.9e-9 at steps 1e-7, 1e-8, 3e-9), the
    third derivative of a small turn out of the plane being large.
    The paths are 3-D or S-shaped: |Θ_e − ψ_e| reaches 1e-4 rad or more."""
    track = pulled_and_released(seed)
    model = track.last_model
    states = [term.point_states(model.full(model.state_of(track.states[-1])))[1]
              for term in tendons_only(model).terms]
    assert any(np.any(s > 0.0) for s in states)  # released: sliding out somewhere
    # Each state with the history it was solved with: cold (pulled in from slack) for the
    # pull; the pull's tensions for the release. (At the pull's state with the pull's own
    # tensions as history, the other tendon's chords sit exactly on their bound, where the
    # clip has a kink and central differences average its two sides.)
    cold = Model(Scene.from_dict(robot(seed)))
    for step, state in ((cold, track.states[0]), (model, track.states[-1])):
        alone = tendons_only(step)
        x = step.state_of(state)
        assert off_one_way(step, x) > 1e-4
        analytic = alone.jacobian(x).toarray()
        numeric = central_jacobian(alone.force, x, fd_steps(step, 1e-8))
        error = np.max(np.abs(analytic - numeric)) / np.max(np.abs(numeric))
        assert error < 2e-7, error


@pytest.mark.parametrize("seed", [0, 5])
def test_the_compiled_kernel_matches_the_reference_on_3d_and_s_paths(seed):
    """At the released state, with the history of the pull, the compiled span kernel's
    force and Jacobian are the numpy reference's to round-off."""
    runs = {kernels: pulled_and_released(seed, kernels) for kernels in ("numpy", "compiled")}
    model = tendons_only(runs["numpy"].last_model)
    compiled = tendons_only(runs["compiled"].last_model)
    x = model.state_of(runs["numpy"].states[-1])
    force, jacobian = model.force(x), model.jacobian(x).toarray()
    assert np.max(np.abs(compiled.force(x) - force)) < 1e-12 * np.max(np.abs(force))
    assert np.max(np.abs(compiled.jacobian(x).toarray() - jacobian)) < 1e-11 * (
        np.max(np.abs(jacobian)))


def _newton_errors(model: Model, x: np.ndarray, iterations: int = 12) -> list[float]:
    """Plain Newton from x (full steps, the model's retraction): the distance of each
    iterate from the last, over the first's."""
    iterates = [x]
    for _ in range(iterations):
        dx = spla.spsolve(model.jacobian(x).tocsc(), -model.force(x))
        x = model.step(x, dx)
        iterates.append(x)
    errors = [float(np.max(np.abs(y - iterates[-1]))) for y in iterates[:-3]]
    return [e / errors[0] for e in errors]


@pytest.mark.parametrize("seed", SEEDS)
def test_newton_converges_quadratically_on_3d_and_s_paths(seed):
    """From the equilibrium at 90 % of the tension, plain Newton at full tension: the last
    two ratios log(e_{k+1}) / log(e_k) of its errors (relative to the first) below 1e-1 and
    above 1e-10 are at least 1.5 (quadratic: 2; with the frozen-tension Jacobian the rate
    is linear, of order μ)."""
    data = robot(seed)
    model = Model(Scene.from_dict(data))
    for tendon in data["tendons"].values():
        tendon["tendon_string"]["tension"] *= 0.9
    start = rodsim.solve(Scene.from_dict(data))
    assert start.success
    errors = _newton_errors(model, start.state)
    ratios = [math.log(b) / math.log(a) for a, b in zip(errors, errors[1:], strict=False)
              if a < 1e-1 and b > 1e-10]
    assert ratios, errors
    assert min(ratios[-2:]) >= 1.5, (ratios, errors)


def test_the_contract_scene_has_chords_sticking_and_sliding_both_ways():
    """The term contract's friction scene (tests/test_term_contract.py) at its random
    states: its tendons have chords sliding in, stuck and (one at least) sliding out, so
    the contract checks the coupling in each regime."""
    model = contract_model("contract-friction-strings")
    rng = np.random.default_rng(list(map(ord, "contract-friction-stringstendon_string")))
    seen: set[float] = set()
    for _ in range(2):
        full = model.full(perturbed_state(model, rng))
        for term in model.terms:
            if isinstance(term, TendonString):
                seen.update(np.unique(term.point_states(full)[1]).tolist())
    assert seen == {-1.0, 0.0, 1.0}

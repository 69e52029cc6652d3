"""The pull–release loop of tendon friction on the shipped robots and on users' robots
(issue 34's aims; docs/tendon.md, "Friction"), and the capstan's exact hold range.

- tdcr-two-segment (ramping s1a to 3 N) and catheter-pull-ring (wire_up to 1 N), every
  tendon's μ = 0.1 or 0.3, the 35-step pull–release cycle of the friction benchmark
  (benchmarks/rodsim_bench/friction.py: 0.1 T_max → T_max → 0.1 T_max): the loop's area
  A = ∫ (d_release − d_pull) dT, d the tip's travel along its pull, converges as N doubles;
  the same cycle at μ = 0 is the frictionless track bitwise. The string's friction has no
  regularisation (the capstan clip is exact Coulomb, rodsim/core/tendon_friction.py), so
  there is no regularisation to converge in.
- Users' robots drawn at random (tests/test_tendon_friction.py's ``user_robot``: TDCRs on
  spacer disks pulled to 22 and 2.9 N, soft polymer catheters with lumens to 2.8 and 1.4 N,
  nitinol tubes to 198 and 333 N; μ 0.05–0.3): the same cycle's area converges in N at
  second order.
- The rigid helix (tests/test_tendon_stiction.py, μ = 0.2): pulled in, the termination's
  tension is T_0 e^{−μΘ} with Θ the turns measured on the state, to 1e-12 relative; released,
  it holds exactly while T e^{μΘ(T)} ≥ T_max e^{−μΘ_max} (Θ(T) measured on the released
  state) — tested 1e-9 relative either side of that edge.
- The actuator's displacement along a track (``Track.pulled_in``) against the self-bent
  catheter's closed form; friction on a rod tendon refused on the command line (exit 2,
  one line).
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from test_tendon_friction import user_robot
from test_tendon_stiction import TENSION, helix_scene, string_term

import rodsim
from rodsim.core.model import Model
from rodsim.core.scene import Scene

#: scene → (its tendons, the ramped tendon, T_max [N]): the friction benchmark's cases.
CASES = {"tdcr-two-segment": (("s1a", "s1b", "s1c", "s2a", "s2b", "s2c"), "s1a", 3.0),
         "catheter-pull-ring": (("wire_up", "wire_down"), "wire_up", 1.0)}
STEPS = 35


def cycle(t_max: float, steps: int = STEPS) -> np.ndarray:
    """0.1 T_max → T_max → 0.1 T_max in ``steps`` values (the benchmark's cycle)."""
    up = (steps + 1) // 2
    rising = np.linspace(0.1 * t_max, t_max, up)
    return np.concatenate([rising, rising[::-1][1:steps - up + 1]])


def loop_area(scene: Scene, key: str, values: np.ndarray) -> float:
    """∫ (d_release − d_pull) dT over the cycle's values [m N], d the tip's travel along the
    direction it moved in the pull (trapezoids on the pull's values)."""
    track = rodsim.track(scene, {key: values}, estimates=False)
    assert track.success, track.message
    tips = track.tips()
    up = (len(values) + 1) // 2
    axis = tips[up - 1] - tips[0]
    travel = (tips - tips[0]) @ (axis / np.linalg.norm(axis))
    gap = travel[up - 1:][::-1] - travel[:up]
    return float(np.sum(0.5 * (gap[1:] + gap[:-1]) * np.diff(values[:up])))


def _shipped(name: str, mu: float | None, nodes: int | None = None) -> Scene:
    tendons, _, _ = CASES[name]
    rod = next(iter(rodsim.load_scene(name).rods))
    changes = [] if mu is None else [f"tendons.{t}.tendon_string.friction={mu!r}"
                                     for t in tendons]
    if nodes is not None:
        changes.append(f"rods.{rod}.nodes={nodes}")
    return rodsim.load_scene(name, changes)


@pytest.mark.parametrize("name", list(CASES))
def test_zero_friction_tracks_the_frictionless_cycle_bitwise(name):
    """μ = 0 on every tendon gives the frictionless track of the 35-step cycle bit for bit
    (positions of every step), and no loop: the release retraces the pull to round-off."""
    _, ramped, t_max = CASES[name]
    key = f"tendons.{ramped}.tendon_string.tension"
    values = cycle(t_max)
    zero = rodsim.track(_shipped(name, 0.0), {key: values}, estimates=False)
    plain = rodsim.track(_shipped(name, None), {key: values}, estimates=False)
    assert zero.success and plain.success
    assert np.array_equal(zero.positions, plain.positions)
    assert abs(loop_area(_shipped(name, 0.0), key, values)) < 1e-9 * t_max * np.max(
        np.abs(plain.tips() - plain.tips()[0]))


@pytest.mark.slow
@pytest.mark.parametrize("name, mu", [(n, mu) for n in CASES for mu in (0.1, 0.3)])
def test_the_loop_area_of_the_shipped_robots_converges_in_n(name, mu):
    """The 35-step cycle's loop area at N, 2N − 1, 4N − 3 and 8N − 7 (tdcr-two-segment from
    16, catheter-pull-ring from 26; the shipped 61 and 101 among them): successive
    differences, relative to the finest area, measured 1.5e-3, 1.3e-3, 3.8e-4 and 1.2e-3,
    1.4e-3, 4.1e-4 on tdcr-two-segment at μ = 0.1 and 0.3 (areas 2.69e-3, 7.81e-3 m N; the
    coarse meshes pre-asymptotic), 8.0e-3, 8.5e-4, 2.3e-4 and 7.3e-3, 6.4e-4, 1.9e-4 on
    catheter-pull-ring (1.02e-3, 2.22e-3 m N): the last halving of order 1.75–1.85; a
    larger μ widens the loop."""
    _, ramped, t_max = CASES[name]
    key = f"tendons.{ramped}.tendon_string.tension"
    first = 16 if name == "tdcr-two-segment" else 26
    nodes = [first, 2 * first - 1, 4 * first - 3, 8 * first - 7]
    areas = [loop_area(_shipped(name, mu, n), key, cycle(t_max)) for n in nodes]
    steps = np.abs(np.diff(areas)) / abs(areas[-1])
    assert areas[-1] > 0.0 and steps[-1] < 6e-4, (areas, steps)
    assert 1.4 < math.log2(steps[-2] / steps[-1]) < 2.6, (areas, steps)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(6))
def test_the_loop_area_of_users_robots_converges_in_n_at_second_order(seed):
    """Each robot's first tendon cycled 0.1 T → T → 0.1 T in 35 steps at its N, 2N − 1 and
    4N − 3: the loop area's successive differences relative to the finest 1.2e-3, 3.4e-4
    (TDCR at 22 N), 1.3e-3, 3.3e-4 (soft catheter at 2.8 N), 1.9e-3, 4.9e-4 (nitinol
    tube at 198 N), 1.2e-3, 3.4e-4, 7.7e-4, 2.0e-4, 1.1e-3, 2.9e-4 (seeds 3–5): orders
    1.75–1.98."""
    data, first = user_robot(seed)
    tension = data["tendons"][first]["tendon_string"]["tension"]
    key = f"tendons.{first}.tendon_string.tension"
    n = data["rods"]["body"]["nodes"]
    areas = []
    for nodes in (n, 2 * n - 1, 4 * n - 3):
        raw = copy.deepcopy(data)
        raw["rods"]["body"]["nodes"] = nodes
        areas.append(loop_area(Scene.from_dict(raw), key, cycle(tension)))
    steps = np.abs(np.diff(areas)) / abs(areas[-1])
    assert areas[-1] > 0.0 and steps[-1] < 1e-3, (areas, steps)
    assert 1.6 < math.log2(steps[0] / steps[1]) < 2.4, (areas, steps)


def test_the_capstan_ratio_and_the_hold_range_on_a_rigid_helix_are_exact():
    """Pulled in from 0.5 to 1 mN: the termination's tension over the actuator's is e^{−μΘ} to
    1e-12 relative, Θ the sum of the turns on the state. Released to T = edge (1 ± 1e-9),
    the edge T_e solving T_e e^{μΘ(T_e)} = τ_last (a fixed point: the turns move with T by
    1e-7 rad): held (the termination's tension unchanged, bit for bit) at or above it, let
    out below it."""
    mu, t_max = 0.2, 1e-3
    scene = Scene.from_dict(helix_scene(11, t_max, friction=mu))
    term = string_term(Model(scene))
    pulled = rodsim.track(scene, {TENSION: [0.5 * t_max, t_max]}, estimates=False)
    top = pulled.tension[-1][-1]
    wrap = float(np.sum(term.turning_angles(pulled.states[-1])))
    assert top / t_max == pytest.approx(math.exp(-mu * wrap), rel=1e-12)
    edge = top * math.exp(-mu * wrap)
    for _ in range(3):  # the edge at the turns of the state released to it
        at = rodsim.track(scene, {TENSION: [0.5 * t_max, t_max, edge]}, estimates=False)
        edge = top * math.exp(-mu * float(np.sum(term.turning_angles(at.states[-1]))))
    for factor, held in ((1 + 1e-9, True), (1 - 1e-9, False)):
        released = rodsim.track(scene, {TENSION: [0.5 * t_max, t_max, edge * factor]},
                                    estimates=False)
        assert released.success, released.message
        assert (released.tension[-1][-1] == top) == held, factor
        if not held:
            assert released.tension[-1][-1] < top


def test_the_actuator_displacement_against_the_closed_form():
    """The self-bent catheter (tests/test_tendon_friction.py, μ = 0.2) pulled 0.5 → 3 N
    in 6 steps and released to 0.5 N in 5: ``Track.pulled_in`` (and the archive's
    ``tendon_pulled_in``), ℓ_0 − ℓ, against the continuum's path length
    ∫ (1 − T/EA)(1 − ρ κ) ds, κ = T ρ/EI, T(s) = T_0/(1 + μ T_0 ρ s/EI), on the pull:
    first order (measured 2.3 %, 1.2 %, 0.58 % of the travel at N = 21, 41, 81; frictionless
    the same, 2.5 %, 1.2 %, 0.62 %: the termination's routing point takes the last
    segment's frame, half a segment's turn short of the tip's). Released, the actuator has
    drawn in more tendon at the same tension than on the pull (the loop)."""
    from scipy.integrate import quad
    from test_tendon_friction import EA, EI, LENGTH, OFFSET, catheter
    from test_tendon_friction import TENSION as PULL

    mu, up, down = 0.2, np.linspace(0.5, 3.0, 6), np.linspace(2.5, 0.5, 5)

    def path(t0: float) -> float:
        def integrand(s: float) -> float:
            tension = t0 / (1 + mu * t0 * OFFSET * s / EI)
            return (1 - tension / EA) * (1 - OFFSET**2 * tension / EI)
        return quad(integrand, 0.0, LENGTH, epsabs=1e-14)[0]

    closed = np.array([path(up[0]) - path(t) for t in up])
    errors = []
    for n in (21, 41, 81):
        track = rodsim.track(Scene.from_dict(catheter(n, mu, 0.5)),
                             {PULL: np.concatenate([up, down])}, estimates=False)
        assert track.success, track.message
        pulled = track.pulled_in["a"]
        errors.append(float(np.max(np.abs(pulled[:len(up)] - closed)) / closed[-1]))
        for k, t in enumerate(down):
            pull = pulled[int(np.flatnonzero(np.isclose(up, t))[0])]
            assert pulled[len(up) + k] > pull, (n, t)
    archived = track.to_xarray()["tendon_pulled_in"].sel(friction_tendon="a").values
    assert np.array_equal(archived, pulled)
    orders = [math.log2(a / b) for a, b in zip(errors, errors[1:], strict=False)]
    assert errors[-1] < 7e-3 and all(0.9 < o < 1.1 for o in orders), (errors, orders)


@pytest.mark.parametrize("table", ["[tendons.tendon]", "[tendons.tendon.tendon_actuation]"])
def test_friction_on_a_rod_tendon_exits_2_with_one_line(cli, capsys, tmp_path, table):
    """``rodsim run`` of table3-catheter1's scene file with friction set on its rod tendon
    (the paper's coupling), on its table or its actuation term: exit 2 and one line naming
    where friction belongs (tendon_string; docs/tendon.md, "Rod tendons have no friction"),
    nothing written."""
    from pathlib import Path

    text = (Path(__file__).parents[1] / "data" / "table3-catheter1.toml").read_text()
    assert f"\n{table}\n" in text
    scene = tmp_path / "rubbing.toml"
    scene.write_text(text.replace(f"\n{table}\n", f"\n{table}\nfriction = 0.2\n", 1))
    out = tmp_path / "out.nc"
    assert cli(["run", str(scene), "-o", str(out)]) == 2
    captured = capsys.readouterr()
    lines = [line for line in captured.err.splitlines() if line.strip()]
    assert len(lines) == 1 and "tendon_string" in lines[0], captured.err
    assert not out.exists()

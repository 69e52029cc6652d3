"""The Jacobian of a string tendon whose friction coefficient varies along it, before and
after its upstream coupling (rodsim/core/terms/_string_span.py): exact Newton counts and
how far the equilibria moved, in one run.

For this checkout and a baseline revision (``--baseline``; its tree extracted by
``git archive``), each in its own process, on the scenes below:

- the tendon term's Jacobian against central differences (steps 1e-7 L and 1e-7 per
  quaternion component) at the cold equilibrium, relative to its largest entry;
- the static solve from rest: its Newton iterations (``newton_iters``);
- a pull–release track (8 steps up to the tension, 8 back down to 40 %, each warm-started):
  the Newton iterations of every step, summed;
- CPU time (process): the static solve, best of 3 after the first; the track, once;
- the node positions of both (the equilibrium and every step's), whose largest difference
  between the two trees, over the catheter's length L, is the move.

Scenes: the catheter bent by its own tendon with μ 0.1 → 0.4 → 0.15 → 0.3 along it
(tests/test_friction_profile.py) at N = 21, 41, 81; a nitinol tendon-driven robot (2 N)
and a soft polymer catheter (20 mN) with profiles of their own; the self-bent catheter with
stiction (μ_k 0.1, μ_s 0.3); the rigid helix with a profile (a 3-D path: without
``tendon_string.exact_jacobian`` the span element does not apply there, Newton linear on
both sides).

Writes ``friction-jacobian.json`` and ``friction-jacobian.md`` into ``--output-dir``
(default ``runs/bench``). Nothing is asserted.

    python benchmarks/friction_jacobian.py --baseline 61294df --output-dir benchmarks/results
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rodsim.app.threads import pin_threads

pin_threads()  # before numpy: threaded BLAS only adds contention here

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
TENSION = "tendons.a.tendon_string.tension"


def _rod(nodes: int, length: float, radius: float, modulus: float) -> dict:
    area = math.pi * radius**2
    return {"length": length, "radius": radius, "youngs_modulus": modulus,
            "stretch_modulus": modulus, "poisson_ratio": 0.3, "density": 6450.0,
            "nodes": nodes, "clamp": "frame", "terms": ["stretch", "bend_twist", "centerline"],
            "centerline": {"K_P": modulus / 2.6 * area}}


def _scene(name: str, rod: dict, offset: float, string: dict) -> dict:
    return {"name": name, "rods": {"backbone": rod},
            "tendons": {"a": {"catheter": "backbone", "coupling": "string", "offset": offset,
                              "direction": [1.0, 0.0], "tendon_string": string}},
            "solver": {"integrator": "static"}}


def scenes() -> dict[str, dict]:
    """The scenes measured (module docstring), by label."""
    out = {}
    bent = {"friction_profile": [0.1, 0.4, 0.15, 0.3],
            "friction_profile_s": [0.0, 0.05, 0.12, 0.2]}
    for n in (21, 41, 81):
        out[f"self-bent N={n}"] = _scene("self-bent", _rod(n, 0.2, 0.7e-3, 54e9), 0.01,
                                         {"tension": 3.0, "spacers": True, **bent})
    out["nitinol 2 N"] = _scene("nitinol", _rod(25, 0.25, 0.5e-3, 60e9), 2e-3, {
        "tension": 2.0, "spacers": True, "friction_profile": [0.05, 0.3, 0.1, 0.25],
        "friction_profile_s": [0.0, 0.08, 0.16, 0.25]})
    out["polymer 20 mN"] = _scene("polymer", _rod(25, 0.12, 1e-3, 20e6), 0.7e-3, {
        "tension": 0.02, "spacers": True, "friction_profile": [0.3, 0.1, 0.4],
        "friction_profile_s": [0.0, 0.06, 0.12]})
    out["self-bent stiction"] = _scene("stiction", _rod(21, 0.2, 0.7e-3, 54e9), 0.01, {
        "tension": 3.0, "spacers": True, "friction": 0.1, "static_friction": 0.3})
    helix = _rod(21, 0.1, 2e-3, 200e9)
    out["rigid helix"] = _scene("helix", helix, 0.01, {
        "tension": 1e-3, "routing": "helix", "helix_radius": 1e-3, "helix_pitch": 0.05,
        "friction_profile": [0.1, 0.5, 0.2, 0.3],
        "friction_profile_s": [0.0, 0.03, 0.07, 0.1]})
    return out


def measure() -> dict:
    """This tree's numbers on every scene (run with this tree's rodsim importable)."""
    import rodsim
    from rodsim.core.model import Model
    from rodsim.core.scene import Scene
    from rodsim.core.terms.tendon_string import TendonString

    out = {}
    for label, data in scenes().items():
        scene = Scene.from_dict(data)
        result = rodsim.solve(scene)
        seconds = []
        for _ in range(3):
            start = time.process_time()
            rodsim.solve(scene)
            seconds.append(time.process_time() - start)
        model = Model(scene)
        rod = model.rods["backbone"].layout.position_index
        alone = model.with_terms([t for t in model.terms if isinstance(t, TendonString)])
        x = result.state
        analytic = alone.jacobian(x).toarray()
        steps = 1e-7 * np.where(model.is_quaternion, 1.0, model.length_scale)
        numeric = np.empty_like(analytic)
        for i, h in enumerate(steps):
            plus, minus = x.copy(), x.copy()
            plus[i] += h
            minus[i] -= h
            numeric[:, i] = (alone.force(plus) - alone.force(minus)) / (2 * h)
        tension = data["tendons"]["a"]["tendon_string"]["tension"]
        ramp = np.concatenate([np.linspace(tension / 8, tension, 8),
                               np.linspace(0.925 * tension, 0.4 * tension, 8)])
        start = time.process_time()
        track = rodsim.track(scene, {TENSION: ramp}, estimates=False)
        out[label] = {
            "success": bool(result.success), "newton": int(result.stats["newton_iters"]),
            "static_ms": 1e3 * min(seconds),
            "fd_error": float(np.max(np.abs(analytic - numeric))
                              / np.max(np.abs(numeric))),
            "state": model.full(x)[rod].tolist(), "length": float(model.length_scale),
            "track_success": bool(track.success),
            "track_newton": int(sum(track.iterations)),
            "track_states": [np.asarray(s)[rod].tolist() for s in track.states],
            "track_seconds": time.process_time() - start}
    return out


def _run(tree: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1")
    done = subprocess.run([sys.executable, str(HERE / "friction_jacobian.py"), "--measure"],
                          env=env, cwd=tree, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default=os.environ.get("RODSIM_BENCH_BASELINE"))
    parser.add_argument("--output-dir", default="runs/bench")
    parser.add_argument("--measure", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.measure:
        print(json.dumps(measure()))
        return
    head = subprocess.run(["git", "rev-parse", "--short=10", "HEAD"], cwd=ROOT,
                          capture_output=True, text=True, check=True).stdout.strip()
    if subprocess.run(["git", "status", "--porcelain", "rodsim"], cwd=ROOT,
                      capture_output=True, text=True, check=True).stdout.strip():
        head += " with uncommitted changes to rodsim"
    with tempfile.TemporaryDirectory() as folder:
        archive = subprocess.run(["git", "archive", args.baseline], cwd=ROOT,
                                 capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", folder], input=archive, check=True)
        before = _run(Path(folder))
    after = _run(ROOT)
    rows = []
    for label in after:
        b, a = before[label], after[label]
        move = np.max(np.abs(np.array(a["state"]) - np.array(b["state"]))) / a["length"]
        track_move = max(float(np.max(np.abs(np.array(p) - np.array(q)))) for p, q in zip(
            a["track_states"], b["track_states"], strict=True)) / a["length"]
        rows.append({"scene": label, "fd_before": b["fd_error"], "fd_after": a["fd_error"],
                     "newton_before": b["newton"], "newton_after": a["newton"],
                     "track_before": b["track_newton"], "track_after": a["track_newton"],
                     "static_ms_before": b["static_ms"], "static_ms_after": a["static_ms"],
                     "track_s_before": b["track_seconds"], "track_s_after": a["track_seconds"],
                     "state_move": move, "track_move": track_move,
                     "success": a["success"] and b["success"] and a["track_success"]
                     and b["track_success"]})
    output = Path(args.output_dir)
    output.mkdir(parents=True, exist_ok=True)
    (output / "friction-jacobian.json").write_text(json.dumps(
        {"head": head, "baseline": args.baseline, "rows": rows}, indent=1) + "\n")
    lines = ["# The Jacobian with a friction profile: before and after the upstream coupling",
             "", f"HEAD {head} against {args.baseline}; CPU times on a shared machine; "
             "exact Newton counts (static from rest; a 16-step pull–release track, "
             "summed); moves are the largest difference of a node's position between "
             "the two trees over L (the track's over "
             "its 16 states).", "",
             "| scene | J vs FD before | after | static Newton before | after | track "
             "Newton before | after | equilibrium move / L | track move / L | static "
             "[ms] before | after | track [s] before | after | all converged |",
             "|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|---|"]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['fd_before']:.1e} | {r['fd_after']:.1e} | "
                     f"{r['newton_before']} | {r['newton_after']} | {r['track_before']} | "
                     f"{r['track_after']} | {r['state_move']:.1e} | {r['track_move']:.1e} | "
                     f"{r['static_ms_before']:.1f} | {r['static_ms_after']:.1f} | "
                     f"{r['track_s_before']:.2f} | {r['track_s_after']:.2f} | "
                     f"{'yes' if r['success'] else 'no'} |")
    (output / "friction-jacobian.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()

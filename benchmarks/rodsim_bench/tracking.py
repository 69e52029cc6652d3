"""Tracking at control-loop rates (``rodsim bench tracking``): steps per second of CPU of
``rodsim.track`` over 201 steps (static) on table3-catheter1 (tendon force 0 → 4 N) and on
tdcr-two-segment (segment 1's tendon s1a 0 → 3 N: string tendons, a conservative model),
each measured in one run against the same track with every step's model re-assembled
(:meth:`Model.with_scene`, what every step did before :meth:`Model.with_values`).

CPU time (``time.process_time``) of the whole track after a warm-up (kernels loaded), the
best of the repeats, the variants interleaved; the equilibria of the two variants are
compared (largest difference of any coordinate, every step). The stability verdict's share
(``rodsim.core.stability.assess``, every step's) is measured in the best repeat of the shared
model. Outputs ``tracking-<size>.nc`` and ``tracking-<size>.md``.

The Tracker's own rate (``rodsim.Tracker``, what a control loop holds) along the same
ramps, interleaved with the tracks: built at the ramp's first value (a cold solve, not
timed), then ``tracker.step`` at each later value, with its verdict at every step (CPU of
the steps and of their verdicts, iterations, unstable steps, and the largest difference of
its states from the track's), and its floor a step: its evaluations and factorisations,
counted in one more run, at their raw costs (``_tracker_floor``, ``rodsim_bench.floor``).

With the environment variable ``RODSIM_BENCH_BASELINE`` set to a git revision of this
repository, the same tracks (shared model) are also run by that revision's code in the same
run, interleaved with the repeats: its tree is extracted (``git archive``) into a temporary
folder and each repeat runs it in a subprocess (``PYTHONPATH`` set to it; the same warm-up,
the same CPU clock inside the process); the table then gives the baseline's steps/s, the
ratio and the largest difference between the two revisions' states; and, where that
revision has a Tracker, its tracker's steps/s, whether it flags the same unstable steps and
the largest difference between the two trackers' states.
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

import numpy as np
import xarray as xr

import rodsim
import rodsim.core.stability as stability
from rodsim.core.model import Model
from rodsim.io.archive import write_dataset
from rodsim_bench.baseline import BaselineTree, baseline_revision
from rodsim_bench.machine import machine

__all__ = ["run", "VARIANTS", "CASES"]

SIZES = {"small": {"repeats": 1, "steps": 21}, "full": {"repeats": 5, "steps": 201}}
#: (scene, ramped key, start, stop [N]).
CASES = (("table3-catheter1", "tendons.tendon.tendon_actuation.force", 0.0, 4.0),
         ("tdcr-two-segment", "tendons.s1a.tendon_string.tension", 0.0, 3.0))
VARIANTS = ("shared model (with_values)", "re-assembled model (with_scene)")


def _track(scene_name: str, ramp: dict, variant: str):
    """(CPU of the whole track, CPU of its verdicts, the track)."""
    scene = rodsim.load_scene(scene_name)
    original, assess = Model.with_values, stability.assess
    spent = [0.0]

    def timed(*args, **kwargs):
        start = time.process_time()
        try:
            return assess(*args, **kwargs)
        finally:
            spent[0] += time.process_time() - start

    if variant == VARIANTS[1]:
        Model.with_values = Model.with_scene  # type: ignore[method-assign]
    stability.assess = timed  # type: ignore[assignment]
    try:
        start = time.process_time()
        path = rodsim.track(scene, ramp, estimates=False)
        return time.process_time() - start, spent[0], path
    finally:
        Model.with_values = original  # type: ignore[method-assign]
        stability.assess = assess  # type: ignore[assignment]


def _tracker_at(scene_name: str, key: str, start: float) -> rodsim.Tracker:
    """A ``rodsim.Tracker`` of ``key`` on the shipped scene, built (cold) at ``start``."""
    from rodsim.app.inverse.parameter_keys import numeric_keys, scene_with

    scene = rodsim.load_scene(scene_name)
    return rodsim.Tracker(scene_with(scene, numeric_keys(scene, [key]), [start]), [key])


def _tracker_run(scene_name: str, key: str, start: float, stop: float, steps: int
                 ) -> tuple[float, float, np.ndarray, list[bool], int]:
    """``rodsim.Tracker`` along the ramp: built at its first value (cold, not timed), then
    ``tracker.step`` at each later one, a verdict at every step: (CPU of the steps, CPU of
    their verdicts, the full states of every step (the first the cold one), each step's
    stable flag, iterations)."""
    import rodsim.app.inverse.tracker as tracker_module

    tracker = _tracker_at(scene_name, key, start)
    states = [tracker.continuation.model.full(tracker.continuation.x)]
    assess, spent = tracker_module.assess, [0.0]

    def timed(*args, **kwargs):
        began = time.process_time()
        try:
            return assess(*args, **kwargs)
        finally:
            spent[0] += time.process_time() - began

    tracker_module.assess = timed  # type: ignore[assignment]
    stable, iterations, steps_done = [], 0, []
    try:
        began = time.process_time()
        for value in np.linspace(start, stop, steps)[1:]:
            steps_done.append(tracker.step([value]))
        seconds = time.process_time() - began
    finally:
        tracker_module.assess = assess  # type: ignore[assignment]
    for step in steps_done:
        if not step.success:
            raise RuntimeError(f"{scene_name}, tracker: {step.message}")
        states.append(tracker.continuation.model.full(step.state))
        stable.append(bool(step.stability is not None and step.stability.stable))
        iterations += step.iterations
    return seconds, spent[0], np.array(states), stable, iterations


def _tracker_floor(scene_name: str, key: str, start: float, stop: float, steps: int
                   ) -> tuple[float, dict[str, float]]:
    """The floor of a Tracker step [s] along the ramp, as ``rodsim_bench.floor`` takes a
    static solve's: in one more (untimed) run of the steps, the evaluations of F, of
    ∂F/∂x and the linear solves and factorisations counted (``counted_calls``), each at its
    raw cost at the last step's equilibrium (``raw_costs``), summed and divided by the
    steps; and the counts a step. Back-substitutions with a kept factorisation and the
    verdict's eigen-iterations are not counted (the verdict is timed on its own)."""
    from rodsim_bench.floor import counted_calls, floor_of, raw_costs

    tracker = _tracker_at(scene_name, key, start)
    with counted_calls() as counts:
        for value in np.linspace(start, stop, steps)[1:]:
            tracker.step([value])
    continuation = tracker.continuation
    costs = raw_costs(continuation.model, continuation.x, 200)
    taken = steps - 1
    return floor_of(counts, costs) / taken, {k: v / taken for k, v in counts.items()}


#: What a baseline subprocess runs: argv[1] the number of steps, argv[2] a folder for the
#: states; prints {scene: CPU seconds} of the tracks and {scene + ' tracker': CPU seconds}
#: of its Tracker's steps (where the revision has one).
_BASELINE_SCRIPT = """
import json, sys, time
import numpy as np
import rodsim
cases = json.loads(sys.argv[3])
steps, folder = int(sys.argv[1]), sys.argv[2]
out = {}
for scene_name, key, start, stop in cases:
    scene = rodsim.load_scene(scene_name)
    rodsim.track(scene, {key: np.linspace(start, stop, 3)}, estimates=False)
    began = time.process_time()
    path = rodsim.track(scene, {key: np.linspace(start, stop, steps)}, estimates=False)
    out[scene_name] = time.process_time() - began
    if not path.success:
        raise SystemExit(scene_name + ': ' + path.message)
    np.save(folder + '/' + scene_name + '.npy', np.array(path.states))
    if hasattr(rodsim, 'Tracker'):
        from rodsim.app.inverse.parameter_keys import numeric_keys, scene_with
        keys = numeric_keys(scene, [key])
        for count in (3, steps):
            tracker = rodsim.Tracker(scene_with(scene, keys, [start]), [key])
            full = [tracker.continuation.model.full(tracker.continuation.x)]
            began = time.process_time()
            done = [tracker.step([v]) for v in np.linspace(start, stop, count)[1:]]
            seconds = time.process_time() - began
        out[scene_name + ' tracker'] = seconds
        full += [tracker.continuation.model.full(s.state) for s in done]
        np.save(folder + '/' + scene_name + ' tracker.npy', np.array(full))
        np.save(folder + '/' + scene_name + ' tracker stable.npy',
                np.array([s.stability.stable for s in done]))
print(json.dumps(out))
"""


class _Baseline:
    """The tracks run by another revision's code (module docstring)."""

    def __init__(self, revision: str, folder: Path) -> None:
        self._tree = BaselineTree(revision, folder)
        self.commit = self._tree.commit
        self.states = folder / "states"
        self.states.mkdir()

    def run(self, steps: int) -> dict[str, float]:
        done = self._tree.python(["-c", _BASELINE_SCRIPT, str(steps), str(self.states),
                                  json.dumps(CASES)])
        return json.loads(done.stdout.strip().splitlines()[-1])

    def states_of(self, scene_name: str) -> np.ndarray:
        return np.load(self.states / f"{scene_name}.npy")

    def tracker_states_of(self, scene_name: str) -> tuple[np.ndarray, np.ndarray] | None:
        """The baseline tracker's full states and stable flags, None without a Tracker."""
        path = self.states / f"{scene_name} tracker.npy"
        if not path.exists():
            return None
        return np.load(path), np.load(self.states / f"{scene_name} tracker stable.npy")


def run(size: str, output_dir: str | Path, progress=None) -> list[Path]:
    revision = baseline_revision()
    if revision:
        with tempfile.TemporaryDirectory() as folder:
            baseline = _Baseline(revision, Path(folder))
            baseline.run(3)  # warm-up: its kernels compiled into its own tree's cache
            return _run(size, output_dir, progress, baseline)
    return _run(size, output_dir, progress, None)


def _run(size: str, output_dir: str | Path, progress, baseline: _Baseline | None
         ) -> list[Path]:
    setting = SIZES[size]
    steps, repeats = setting["steps"], setting["repeats"]
    names = [case[0] for case in CASES]
    cpu = {(c, v): [] for c in names for v in VARIANTS}
    base_cpu: dict[str, list[float]] = {c: [] for c in names}
    verdict = {c: np.inf for c in names}
    paths = {}
    follow: dict[str, list[float]] = {c: [] for c in names}
    base_follow: dict[str, list[float]] = {c: [] for c in names}
    followed: dict[str, tuple[float, np.ndarray, list[bool], int]] = {}
    for scene_name, key, start, stop in CASES:
        _track(scene_name, {key: np.linspace(start, stop, 3)}, VARIANTS[0])  # warm-up
        _tracker_run(scene_name, key, start, stop, 3)
    for repeat in range(repeats):
        if baseline is not None:
            if progress is not None:
                progress(repeat / repeats, f"tracking: baseline {baseline.commit[:7]} "
                         f"({repeat + 1}/{repeats})")
            for scene_name, seconds in baseline.run(steps).items():
                if scene_name.endswith(" tracker"):
                    base_follow[scene_name.removesuffix(" tracker")].append(seconds)
                else:
                    base_cpu[scene_name].append(seconds)
        for scene_name, key, start, stop in CASES:
            if progress is not None:
                progress(repeat / repeats, f"tracking: {scene_name}, tracker "
                         f"({repeat + 1}/{repeats})")
            seconds, judged, states, stable, count = _tracker_run(scene_name, key, start,
                                                                  stop, steps)
            if seconds <= min(follow[scene_name], default=np.inf):
                followed[scene_name] = judged, states, stable, count
            follow[scene_name].append(seconds)
            ramp = {key: np.linspace(start, stop, steps)}
            for variant in VARIANTS:
                if progress is not None:
                    progress(repeat / repeats, f"tracking: {scene_name}, {variant} "
                             f"({repeat + 1}/{repeats})")
                seconds, judged, path = _track(scene_name, ramp, variant)
                if not path.success:
                    raise RuntimeError(f"{scene_name}, {variant}: {path.message}")
                if variant == VARIANTS[0] and seconds <= min(cpu[scene_name, variant],
                                                             default=np.inf):
                    verdict[scene_name] = judged
                cpu[scene_name, variant].append(seconds)
                paths[scene_name, variant] = path
    floors = {c[0]: _tracker_floor(*c, steps) for c in CASES}
    best = {k: min(v) for k, v in cpu.items()}
    rate = {k: (steps - 1) / v for k, v in best.items()}
    difference = {c: float(np.max(np.abs(np.array(paths[c, VARIANTS[0]].states)
                                          - np.array(paths[c, VARIANTS[1]].states))))
                  for c in names}
    iterations = {k: int(sum(p.iterations)) for k, p in paths.items()}
    against = {}
    if baseline is not None:
        for c in names:
            best_base = min(base_cpu[c])
            ours = np.array(paths[c, VARIANTS[0]].states)
            theirs = baseline.states_of(c)
            against[c] = (best_base, (steps - 1) / best_base,
                          best_base / best[c, VARIANTS[0]],
                          float(np.max(np.abs(ours - theirs))) if ours.shape == theirs.shape
                          else float("nan"))
    ds = xr.Dataset(
        {"cpu": (("scene", "variant", "repeat"),
                 np.array([[cpu[c, v] for v in VARIANTS] for c in names]),
                 {"units": "s", "long_name": "CPU time of the whole track (cold step "
                  "included)"}),
         "steps_per_second": (("scene", "variant"),
                              np.array([[rate[c, v] for v in VARIANTS] for c in names]),
                              {"units": "1/s", "long_name": "steps per CPU second (best "
                               "repeat, the cold step included)"}),
         "verdict_cpu": ("scene", np.array([verdict[c] for c in names]),
                         {"units": "s", "long_name": "CPU time of the stability verdicts in "
                          "the best repeat of the shared model"}),
         "newton_iterations": (("scene", "variant"),
                               np.array([[float(iterations[c, v]) for v in VARIANTS]
                                         for c in names]),
                               {"units": "1", "long_name": "Newton and chord iterations "
                                "of the whole track"}),
         "largest_state_difference": ("scene", np.array([difference[c] for c in names]),
                                      {"units": "1", "long_name": "largest difference of a "
                                       "coordinate between the two variants' tracks"})},
        coords={"scene": ("scene", names, {"long_name": "scene tracked"}),
                "variant": ("variant", list(VARIANTS), {"long_name": "how each step's "
                                                         "model is made"}),
                "repeat": ("repeat", np.arange(repeats), {"long_name": "repeat"})})
    ds["tracker_cpu"] = (("scene", "repeat"), np.array([follow[c] for c in names]),
                         {"units": "s", "long_name": "CPU time of the Tracker's steps "
                          "(tracker.step at every value after the first; a verdict each)"})
    ds["tracker_steps_per_second"] = ("scene", np.array([(steps - 1) / min(follow[c])
                                                         for c in names]),
                                      {"units": "1/s", "long_name": "Tracker steps per CPU "
                                       "second (best repeat)"})
    ds["tracker_verdict_cpu"] = ("scene", np.array([followed[c][0] for c in names]),
                                 {"units": "s", "long_name": "CPU time of the Tracker's "
                                  "verdicts in its best repeat"})
    ds["tracker_iterations"] = ("scene", np.array([float(followed[c][3]) for c in names]),
                                {"units": "1", "long_name": "Newton and chord iterations of "
                                 "the Tracker's steps"})
    ds["tracker_floor"] = ("scene", np.array([floors[c][0] for c in names]),
                           {"units": "s", "long_name": "floor of a Tracker step: its "
                            "evaluations and factorisations at their raw costs"})
    ds["tracker_track_difference"] = (
        "scene", np.array([_difference(followed[c][1], paths[c, VARIANTS[0]].states)
                           for c in names]),
        {"units": "1", "long_name": "largest difference of a coordinate between the "
         "Tracker's and the track's (shared model) states"})
    if baseline is not None:
        ds["baseline_cpu"] = (("scene", "repeat"), np.array([base_cpu[c] for c in names]),
                              {"units": "s", "long_name": "CPU time of the whole track (shared "
                               "model) by the baseline revision's code",
                               "baseline_commit": baseline.commit})
        ds["baseline_state_difference"] = ("scene", np.array([against[c][3] for c in names]),
                                           {"units": "1", "long_name": "largest difference "
                                            "of a coordinate between this revision's and the "
                                            "baseline's tracks"})
    ds.attrs = {"title": "rodsim: tracking rate", "benchmark": "tracking", "size": size,
                "ramps": "; ".join(f"{c[0]}: {c[1]} {c[2]} -> {c[3]}, {steps} values"
                                   for c in CASES),
                **{f"machine_{k}": v for k, v in machine().items()}}
    output = Path(output_dir) / f"tracking-{size}.nc"
    write_dataset(ds, output)
    lines = [f"# Tracking, {steps} steps ({size}, best of {repeats}, CPU)", "",
             "| scene, ramp | each step's model | CPU [s] | steps/s | ms/step | verdict "
             "ms/step | iterations |", "|---|---|--:|--:|--:|--:|--:|"]
    for scene_name, key, start, stop in CASES:
        for v in VARIANTS:
            share = (f"{1e3 * verdict[scene_name] / (steps - 1):.2f}" if v == VARIANTS[0]
                     else "")
            lines.append(f"| {scene_name}, {key} {start:g} → {stop:g} N | {v} | "
                         f"{best[scene_name, v]:.3f} | {rate[scene_name, v]:.0f} | "
                         f"{1e3 / rate[scene_name, v]:.2f} | {share} | "
                         f"{iterations[scene_name, v]} |")
    lines += [""] + [f"{c}: ratio {rate[c, VARIANTS[0]] / rate[c, VARIANTS[1]]:.2f}×; "
                     f"largest difference between the two tracks' states: "
                     f"{difference[c]:.1e}." for c in names]
    if baseline is not None:
        lines += ["", f"Against the baseline {baseline.commit} (its code, the same tracks "
                  "and repeats, interleaved in this run; shared model):", "",
                  "| scene | baseline CPU [s] | baseline steps/s | this steps/s | speed-up | "
                  "largest state difference |", "|---|--:|--:|--:|--:|--:|"]
        for c in names:
            base_seconds, base_rate, ratio, moved = against[c]
            lines.append(f"| {c} | {base_seconds:.3f} | {base_rate:.0f} | "
                         f"{rate[c, VARIANTS[0]]:.0f} | {ratio:.2f}× | {moved:.1e} |")
    lines += _tracker_lines(steps, names, follow, followed, paths, baseline, base_follow,
                            floors)
    lines += ["", "Machine: " + ", ".join(f"{k} {v}" for k, v in machine().items())]
    table = output.with_suffix(".md")
    table.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return [output, table]


def _difference(states: np.ndarray, others: list[np.ndarray] | np.ndarray) -> float:
    """Largest difference of a coordinate between two runs' full states (NaN when their
    shapes differ)."""
    theirs = np.asarray(others)
    return (float(np.max(np.abs(states - theirs))) if states.shape == theirs.shape
            else float("nan"))


def _tracker_lines(steps: int, names: list[str], follow: dict[str, list[float]],
                   followed: dict[str, tuple[float, np.ndarray, list[bool], int]],
                   paths: dict, baseline: _Baseline | None,
                   base_follow: dict[str, list[float]],
                   floors: dict[str, tuple[float, dict[str, float]]]) -> list[str]:
    """The table of the Tracker's rates against their floors (and the baseline's rates, if
    any)."""
    lines = ["", f"`rodsim.Tracker` along the same ramps: built at the first value (not "
             f"timed), then `tracker.step` at each of the {steps - 1} others, a verdict at "
             "every step; CPU of the steps, best repeat. The floor is a step's evaluations "
             "and factorisations, counted in one more run, at their raw costs "
             "(`rodsim_bench.floor`); the verdict is apart:", "",
             "| scene | CPU [s] | steps/s | ms/step | verdict ms/step | floor ms/step | "
             "(step − verdict) / floor | F / F+∂F / ∂F alone / linear a step | iterations | "
             "unstable steps | largest difference from the track |",
             "|---|--:|--:|--:|--:|--:|--:|---|--:|--:|--:|"]
    for c in names:
        best = min(follow[c])
        judged, states, stable, count = followed[c]
        floor, counts = floors[c]
        lines.append(f"| {c} | {best:.3f} | {(steps - 1) / best:.0f} | "
                     f"{1e3 * best / (steps - 1):.2f} | {1e3 * judged / (steps - 1):.2f} | "
                     f"{1e3 * floor:.2f} | {(best - judged) / (steps - 1) / floor:.2f} | "
                     f"{counts.get('force', 0):.2f} / {counts.get('jacobian', 0):.2f} / "
                     f"{counts.get('jacobian_alone', 0):.2f} / "
                     f"{counts.get('linear', 0):.2f} | {count} | {stable.count(False)} | "
                     f"{_difference(states, paths[c, VARIANTS[0]].states):.1e} |")
    if baseline is None or not all(base_follow[c] for c in names):
        return lines
    lines += ["", f"The Tracker against the baseline {baseline.commit} (its code, the same "
              "steps, interleaved in this run):", "",
              "| scene | baseline steps/s | this steps/s | speed-up | same unstable steps | "
              "largest state difference |", "|---|--:|--:|--:|--:|--:|"]
    for c in names:
        best, base = min(follow[c]), min(base_follow[c])
        theirs = baseline.tracker_states_of(c)
        _, states, stable, _ = followed[c]
        same = "" if theirs is None else ("yes" if np.array_equal(np.array(stable), theirs[1])
                                          else "NO")
        moved = float("nan") if theirs is None else _difference(states, theirs[0])
        lines.append(f"| {c} | {(steps - 1) / base:.0f} | {(steps - 1) / best:.0f} | "
                     f"{base / best:.2f}× | {same} | {moved:.1e} |")
    return lines

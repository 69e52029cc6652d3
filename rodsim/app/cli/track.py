"""``rodsim track``: equilibria along an actuation path, each warm-started from the last."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from rodsim.app.cli.common import EXIT_OK, EXIT_SOLVER_FAILURE, UserError, warn
from rodsim.app.cli.pipeline import SceneCommand, execute

__all__ = ["cmd_track", "parsed_ramps"]


class Track(SceneCommand):
    """Solve a sequence of equilibria while scene values ramp together (--ramp, repeatable:
    every ramp needs the same COUNT); each step starts from the previous equilibrium, a
    failing step is retried with halved increments. Writes one archive with a `step`
    dimension and a figure (docs/inverse.md); a track that stops early (a failed or unstable
    step, Ctrl-C, SIGTERM) writes its finished steps, marked incomplete."""

    kind = "track"
    integrator_flag = True

    def prepare(self, scene: Any) -> None:
        self.ramps = parsed_ramps(self.args.ramp)  # before any folder or work

    def bad_input(self) -> tuple[type[Exception], ...]:
        from rodsim.core.scene import SceneError

        return (SceneError,)

    def solve(self, scene: Any, integrator: str, progress: Any) -> Any:
        from rodsim.app.inverse.track import track

        self.scene, self.integrator_used = scene, integrator
        return track(scene, self.ramps, integrator, progress=progress,
                     allow_unstable=self.args.allow_unstable)

    def failure(self, result: Any) -> str | None:
        if not result.steps:  # nothing finished: nothing written
            return f"rodsim: solver failure: {result.message}"
        return None

    def report(self, result: Any) -> None:
        scene = self.scene
        times = result.times
        warm = sum(times[1:]) / max(len(times) - 1, 1)
        last = result.steps - 1
        print(f"scene       {scene.name}: {result.steps} steps of "
              + ", ".join(f"{k.name} {result.values[0, i]:g} → {result.values[last, i]:g} "
                          f"{k.unit}" for i, k in enumerate(result.keys)))
        print(f"integrator  {self.integrator_used}")
        tip = result.tips()[-1]
        print(f"last tip    x = {tip[0]: .6f} m  y = {tip[1]: .6f} m  z = {tip[2]: .6f} m")
        speed = f" ({1.0 / warm:.0f} steps/s)" if warm > 0 else ""
        print(f"wall time   {sum(times):.4f} s: first step (cold) {times[0]:.4f} s, warm steps "
              f"{1e3 * warm:.3f} ms each{speed}, {int(sum(result.halvings))} halvings")
        unstable = result.unstable_steps
        if unstable:
            from rodsim.core.stability import eigenvalue_text

            print(f"stability   UNSTABLE at {len(unstable)} of {result.steps} steps (first: "
                  f"step {unstable[0]}, stiffness "
                  f"{eigenvalue_text(result.min_eigenvalues[unstable[0]])}); flagged in the "
                  "archive")
        else:
            print("stability   no unstable step (the stiffness K = -dF/dx positive definite, "
                  "or neutral: zero modes within its tolerance)")
        dead = result.dead_zone_steps
        if result.tension:
            print("dead zone   " + (f"{len(dead)} of {result.steps} steps (first: step "
                                    f"{dead[0]}): the termination tensions held while the "
                                    "ramp moved (backlash)" if dead else "none: every "
                                    "step moved a termination tension"))
        # Ctrl-C or SIGTERM while the steps' estimates are made: the archive is written
        # without them, then the command stops as interrupted (verdict).
        self.estimates_interrupted = print_last_step_trust(result)

    def verdict(self, result: Any) -> int:
        if getattr(self, "estimates_interrupted", False):
            raise KeyboardInterrupt
        if not result.success:  # stopped at a failed or unstable step: archived, a failure
            failure = "" if result.unstable_step is not None else "solver failure: "
            print(f"rodsim: {failure}{result.message}; the archive holds the {result.steps} "
                  "finished step(s), marked incomplete", file=sys.stderr)
            return EXIT_SOLVER_FAILURE
        unstable = result.unstable_steps
        if unstable:
            warn(f"{len(unstable)} step(s) are unstable equilibria (first: step {unstable[0]}); "
                 "kept because of --allow-unstable, flagged in the archive (variable 'stable')")
        return EXIT_OK


def parsed_ramps(texts: list[str]) -> dict[str, Any]:
    """The ``--ramp`` arguments as {key: values} (UserError, one line, for a bad one or a
    key named twice)."""
    from rodsim.app.inverse.track import parse_ramp
    from rodsim.core.scene import SceneError

    try:
        ramps = dict(parse_ramp(text) for text in texts)
    except SceneError as exc:
        raise UserError(str(exc)) from None
    if len(ramps) != len(texts):
        raise UserError("--ramp names the same key twice")
    return ramps


def cmd_track(args: argparse.Namespace) -> int:
    return execute(Track(args))


def make_step_estimates(track: Any) -> bool:
    """Estimate every step's errors from the companion paths (rodsim/app/inverse/
    track_estimates.py). True when Ctrl-C or SIGTERM stopped them (the track keeps none)."""
    from rodsim.app.inverse.track_estimates import estimate_steps

    try:
        estimate_steps(track)
    except KeyboardInterrupt:
        track.step_discretisation_error, track.step_penalty_error = [], []
        print("rodsim: interrupted while estimating the steps' errors; writing the archive "
              "without them", file=sys.stderr)
        return True
    return False


def print_step_estimates(track: Any) -> None:
    """Print the largest of each per-step estimate over the steps, and at which step."""
    import numpy as np

    from rodsim.app.discretisation import TRUST_WARNING

    for label, values in (("discretis.", track.step_discretisation_error),
                          ("penalty", track.step_penalty_error)):
        errors = np.asarray(values, dtype=float)
        if not errors.size:
            continue
        missing = int(np.sum(~np.isfinite(errors)))
        if missing == errors.size:
            print(f"{label:<11s} per step: no estimate (a companion path failed)")
            continue
        step = int(np.nanargmax(errors))
        line = f"{label:<11s} per step: largest error ≈ {errors[step]:.2g} L at step {step}"
        print(line + (f"; {missing} step(s) without an estimate" if missing else ""))
        if errors[step] > TRUST_WARNING:
            print(f"warning     {int(np.sum(errors > TRUST_WARNING))} step(s) above "
                  f"{TRUST_WARNING:g} L: the archive's per-step variable says which")


def print_last_step_trust(track: Any) -> bool:
    """Make every step's error estimates (``make_step_estimates``), then print the last
    step's and keep them on ``track`` for its archive: taken from the per-step estimates
    (one source, no re-solve; rodsim/app/inverse/track_estimates.py,
    ``last_step_estimates``), or, only when those could not be made, from a cold re-solve
    of the last step (rodsim/app/trust.py); then the largest per-step figures. True when
    an interrupt stopped the estimates."""
    from rodsim.app.inverse.track_estimates import last_step_estimates, last_step_text
    from rodsim.app.trust import compression_text

    if not track.steps:
        return False
    interrupted = make_step_estimates(track)
    if last_step_estimates(track):
        print(last_step_text(track))
        if track.tendon_compression:
            print(compression_text(track.tendon_compression))
    elif not interrupted:
        cold_last_step_trust(track)
    print_step_estimates(track)
    return interrupted


def cold_last_step_trust(track: Any) -> None:
    """The last step's estimates from a cold re-solve of it (rodsim/app/trust.py): what a
    track without per-step estimates (a model of no rods) gets."""
    from rodsim.app.trust import assess, compression_text, last_step_result

    last = last_step_result(track)
    if last is None:
        track.penalty_error = track.discretisation_error = float("nan")
        print("penalty     error estimates unavailable: the last step did not re-solve "
              "with the static integrator")
        return
    estimate = assess(last, model=track.last_model)  # with friction: that step's anchors
    track.penalty_error = last.penalty_error
    track.discretisation_error = last.discretisation_error
    track.tendon_compression = last.tendon_compression
    print(estimate.text("last step: "))
    if last.tendon_compression:
        print(compression_text(last.tendon_compression))

"""``rodsim batch``: the equilibria of many cases of one scene into one archive, resumably
(rodsim/app/batch.py; docs/batch.md)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rodsim.app.cli.common import (
    EXIT_OK,
    EXIT_SOLVER_FAILURE,
    UserError,
    check_integrator,
    load_scene_or_fail,
    output_path,
)
from rodsim.app.cli.study import study_status

__all__ = ["cmd_batch"]


def cmd_batch(args: argparse.Namespace) -> int:
    from rodsim.app.batch import solve_many
    from rodsim.app.batch_cases import checked_cases, read_cases_csv
    from rodsim.app.progress import ProgressPrinter
    from rodsim.app.study_parts import parts_folder
    from rodsim.app.study_spec import StudyError
    from rodsim.core.schema import SceneError
    from rodsim.io.input_file import InputError

    check_integrator(args.integrator)
    scene = load_scene_or_fail(args.scene, args.set, args.integrator)
    try:  # the whole table checked before anything is created or run
        cases = read_cases_csv(args.cases)
        checked_cases(scene, cases)
    except (SceneError, InputError) as exc:
        raise UserError(f"--cases {str(args.cases)[:80]}: {exc}") from None
    output = output_path(args.output, f"{scene.name}-batch.nc")
    printer = ProgressPrinter(delay=0.0)
    resumed: list[int] = []

    def progress(done: int, failed: int, total: int, elapsed: float) -> None:
        if not resumed:
            resumed.append(done)
        printer(done / total, study_status("batch", done, failed, total, elapsed,
                                           resumed[0]))

    def log(message: str) -> None:
        printer.close()
        print(f"rodsim: {message}", file=sys.stderr, flush=True)

    interrupted = False
    try:
        dataset = solve_many(scene, cases, args.integrator, output=output,
                             workers=args.workers, scheduler=args.scheduler,
                             chunk=args.chunk, progress=progress, log=log,
                             warm=args.warm, penalty=args.penalty)
    except (StudyError, SceneError) as exc:
        raise UserError(str(exc)) from None
    except KeyboardInterrupt:
        interrupted = True
        raise
    finally:
        printer.close()
        if interrupted and parts_folder(output).is_dir():
            print(f"rodsim: batch stopped; its finished cases are kept in "
                  f"{parts_folder(output)}: run the same command again to resume",
                  file=sys.stderr)
    failed = int(dataset.attrs["failed_cases"])
    print(f"batch       {scene.name}: {dataset.attrs['cases']} cases, {failed} failed")
    unstable = int((dataset["stable"] == 0).sum())
    if unstable:
        print(f"rodsim: warning: {unstable} case(s) are UNSTABLE equilibria (the archive's "
              "'stable' variable says which)", file=sys.stderr)
    print(f"archive     {Path(output)}")
    return EXIT_SOLVER_FAILURE if failed else EXIT_OK

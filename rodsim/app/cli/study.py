"""``rodsim study``: a shipped study over its grid into one archive, resumably."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from rodsim.app.cli.common import EXIT_OK, EXIT_SOLVER_FAILURE, UserError, output_path

__all__ = ["cmd_study", "estimate_lines", "study_status"]


def estimate_lines(dataset: Any) -> list[str]:
    """The study summary's error-estimate lines: for each of ``discretisation_error`` and
    ``penalty_error``, the largest over the points and the point where it is (NaN points
    counted: an estimate that could not be made), with the warning above 1e-3 L."""
    import numpy as np

    from rodsim.app.discretisation import TRUST_WARNING
    from rodsim.io.archive_schema import STATUS

    lines = []
    dims = [str(dim) for dim in dataset["status"].dims]
    for key, label in (("discretisation_error", "discretis."), ("penalty_error", "penalty")):
        if key not in dataset:
            continue
        values = np.asarray(dataset[key].values, dtype=float)
        ok = np.asarray(dataset["status"].values) == STATUS["ok"]
        missing = int(np.sum(ok & ~np.isfinite(values)))
        if not np.any(np.isfinite(values)):
            lines.append(f"{label:<11s} no estimate at any point")
            continue
        index = np.unravel_index(int(np.nanargmax(values)), values.shape)
        where = ", ".join(f"{dim}={_label(dataset[dim].values[i])}"
                          for dim, i in zip(dims, index, strict=True))
        line = f"{label:<11s} largest error ≈ {values[index]:.2g} L at {where}"
        if missing:
            line += f"; {missing} point(s) without an estimate"
        lines.append(line)
        above = int(np.sum(values > TRUST_WARNING))
        if above or missing:
            lines.append(f"warning     {key} above {TRUST_WARNING:g} L or missing at "
                         f"{above + missing} point(s): the archive's {key!r} variable says "
                         "which")
    return lines


def _label(value: Any) -> str:
    """A point's coordinate label as text."""
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def study_status(name: str, done: int, failed: int, total: int, elapsed: float,
                  resumed: int) -> str:
    """A study's progress line. The ETA comes from the points run in this session only
    (``done - resumed``): points kept from an interrupted run took no time here."""
    remaining = total - done
    ran = done - resumed
    eta = f", ETA {elapsed / ran * remaining:.0f} s" if ran > 0 and remaining else ""
    kept = f" ({resumed} kept from an earlier run)" if resumed else ""
    return f"{name}: {done}/{total} done{kept}, {failed} failed, {remaining} remaining{eta}"


def cmd_study(args: argparse.Namespace) -> int:
    from rodsim.app.progress import ProgressPrinter
    from rodsim.app.study import StudyError, available_studies, load_study
    from rodsim.app.study_runner import parts_folder, run_study
    from rodsim.io.archive import ArchiveError

    if args.name is None:
        for name, study in available_studies().items():
            print(f"{name:<12s} {study.title}")
        return EXIT_OK
    printer = ProgressPrinter(delay=0.0)
    resumed: list[int] = []  # points recorded before this session (the first call's count)

    def progress(done: int, failed: int, total: int, elapsed: float) -> None:
        if not resumed:
            resumed.append(done)
        printer(done / total if total else 1.0,
                study_status(args.name, done, failed, total, elapsed, resumed[0]))

    def log(message: str) -> None:
        printer.close()  # end an in-place progress line first
        print(f"rodsim: {message}", file=sys.stderr, flush=True)

    # SIGTERM stops a study as Ctrl-C does (rodsim.app.cli.main): finished points kept.
    interrupted = False
    output = ""
    try:
        study = load_study(args.name)
        output = str(output_path(args.output, f"{args.name}-{args.size}.nc"))
        dataset = run_study(study, args.size, output, workers=args.workers,
                            scheduler=args.scheduler, progress=progress, log=log,
                            worker_timeout=args.worker_timeout)
    except (StudyError, ArchiveError) as exc:
        raise UserError(str(exc)) from None
    except KeyboardInterrupt:
        interrupted = True
        raise
    finally:
        printer.close()
        if interrupted and output and parts_folder(output).is_dir():
            print(f"rodsim: study stopped; its finished points are kept in "
                  f"{parts_folder(output)}: run the same command again to resume",
                  file=sys.stderr)
    failed = int(dataset.attrs["failed_points"])
    print(f"study       {study.name} ({args.size}): {dataset.attrs['points']} points, "
          f"{failed} failed")
    for line in estimate_lines(dataset):
        print(line)
    unstable = int((dataset["stable"] == 0).sum()) if "stable" in dataset else 0
    if unstable:
        print(f"rodsim: warning: {unstable} point(s) of the study are UNSTABLE equilibria "
              "(the archive's 'stable' variable says which)", file=sys.stderr)
    print(f"archive     {output}")
    return EXIT_SOLVER_FAILURE if failed else EXIT_OK

"""``rodsim rerun``: solve an archive's scene again and compare with what it stores (a run,
a track, or the points of a study)."""

from __future__ import annotations

import argparse
import json
import sys

from rodsim.app.cli.common import EXIT_OK, EXIT_SOLVER_FAILURE, UserError
from rodsim.app.cli.run import print_run_summary

__all__ = ["cmd_rerun"]


def cmd_rerun(args: argparse.Namespace) -> int:
    from rodsim.app.api import rerun
    from rodsim.app.inverse.continuation import EquilibriumFailure
    from rodsim.app.inverse.path_record import path_solver
    from rodsim.app.study import StudyError
    from rodsim.core.scene import SceneError
    from rodsim.io.archive import ArchiveError, read_dataset

    try:
        dataset = read_dataset(args.archive)
        if "study" in dataset.attrs:
            return _rerun_study(dataset, args)
        if args.point:
            raise UserError("--point applies to study archives only")
        if dataset.attrs.get("kind") == "track":
            return _rerun_track(dataset, args)
        if dataset.attrs.get("kind") == "batch":
            return _rerun_batch(dataset, args)
        if dataset.attrs.get("kind") == "trajectory":
            raise UserError("a trajectory archive is not re-run (rerun compares equilibria): "
                            "run `rodsim simulate` again with its history's arguments")
        result, difference = rerun(dataset, path_solver(dataset))
    except (ArchiveError, SceneError, StudyError) as exc:
        raise UserError(f"{args.archive}: {exc}") from None
    except EquilibriumFailure as exc:  # a value of a fit's or reach's stored path
        print(f"rodsim: solver failure on rerun: {exc}", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    if not result.success:
        print(f"rodsim: solver failure on rerun: {result.message}", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    print_run_summary(result, None)
    length = max(shape.s[-1] for shape in result.rods.values())
    return rerun_verdict("positions", difference, length, args.tolerance)


def rerun_verdict(what: str, difference: float, length: float, tolerance: float) -> int:
    """Print the largest difference from the archive; exit 1 above ``tolerance`` × L."""
    print(f"rerun       largest difference from the stored {what}: {difference:.3g} m "
          f"({difference / length:.3g} L)")
    if difference > tolerance * length:
        print(f"rodsim: rerun differs from the archive by more than {tolerance:g} L",
              file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    return EXIT_OK


def _rerun_batch(dataset, args: argparse.Namespace) -> int:
    from rodsim.app.batch import rerun_batch

    again, difference = rerun_batch(dataset)
    print(f"batch       re-ran {again.attrs['cases']} cases, {again.attrs['failed_cases']} "
          "failed")
    length = float(again["s"].max())  # the longest rod's length
    return rerun_verdict("positions", difference, length, args.tolerance)


def _rerun_track(dataset, args: argparse.Namespace) -> int:
    from rodsim.app.inverse.track_rerun import rerun_track

    again, difference = rerun_track(dataset)
    if not again.success:
        print(f"rodsim: solver failure on rerun: {again.message}", file=sys.stderr)
        return EXIT_SOLVER_FAILURE
    print(f"track       {again.scene.name}: re-ran {again.steps} steps")
    if "slip_state" in dataset.variables:
        _slip_line(dataset["slip_state"].values, again.slip)
    length = max(rod.length for rod in again.model.rods.values())
    return rerun_verdict("centerlines", difference, length, args.tolerance)


def _slip_line(stored, slip: list) -> None:
    """How many of a track archive's stick/slip states (docs/tendon.md, "Friction") the
    re-run gives otherwise: a point exactly at its edge may flip with round-off, so this is
    told, not judged (the centerlines are)."""
    import numpy as np

    again = np.array(slip)[:len(stored)]
    differ = int(np.sum(again != stored)) if again.shape == stored.shape else stored.size
    print(f"rerun       stick/slip states: {differ} of {stored.size} differ from the stored")


def _rerun_study(dataset, args: argparse.Namespace) -> int:
    from rodsim.app.study import STATUS, rerun_study

    select: dict[str, str] = {}
    for item in args.point:
        key, sep, value = item.partition("=")
        if not sep:
            raise UserError(f"--point {item!r}: expected DIM=VALUE")
        key, value = key.strip(), value.strip()
        if key in select:
            raise UserError(f"--point {key}=… given twice ({select[key]} and {value}): a "
                            "point has one value per swept parameter")
        select[key] = value
    records, difference = rerun_study(dataset, select)
    failed = sum(r["status"] != STATUS["ok"] for r in records)
    length = float(json.loads(dataset.attrs["scene_json"])["rods"][
        str(dataset["rod"].values[0])]["length"])
    print(f"study       {dataset.attrs['study']} ({dataset.attrs['size']}): re-ran "
          f"{len(records)} point(s), {failed} failed")
    return rerun_verdict("centerlines", difference, length, args.tolerance)

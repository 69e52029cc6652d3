"""``rodsim compile``: fill numba's on-disk cache with every compiled kernel ahead of time
(rodsim/app/precompile.py), an optional step after installing."""

from __future__ import annotations

import argparse

from rodsim.app.cli.common import EXIT_OK, EXIT_SOLVER_FAILURE, UserError

__all__ = ["cmd_compile"]


def cmd_compile(args: argparse.Namespace) -> int:
    from rodsim.app.precompile import compile_kernels, compile_steps
    from rodsim.app.progress import ProgressPrinter

    try:
        compile_steps(args.scenes or None)  # an unknown scene: one line, before any work
    except ValueError as exc:
        raise UserError(str(exc)) from None
    printer = ProgressPrinter(delay=0.0)
    try:
        summary = compile_kernels(args.scenes or None, printer)
    finally:
        printer.close()
    print(summary.text())
    return EXIT_SOLVER_FAILURE if summary.failed else EXIT_OK

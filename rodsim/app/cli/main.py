"""The ``rodsim`` command: ``main`` (also called in process by the tests) and
``entry``, the installed command's whole process.

Human-readable summaries go to stdout, errors to stderr. Exit codes: 0 success, 1 solver
failure, 2 bad input (scene, option, path or archive), 130 interrupted (Ctrl-C or SIGTERM).
User errors never show a traceback.
"""

from __future__ import annotations

import argparse
import os
import shlex
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from typing import NoReturn

from rodsim.app.cli import common
from rodsim.app.cli.common import EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_OK, UserError
from rodsim.app.cli.parser import build_parser
from rodsim.app.threads import pin_threads

__all__ = ["main", "entry"]


def main(argv: Sequence[str] | None = None, *, process: bool = False) -> int:
    """The ``rodsim`` command. It pins BLAS threads (``rodsim.app.threads``) and, as it
    only writes figures to files, selects matplotlib's file backend unless ``MPLBACKEND`` is
    set — before anything imports numpy or matplotlib.

    ``process``: this call is the whole process (``entry``, the installed command and
    ``python -m rodsim``): a command of ``rodsim.app.lean.LEAN_COMMANDS``, or a study
    on local workers, then hides dask from xarray (``rodsim.app.lean.hides_dask``),
    and one of ``rodsim.app.lean.EARLY_EXIT_COMMANDS`` ends the process at once when it
    returns normally (``rodsim.app.lean``)."""
    pin_threads()
    os.environ.setdefault("MPLBACKEND", "Agg")
    parser = build_parser()
    args = parser.parse_args(argv)
    command: Callable[[argparse.Namespace], int] = args.func
    from rodsim.app.lean import EARLY_EXIT_COMMANDS, fast_exit, hide_dask, hides_dask
    from rodsim.io.provenance import invocation

    if process and hides_dask(args.command, getattr(args, "scheduler", None)):
        hide_dask()
    words = list(sys.argv[1:] if argv is None else argv)
    common.CREATED_FOLDERS.clear()
    previous = (signal.signal(signal.SIGTERM, _interrupt)  # SIGTERM stops as Ctrl-C does
                if threading.current_thread() is threading.main_thread() else None)
    try:
        with invocation(shlex.join(["rodsim", *words])):  # the archives' history line
            code = command(args)
        if process and args.command in EARLY_EXIT_COMMANDS:
            fast_exit(code)
        return code
    except UserError as exc:
        common.remove_created_output_folder()  # exit 2 leaves nothing behind, an empty runs/ too
        print(f"rodsim: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except MemoryError:  # beyond the estimate (rodsim.core.memory): still one line
        common.remove_created_output_folder()
        print("rodsim: error: out of memory (the process's limit or the machine's); lower "
              "rods.<rod>.nodes, or raise the limit (ulimit -v)", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:  # output piped into a closed reader (e.g. `| head`)
        sys.stderr.close()
        return EXIT_OK
    except KeyboardInterrupt:
        print("rodsim: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _interrupt(signum: int, frame: object) -> None:
    """SIGTERM handler of every command: stop as Ctrl-C does (what is finished and worth
    keeping is written, e.g. a track's steps; then "rodsim: interrupted", exit 130)."""
    raise KeyboardInterrupt


def entry() -> NoReturn:
    """The installed ``rodsim`` command and ``python -m rodsim``: ``main`` as the whole
    process."""
    sys.exit(main(process=True))

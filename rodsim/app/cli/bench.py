"""``rodsim bench``: a benchmark of the source checkout's benchmarks/ folder."""

from __future__ import annotations

import argparse

from rodsim.app.cli.common import EXIT_OK, UserError

__all__ = ["cmd_bench"]


def cmd_bench(args: argparse.Namespace) -> int:
    import importlib

    from rodsim.app.bench_locator import BenchmarksMissing, load_benchmarks, results_folder
    from rodsim.app.progress import ProgressPrinter
    from rodsim.io.output import OutputError, probe_folder

    try:
        package = load_benchmarks()
    except BenchmarksMissing as exc:
        raise UserError(str(exc)) from None
    if args.benchmark not in package.BENCHMARKS:
        raise UserError(f"no benchmark {args.benchmark!r}; the benchmarks are "
                        + ", ".join(package.BENCHMARKS))
    module = importlib.import_module(f"{package.__name__}.{args.benchmark.replace('-', '_')}")
    sizes = getattr(module, "SIZES", None)
    if args.size == "medium" and not (isinstance(sizes, dict) and "medium" in sizes):
        raise UserError(f"--size medium: {args.benchmark} has no medium size; allowed: "
                        "small or full")
    if args.output_dir is not None and args.commit:
        raise UserError("give either -o/--output or --commit, not both")
    output = results_folder(args.output_dir, args.commit)
    if output is None:
        raise UserError("--commit: no benchmarks/results folder of a source checkout to write "
                        "the benchmark's results to; give the output folder with -o/--output")
    if args.output_dir is None and not args.commit:
        try:
            output.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise UserError(f"cannot create the output folder {str(output)!r} "
                            f"({exc.strerror or exc}); give one with -o") from None
    try:  # before the benchmark runs, not after
        probe_folder(output, what=f"-o {output}")
    except OutputError as exc:
        raise UserError(str(exc)) from None
    printer = ProgressPrinter(delay=0.0)
    try:
        paths = module.run(args.size, output, printer)
    finally:
        printer.close()
    for path in paths:
        print(f"wrote       {path}")
    return EXIT_OK

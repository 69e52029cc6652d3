"""Benchmarks (``rodsim bench``): work-precision, adaptive against the paper integrator in
the paper's damping regime, scaling in N, the stability stress map, and
what skipping unneeded work buys, and the fast core (compiled kernels against the numpy
reference); what a user waits for around the solves: the whole-process CPU of short
commands (startup), the tracking rate (tracking) and a study on 1 and 2 workers
(workers).

Each benchmark is one module with ``run(size, output_dir, progress) -> list[Path]`` that
writes its numbers (a netCDF archive with the machine description in its attributes), its
figures and a markdown table under ``output_dir`` (default ``benchmarks/results``).
Timings on shared machines are noisy: compare the ratios measured within one run.
"""

BENCHMARKS = ("work-precision", "paper-regime", "scaling", "stress", "skip-work", "kernels",
              "pyelastica", "startup", "tracking", "workers")

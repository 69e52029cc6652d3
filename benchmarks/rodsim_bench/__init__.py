"""Benchmarks (``rodsim bench``): work-precision, adaptive against the paper integrator in
the paper's damping regime, scaling in N (and to N = 100 000), the stability stress map,
what skipping unneeded work buys, the fast core (compiled kernels against the numpy
reference), the string tendons' solves against their reference, contact, and a contact force
recovered from the shape (force-from-shape), a static solve against its floor (floor), the
exact iteration and step counts the tests bound with a margin (iterations); what a user
waits for around the solves: the whole-process CPU of short commands (startup), the tracking
rate (tracking), a study on 1 and 2 workers (workers), the natural frequencies of a
bent robot (modes), tendon friction's pull–release cycles and static solves (friction) and
many equilibria of one scene on 1 and 2 workers (batch); physical time's integrators at
equal tip accuracy, the midpoint rule against IDA (dynamics), PyElastica against rodsim in
physical time (pyelastica-dynamics), their CPU per step
(step-cost), tdcr-two-segment against the real-time aim (real-time) and its cost against
the time simulated (time-scaling); and hostile
command lines, each its own process, sorted into clear refusals, failures, checked
successes and defects (hostile).

Each benchmark is one module with ``run(size, output_dir, progress) -> list[Path]`` that
writes its numbers (a netCDF archive with the machine description in its attributes), its
figures and a markdown table under ``output_dir`` (``rodsim bench`` gives ``runs/bench`` of the
current folder by default, the committed ``benchmarks/results`` with ``--commit``).
Timings on shared machines are noisy: compare the ratios measured within one run.
"""

BENCHMARKS = ("work-precision", "paper-regime", "scaling", "large-n", "stress", "skip-work",
              "kernels", "pyelastica", "pyelastica-dynamics", "string-tendon", "contact",
              "force-from-shape", "floor",
              "iterations", "startup", "tracking", "workers", "modes", "friction",
              "batch", "dynamics", "step-cost", "real-time", "cvode-scaling", "time-scaling",
              "hostile")

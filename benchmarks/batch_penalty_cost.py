"""What a batch case's penalty estimate costs (issue 35 item 1): ``rodsim.solve_many`` on
``--cases`` random tdcr-two-segment cases of ``rodsim bench batch``, in this process, without
and with ``penalty=True``, alternated, best of ``--repeats``; CPU per case
(``time.process_time``) and their ratio. Checks on the way that the equilibria are the same
bit for bit. Prints one line.

    python benchmarks/batch_penalty_cost.py --cases 100
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent), str(HERE)]

import numpy as np  # noqa: E402

from rodsim.app.batch import solve_many  # noqa: E402
from rodsim_bench.batch import SCENE, random_cases  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    cases = random_cases(args.cases)
    solve_many(SCENE, random_cases(5, seed=1), penalty=True)  # imports, model, kernels
    plain, estimated = [], []
    for _ in range(args.repeats):
        start = time.process_time()
        a = solve_many(SCENE, cases)
        plain.append(time.process_time() - start)
        start = time.process_time()
        b = solve_many(SCENE, cases, penalty=True)
        estimated.append(time.process_time() - start)
        if not np.array_equal(a["position"].values, b["position"].values, equal_nan=True):
            raise SystemExit("the equilibria differ with penalty=True")
    without, with_ = min(plain) / args.cases * 1e3, min(estimated) / args.cases * 1e3
    errors = b["penalty_error"].values
    print(f"{args.cases} cases, best of {args.repeats}: {without:.2f} ms a case without the "
          f"estimate, {with_:.2f} ms with it ({with_ / without:.2f}x); penalty_error median "
          f"{np.nanmedian(errors):.3g} L, largest {np.nanmax(errors):.3g} L")


if __name__ == "__main__":
    main()

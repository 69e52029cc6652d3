"""A study at its small size: the paper's Fig. 7b (tip error against N) with the points run
on two worker processes, archived as one netCDF file and plotted from the archive alone.

Writes ``runs/examples/fig7b-small.nc`` and ``.png`` under the current folder. Run:
``python examples/03_study_small.py`` (about half a minute).
"""

from pathlib import Path

from rodsim.app.figures import plot_dataset
from rodsim.app.study import load_study
from rodsim.app.study_runner import run_study

folder = Path("runs") / "examples"
folder.mkdir(parents=True, exist_ok=True)
archive = folder / "fig7b-small.nc"
if __name__ == "__main__":  # the worker processes import this file again
    ds = run_study(load_study("fig7b"), "small", archive, workers=2)
    ok = ds.where(ds.status == 0)
    print(ok.tip_error.to_series())
    for path in plot_dataset(ds, folder / "fig7b-small", ["png"]):
        print("figure", path)

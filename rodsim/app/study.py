"""Studies: a base scene, swept parameters on a grid, and what to collect at each point.

A study is declared once (``studies/<name>.py`` defines ``STUDY``, a ``Study`` of
``Sweep`` s) and runs point by point: ``evaluate_point`` solves one grid point and
returns a small JSON-able record (what the runner persists as soon as the point finishes);
``assemble`` turns the records into one xarray Dataset with a dimension per swept
parameter. Centerlines of different N are compared on a common normalised arc-length grid
σ = s / L. Everything needed to re-run a point — the resolved base scene, the sweeps, the
integrator — is stored in the Dataset's attributes (``spec_json``), independent of the study
file that created it.

This module holds the declaration and the registry of shipped studies, and is the import
home of the names a user needs; the parts live beside it: the resolved spec and the grid
(``rodsim.app.study_spec``), the points (``rodsim.app.study_points``), their scoring
(``rodsim.app.scoring``), the parts folder (``rodsim.app.study_parts``), the runner
(``rodsim.app.study_runner``) and the archive's layout (``rodsim.io.study_dataset``).
"""

from __future__ import annotations

import importlib
import pkgutil
import re
from dataclasses import dataclass

from rodsim.app.study_points import assemble, evaluate_point, point_model, rerun_study
from rodsim.app.study_spec import (
    StudyError,
    StudySpec,
    Sweep,
    SweepSpec,
    grid_points,
    grid_shape,
    point_scene,
)
from rodsim.core.analytic.reference import REFERENCE_KINDS
from rodsim.core.scene import SceneError
from rodsim.io.archive_schema import STATUS

__all__ = ["Sweep", "Study", "StudySpec", "SweepSpec", "StudyError", "available_studies",
           "load_study", "evaluate_point", "assemble", "rerun_study", "STATUS", "grid_points",
           "grid_shape", "point_scene", "point_model"]


@dataclass(frozen=True)
class Study:
    """A study declaration (see the module docstring).

    Attributes
    ----------
    name, title
        Registry name (``rodsim study NAME``) and a one-line title.
    paper
        What the paper shows for it (figure number and claim), for docs and plots.
    scene
        Base scene: a shipped scene name or a path.
    integrator
        Integrator used at every point; ``None`` uses each point's ``solver.integrator``
        (so a sweep over that key compares integrators).
    sweeps
        ``{"small": [...], "full": [...]}``: the grid for each size.
    overrides
        Fixed ``key=value`` changes applied to the base scene.
    reference
        ``exact``, ``paper``, ``extensible`` or ``arc`` (analytic, per point), ``last`` (the
        last point along the first sweep, e.g. the finest N), or ``None``.
    plot
        Figure kind for ``rodsim plot`` (see rodsim/app/figures/plot.py).
    history
        Keep per-step history (tip and error against the reference per step: Fig. 8).
    sigma_points
        Samples of the common normalised arc-length grid.
    """

    name: str
    title: str
    paper: str
    scene: str
    integrator: str | None
    sweeps: dict[str, list[Sweep]]
    overrides: tuple[str, ...] = ()
    reference: str | None = None
    plot: str = "centerlines"
    history: bool = False
    sigma_points: int = 101

    def spec(self, size: str) -> StudySpec:
        """Everything a worker needs to run this study's points (JSON-able, picklable)."""
        if size not in self.sweeps:
            raise StudyError(f"study {self.name!r} has no size {size!r}; sizes: "
                             + ", ".join(self.sweeps))
        if self.reference is not None and self.reference not in (*REFERENCE_KINDS, "last"):
            raise StudyError(f"study {self.name!r}: unknown reference {self.reference!r}")
        from rodsim.app.api import load_scene

        try:
            scene = load_scene(self.scene, self.overrides)
        except SceneError as exc:
            raise StudyError(f"study {self.name!r}: {exc}") from None
        spec = StudySpec(
            name=self.name, title=self.title, paper=self.paper, size=size,
            integrator=self.integrator, reference=self.reference, plot=self.plot,
            history=self.history, sigma_points=self.sigma_points,
            base_scene_json=scene.to_json(), base_scene_toml=scene.source,
            sweeps=tuple(SweepSpec(s.name, s.key, s.values, s.units, s.long_name, s.labels)
                         for s in self.sweeps[size]))
        return StudySpec.from_json(spec.to_json())  # as it reads back: tuples become lists


def available_studies() -> dict[str, Study]:
    """Every study shipped in ``studies/`` (installed as the package ``rodsim.studies``)."""
    import rodsim.studies as package

    found = {}
    for module in pkgutil.iter_modules(package.__path__):
        if module.name.startswith("_"):
            continue
        study = getattr(importlib.import_module(f"rodsim.studies.{module.name}"), "STUDY", None)
        if isinstance(study, Study):
            found[study.name] = study
    return dict(sorted(found.items(), key=lambda item: natural_key(item[0])))


def natural_key(name: str) -> tuple[tuple[int, int | str], ...]:
    """Sort key ordering the numbers within names by value: fig6 before fig22."""
    return tuple((0, int(part)) if part.isdigit() else (1, part)
                 for part in re.split(r"(\d+)", name) if part)


def load_study(name: str) -> Study:
    """A shipped study by name (StudyError listing the available ones otherwise)."""
    studies = available_studies()
    if name not in studies:
        raise StudyError(f"unknown study {name!r}; available: {', '.join(studies)}")
    return studies[name]

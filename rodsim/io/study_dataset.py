"""The study archive's layout: one Dataset for a whole study, a dimension per swept
parameter, built from the points' records (docs/archive.md, "Study archives"). The run
archive's layout is ``rodsim.io.run_dataset``; the study's declaration, grid and
evaluation are the app's (``rodsim.app.study``), which hands this module its resolved
spec (a ``rodsim.app.study_spec.StudySpec``; io does not import the app) and the
records."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from rodsim.core.analytic.reference import REFERENCE_KINDS
from rodsim.io.archive_schema import ERROR_ESTIMATES, SCHEMA_VERSION, STATUS
from rodsim.io.provenance import archive_attributes
from rodsim.io.run_dataset import step_coordinate
from rodsim.io.statistics import POINT_STAT_DOCS, POINT_STATS

__all__ = ["study_dataset"]


def study_dataset(spec: Any, records: list[dict[str, Any]], call: str) -> xr.Dataset:
    """One Dataset for the whole study from one record per grid point (every point has one:
    the caller checks). ``spec`` is the resolved study (its sweeps, reference, history,
    σ samples, names and stored scene are read); ``call`` is the history's words for the
    call that built it."""
    shape = tuple(len(s.values) for s in spec.sweeps)
    dims = tuple(s.name for s in spec.sweeps)
    by_index = {tuple(r["index"]): r for r in records}
    ok = [r for r in records if "tip" in r]
    rods = list(ok[0]["tip"]) if ok else spec.rod_names
    sigma = np.linspace(0.0, 1.0, spec.sigma_points)

    def grid(fill: Any, tail: tuple[int, ...] = (), dtype: Any = float) -> np.ndarray:
        return np.full(shape + tail, fill, dtype=dtype)

    status = grid(STATUS["error"], dtype=np.int8)
    message = grid("", dtype=object)
    # Errors only against a reference: a study without one stores no error variables.
    errors = ("tip_error", "area_error") if spec.reference in REFERENCE_KINDS else ()
    verdicts = ("stable", "stiffness_min_eigenvalue")
    # The points' error estimates, when the records hold them (those of an older rodsim
    # resumed from a parts folder do not: NaN there).
    estimates = tuple(k for k in ERROR_ESTIMATES if any(k in r for r in records))
    scalars = {k: grid(np.nan) for k in ("residual", "quaternion_norm_error", *errors,
                                         *verdicts, *estimates, *POINT_STATS)}
    tip = grid(np.nan, (len(rods), 3))
    centerline = grid(np.nan, (len(rods), len(sigma), 3))
    steps = max((len(r.get("history_time", [])) for r in records), default=0)
    history = {"history_time": grid(np.nan, (steps,)), "history_error": grid(np.nan, (steps,)),
               "history_tip": grid(np.nan, (steps, 3))}
    for index, r in by_index.items():
        status[index], message[index] = r["status"], r["message"]
        for key in ("residual", "quaternion_norm_error", *errors, *verdicts, *estimates):
            if key in r:
                scalars[key][index] = r[key]
        for key in POINT_STATS:
            if "stats" in r:
                scalars[key][index] = r["stats"][key]
        if "tip" not in r:
            continue
        for k, rod in enumerate(rods):
            tip[index + (k,)] = r["tip"][rod]
            centerline[index + (k,)] = r["centerline"][rod]
        for key, array in history.items():
            values = np.asarray(r.get(key, []), dtype=float)
            if len(values):
                array[index + (slice(0, len(values)),)] = values
    data_vars: dict[str, Any] = {
        "status": (dims, status, {"units": "1", "long_name": "point status",
                                  "flag_values": np.array(list(STATUS.values()), dtype=np.int8),
                                  "flag_meanings": " ".join(STATUS)}),
        # Text has no units (CF): string variables and coordinates carry long_name only.
        "message": (dims, message.astype(str),
                    {"long_name": "solver message of the point, or why it failed"}),
        "tip": (dims + ("rod", "axis"), tip, {"units": "m", "long_name": "tip position"}),
        "centerline": (dims + ("rod", "sigma", "axis"), centerline,
                       {"units": "m", "long_name": "centerline at normalised arc length"}),
    }
    docs = {
        "residual": ("1", "final scaled force residual"),
        "quaternion_norm_error": ("1", "largest | |q| - 1 |"),
        "stable": ("1", "1 if the point's equilibrium is stable, 0 if not (NaN: failed point "
                        "or no verdict)"),
        "stiffness_min_eigenvalue": ("1", "smallest eigenvalue of the stiffness at an unstable "
                                          "point (NaN where stable)"),
        "tip_error": ("1", f"tip distance to the {spec.reference} reference / L"),
        "area_error": ("m", f"area between the centerline and the {spec.reference} "
                            "reference / L (Fig. 21)"),
        "discretisation_error": ("1", "estimated discretisation error of the point's "
                                 "equilibrium / L (as rodsim run's; NaN: failed point or none)"),
        "penalty_error": ("1", "estimated penalty error of the point's equilibrium / L (as "
                          "rodsim run's; NaN: failed point or none)"),
        **POINT_STAT_DOCS,
    }
    for key, values in scalars.items():
        units, long_name = docs[key]
        data_vars[key] = (dims, values, {"units": units, "long_name": long_name})
    if spec.history:
        data_vars["history_time"] = (dims + ("step",), history["history_time"],
                                     {"units": "s", "long_name": "pseudo-time after each step"})
        data_vars["history_tip"] = (dims + ("step", "axis"), history["history_tip"],
                                    {"units": "m", "long_name": "tip after each step"})
        if errors:
            data_vars["history_error"] = (
                dims + ("step",), history["history_error"],
                {"units": "1", "long_name": f"tip distance to the {spec.reference} "
                 "reference / L after each step"})
    coords: dict[str, Any] = {
        "rod": ("rod", rods, {"long_name": "rod"}),
        "sigma": ("sigma", sigma, {"units": "1", "long_name": "normalised rest arc length s/L"}),
        "axis": ("axis", ["x", "y", "z"], {"long_name": "world axis"}),
    }
    for s in spec.sweeps:
        labels = np.asarray(s.coordinate)
        key = s.key if isinstance(s.key, str) else ", ".join(s.key)
        attrs = {"units": s.units, "long_name": s.long_name or key, "scene_key": key}
        if not np.issubdtype(labels.dtype, np.number):  # names ("corde", "on"): no units
            del attrs["units"]
        coords[s.name] = (s.name, labels, attrs)
    if spec.history:
        coords.update(step_coordinate(steps))
    ds = xr.Dataset(data_vars, coords)
    ds.attrs.update({
        "title": f"rodsim study {spec.name}: {spec.title}",
        **archive_attributes(call),
        "study": spec.name, "size": spec.size, "paper": spec.paper,
        "integrator": str(spec.integrator or "per point (solver.integrator)"),
        "reference": str(spec.reference),
        "plot": spec.plot, "spec_json": spec.to_json(),
        "scene_json": spec.base_scene_json, "scene_toml": spec.base_scene_toml,
        "schema_version": SCHEMA_VERSION,
        "points": int(np.prod(shape)), "failed_points": int(np.sum(status != STATUS["ok"])),
    })
    return ds

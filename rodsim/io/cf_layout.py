"""The file layout of a schema 3 archive (docs/archive.md, "Labels and names in the file"),
and the names of the variables that hold scene values.

In memory a rodsim archive Dataset labels its small dimensions with text (``axis`` = x, y,
z; ``component`` = q1 … q4; a study's ``rod`` and named sweep values), so that
``ds.sel(axis="y")`` works. CF (and its checker) wants coordinate variables to be numeric,
and text as character arrays. So ``to_file`` (called by ``write_dataset``) stores each
text dimension coordinate ``d`` as a numeric index 0, 1, … with the labels in an auxiliary
coordinate ``d_label`` (attribute ``label_variable`` on ``d`` names it), and every text
variable as a character array; ``from_file`` (called by ``read_dataset``) puts the
labels back as the dimension's coordinate. Archives of schemas 1 and 2 have text coordinates
and are read as they are.

Scene keys are dotted (``tendons.tendon.tendon_actuation.force``), which CF does not allow
in a variable name (§2.3: letters, digits and underscores): ``variable_name`` is the
name of the variable holding a key's values in track, fit and reach archives, and the
variable's ``scene_key`` attribute keeps the key (``key_variable`` finds it in any
schema).
"""

from __future__ import annotations

import re
from collections.abc import Hashable
from typing import TYPE_CHECKING, Any

import numpy as np

from rodsim.io.archive_content import ArchiveContent, is_text

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["variable_name", "key_variable", "file_layout", "to_file", "from_file",
           "LABEL_ATTRIBUTE"]

#: Attribute of a numeric index coordinate naming its label variable.
LABEL_ATTRIBUTE = "label_variable"


def variable_name(key: str) -> str:
    """A CF-valid variable name for scene key ``key``: every run of characters other than
    letters, digits and underscores becomes one underscore
    (``rods.catheter.tip_load.force[0]`` → ``rods_catheter_tip_load_force_0``)."""
    name = re.sub(r"[^A-Za-z0-9_]+", "_", key).strip("_")
    return name if name[:1].isalpha() else f"v_{name}"


def key_variable(ds: xr.Dataset, key: str, suffix: str = "") -> xr.DataArray:
    """The variable of scene key ``key`` (plus ``suffix``: ``initial``, ``standard_error``)
    in an archive of any schema: named by ``variable_name`` since schema 3, by the
    dotted key before (``key.suffix``). KeyError if neither is there."""
    for name in (variable_name(key) + (f"_{suffix}" if suffix else ""),
                 key + (f".{suffix}" if suffix else "")):
        if name in ds.variables:
            return ds[name]
    raise KeyError(key)


def file_layout(content: ArchiveContent) -> ArchiveContent:
    """The content as a schema 3 file holds it: each text dimension coordinate ``d``
    replaced by the numeric index 0, 1, … (int32, attribute ``LABEL_ATTRIBUTE``) and
    the labels in the coordinate ``d_label`` beside it (ValueError if that name is taken).
    Text stays text here; the writers store it as characters."""
    sizes = content.sizes()
    coords = dict(content.coords)
    for dim in sizes:
        if dim not in coords or coords[dim][0] != (dim,) or not is_text(coords[dim][1]):
            continue
        label = f"{dim}_label"
        if label in content.variables:
            raise ValueError(f"cannot label dimension {dim!r}: variable {label!r} exists")
        _, values, attrs = coords.pop(dim)
        long_name = attrs.get("long_name", dim)
        coords[dim] = ((dim,), np.arange(sizes[dim], dtype=np.int32),
                       {"long_name": f"index of {long_name}", "units": "1",
                        LABEL_ATTRIBUTE: label})
        coords[label] = ((dim,), values.astype(str), {**attrs, "long_name": long_name})
    return ArchiveContent(dict(content.data_vars), coords, dict(content.attrs))


def to_file(ds: xr.Dataset) -> tuple[xr.Dataset, dict[Hashable, dict[str, Any]]]:
    """The Dataset as a schema 3 file holds it (``file_layout``; the variables keep
    their encodings), and the encoding for ``to_netcdf`` (text as character arrays; no
    _FillValue on any coordinate)."""
    out = file_layout(ArchiveContent.of(ds)).to_xarray()
    for name in out.variables:
        if name in ds.variables:
            out[name].encoding = dict(ds[name].encoding)
    encoding: dict[Hashable, dict[str, Any]] = {name: {"_FillValue": None}
                                                for name in out.coords}
    for name, variable in out.variables.items():
        if is_text(variable.values):
            encoding.setdefault(name, {})["dtype"] = "S1"
    return out, encoding


def from_file(ds: xr.Dataset) -> xr.Dataset:
    """The in-memory Dataset of a file written by ``to_file``: each labelled index
    coordinate replaced by its labels (a Dataset without labelled indices is returned as
    it is)."""
    for dim in list(ds.dims):
        if dim not in ds.coords:
            continue
        label = ds[dim].attrs.get(LABEL_ATTRIBUTE)
        if not isinstance(label, str) or label not in ds.variables or ds[label].dims != (dim,):
            continue
        attrs = dict(ds[label].attrs)
        values = ds[label].values.astype(str)
        ds = ds.drop_vars([dim, label]).assign_coords({dim: (dim, values, attrs)})
    return ds

"""Write an archive's content (``rodsim.io.archive_content.ArchiveContent``) to a
netCDF-4 file with the netCDF4 library alone, as xarray's ``to_netcdf`` writes a schema 3
archive (docs/archive.md): so that ``rodsim run`` needs neither xarray nor pandas.

The conventions it follows are xarray's, so that a file written here and one written by
``Dataset.to_netcdf`` with ``rodsim.io.cf_layout.to_file``'s encoding read back the
same (tests/test_netcdf_writer.py compares the two, variable by variable and attribute by
attribute):

- floating-point data variables carry ``_FillValue`` = NaN, coordinates none;
- text is stored as characters (``S1``) along a dimension ``string<n>``, n the longest
  value's UTF-8 length (at least 1), with the attribute ``_Encoding`` = ``utf-8``;
- booleans are stored as int8 with the attribute ``dtype`` = ``bool``;
- a data variable lists, in its ``coordinates`` attribute (sorted), the coordinates that
  are not dimensions and whose dimensions are all its own; the other such coordinates are
  listed in the global ``coordinates`` attribute;
- attributes: Python int as int64, float as float64, lists as arrays, text as it is.

No compression, contiguous storage. The caller writes to a temporary file and renames it
(``rodsim.io.archive.write_content``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from rodsim.io.archive_content import ArchiveContent, is_text

__all__ = ["write_netcdf"]


def write_netcdf(content: ArchiveContent, path: Path) -> None:
    """Write ``content`` (already in its file layout) to the netCDF-4 file ``path``."""
    import netCDF4

    sizes = content.sizes()
    attached: set[str] = set()
    with netCDF4.Dataset(path, "w", format="NETCDF4") as handle:
        handle.set_auto_maskandscale(False)
        for name, (dims, values, attrs) in content.variables.items():
            extra: dict[str, Any] = {}
            if name in content.data_vars:
                listed = sorted(c for c, (cdims, _, _) in content.coords.items()
                                if c not in sizes and set(cdims) <= set(dims))
                attached.update(listed)
                if listed:
                    extra["coordinates"] = " ".join(listed)
            _write_variable(handle, name, dims, values, attrs, extra,
                            coordinate=name in content.coords)
        loose = sorted(c for c in content.coords if c not in sizes and c not in attached)
        for key, value in content.attrs.items():
            handle.setncattr(key, _attribute(value))
        if loose:
            handle.setncattr("coordinates", " ".join(loose))


def _dimension(handle: Any, name: str, size: int) -> None:
    if name not in handle.dimensions:
        handle.createDimension(name, size)


def _write_variable(handle: Any, name: str, dims: tuple[str, ...], values: np.ndarray,
                    attrs: dict[str, Any], extra: dict[str, Any], coordinate: bool) -> None:
    encoding: dict[str, Any] = {}
    if is_text(values):
        encoded = np.vectorize(lambda v: str(v).encode("utf-8"), otypes=[object])(values) \
            if values.size else values.astype(bytes)
        width = max([1, *(len(v) for v in encoded.flat)])
        stored = np.asarray(encoded, dtype=f"S{width}")
        characters = stored.view("S1").reshape(*values.shape, width)
        string_dim = f"string{width}"
        _dimension(handle, string_dim, width)
        for dim, size in zip(dims, values.shape, strict=True):
            _dimension(handle, dim, size)
        variable = handle.createVariable(name, "S1", (*dims, string_dim), fill_value=None)
        encoding["_Encoding"] = "utf-8"
        data: np.ndarray = characters
    else:
        if values.dtype.kind == "b":
            data = values.astype(np.int8)
            encoding["dtype"] = "bool"
        elif values.dtype.kind in "iuf":
            data = values
        else:
            raise TypeError(f"variable {name!r}: cannot store values of type {values.dtype}")
        for dim, size in zip(dims, values.shape, strict=True):
            _dimension(handle, dim, size)
        fill = np.nan if data.dtype.kind == "f" and not coordinate else None
        variable = handle.createVariable(name, data.dtype, dims, fill_value=fill)
    for key, value in {**attrs, **encoding, **extra}.items():
        variable.setncattr(key, _attribute(value))
    if data.ndim == 0:
        variable.assignValue(data)
    elif data.size:
        variable[...] = data


def _attribute(value: Any) -> Any:
    """An attribute value as xarray stores it."""
    if isinstance(value, bool) or isinstance(value, np.bool_):
        raise TypeError(f"attribute value {value!r}: booleans are not netCDF attributes")
    if isinstance(value, int):
        return np.int64(value)
    if isinstance(value, float):
        return np.float64(value)
    if isinstance(value, list | tuple):
        return np.asarray(value)
    return value

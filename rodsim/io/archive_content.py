"""An archive's content as plain numpy values: what an xarray Dataset of a rodsim archive
holds, without xarray.

``rodsim run`` builds its archive, lays it out for the file (``rodsim.io.cf_layout.
file_layout``) and writes it (``rodsim.io.netcdf_writer``) without importing xarray and
pandas (0.28 s of CPU of a 1 s command, docs/benchmark-history.md "Start-up"); the Python API
(``rodsim.run_dataset``) turns the same content into the Dataset with
``ArchiveContent.to_xarray``. A variable is ``(dims, values, attrs)``, as xarray's own
constructor takes it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["ArchiveContent", "Variable", "VariableLike", "is_text"]

#: A variable: its dimension names, values and attributes.
Variable = tuple[tuple[str, ...], np.ndarray, dict[str, Any]]
#: A variable as :class:`ArchiveContent` takes it (as xarray's constructor does): one
#: dimension's name or a sequence of names, values of any array-like form, and attributes
#: (optional).
VariableLike = (tuple[str | Sequence[str], ArrayLike]
                | tuple[str | Sequence[str], ArrayLike, Mapping[str, Any]])


def is_text(values: np.ndarray) -> bool:
    """Whether ``values`` hold text (unicode or bytes, or objects that are all str)."""
    return values.dtype.kind in "US" or (values.dtype.kind == "O" and values.size > 0
                                        and all(isinstance(v, str) for v in values.flat))


@dataclass(init=False)
class ArchiveContent:
    """Data variables, coordinates and global attributes of an archive, in the order they
    were added (a file keeps that order). The variables are taken in any
    ``VariableLike`` form and held as ``Variable``."""

    data_vars: dict[str, Variable]
    coords: dict[str, Variable]
    attrs: dict[str, Any]

    def __init__(self, data_vars: Mapping[str, VariableLike] | None = None,
                 coords: Mapping[str, VariableLike] | None = None,
                 attrs: dict[str, Any] | None = None) -> None:
        self.data_vars = {name: _variable(v) for name, v in (data_vars or {}).items()}
        self.coords = {name: _variable(v) for name, v in (coords or {}).items()}
        self.attrs = attrs if attrs is not None else {}

    @property
    def variables(self) -> dict[str, Variable]:
        """Every variable, data variables first."""
        return {**self.data_vars, **self.coords}

    def sizes(self) -> dict[str, int]:
        """The length of each dimension (ValueError when two variables disagree)."""
        out: dict[str, int] = {}
        for name, (dims, values, _) in self.variables.items():
            if len(dims) != values.ndim:
                raise ValueError(f"variable {name!r}: {values.ndim} dimensions, named {dims}")
            for dim, size in zip(dims, values.shape, strict=True):
                if out.setdefault(dim, size) != size:
                    raise ValueError(f"dimension {dim!r}: length {size} in {name!r}, "
                                     f"{out[dim]} elsewhere")
        return out

    def to_xarray(self) -> xr.Dataset:
        """The xarray Dataset of this content."""
        import xarray as xr

        return xr.Dataset(data_vars=self.data_vars, coords=self.coords, attrs=self.attrs)

    @classmethod
    def of(cls, dataset: xr.Dataset) -> ArchiveContent:
        """The content of an xarray Dataset (values read into memory)."""
        def plain(name: Any) -> Variable:
            variable = dataset.variables[name]
            return tuple(str(d) for d in variable.dims), np.asarray(variable.values), dict(
                variable.attrs)

        return cls({str(n): plain(n) for n in dataset.data_vars},
                   {str(n): plain(n) for n in dataset.coords}, dict(dataset.attrs))


def _variable(variable: VariableLike) -> Variable:
    dims, values, *rest = variable
    dims = (dims,) if isinstance(dims, str) else tuple(dims)
    return dims, np.asarray(values), dict(rest[0]) if rest else {}

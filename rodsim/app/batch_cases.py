"""A batch's cases (``rodsim.solve_many``, ``rodsim batch``): a table of scene values, one
column per numeric scene key (as ``track`` ramps them, rodsim/app/inverse/parameter_keys.py)
and one row per case, read from a mapping, an xarray Dataset, a pandas DataFrame (read by
its columns; pandas is never imported here) or a CSV file, and checked in full before any
case runs: every key a numeric model parameter, every value a finite number in its declared
range, and, for values that take part in a rule across tables (a radius against a length, a
lumen offset inside the radii), every case's scene valid. A bad table is refused with a
one-line ``rodsim.core.schema.SceneError`` naming the case and the key.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from rodsim.app.inverse.parameter_keys import NumericKey, _local, numeric_keys, scene_with
from rodsim.core.scene import Scene, cross_table_culprit
from rodsim.core.schema import SceneError
from rodsim.io.input_file import check_input_file

__all__ = ["MAX_CASES", "MAX_CASES_BYTES", "case_columns", "read_cases_csv", "checked_cases"]

#: Most cases of one batch (a million tdcr-two-segment equilibria are 3.4 GB of archive).
MAX_CASES = 1_000_000
#: Largest cases CSV read [bytes].
MAX_CASES_BYTES = 256 * 1024 ** 2


def case_columns(cases: Any) -> dict[str, Any]:
    """The table's columns, key → values: a mapping as it is, an xarray Dataset's data
    variables, a pandas DataFrame's columns (SceneError for anything else)."""
    if isinstance(cases, Mapping):
        return {str(key): column for key, column in cases.items()}
    if hasattr(cases, "data_vars"):  # an xarray Dataset
        return {str(name): cases[name].values for name in cases.data_vars}
    if hasattr(cases, "columns") and hasattr(cases, "to_numpy"):  # a pandas DataFrame
        return {str(name): cases[name].to_numpy() for name in cases.columns}
    raise SceneError("cases must map scene keys to arrays of values (a dict, an xarray "
                     f"Dataset or a pandas DataFrame), got {type(cases).__name__}")


def _column(key: str, column: Any) -> np.ndarray:
    """One column as floats; SceneError naming the first case that is not a number or is
    missing (NaN, an empty cell, None)."""
    if isinstance(column, (str, bytes)) or np.ndim(column) != 1:
        raise SceneError(f"cases {key[:60]!r}: expected a flat list of numbers, one per case")
    values = np.empty(len(column))
    for case, value in enumerate(column):
        if value is None or (isinstance(value, str) and not value.strip()):
            raise SceneError(f"cases {key[:60]!r}: case {case} has no value")
        if isinstance(value, (bool, np.bool_)):
            raise SceneError(f"cases {key[:60]!r}: case {case} is {value}, not a number")
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise SceneError(f"cases {key[:60]!r}: case {case} is {str(value)[:40]!r}, not a "
                             "number") from None
        if math.isnan(number):
            raise SceneError(f"cases {key[:60]!r}: case {case} has no value (NaN)")
        if math.isinf(number):
            raise SceneError(f"cases {key[:60]!r}: case {case} is {number}, not a finite "
                             "number")
        values[case] = number
    return values


def checked_cases(scene: Scene, cases: Any) -> tuple[list[NumericKey], np.ndarray]:
    """The keys and the (cases, keys) values of a cases table, every case checked against
    the scene's declarations and rules across tables (module docstring); SceneError."""
    columns = case_columns(cases)
    if not columns:
        raise SceneError("cases name no scene key")
    values = [_column(key, column) for key, column in columns.items()]
    lengths = {len(v) for v in values}
    if len(lengths) != 1:
        raise SceneError("every column of the cases needs the same number of values, got "
                         + ", ".join(f"{k[:30]}: {len(v)}" for k, v in zip(
                             columns, values, strict=True)))
    count = lengths.pop()
    if count == 0:
        raise SceneError("the cases table is empty (no case)")
    if count > MAX_CASES:
        raise SceneError(f"{count} cases, more than the {MAX_CASES} allowed in one batch")
    keys = numeric_keys(scene, list(columns))
    table = np.column_stack(values)
    for column, key in enumerate(keys):
        low, high = key.bounds()
        outside = np.flatnonzero((table[:, column] < low) | (table[:, column] > high))
        if outside.size:
            case = int(outside[0])
            raise SceneError(f"case {case}: {key.name} = {table[case, column]:g} is out of "
                             f"range; allowed: {key.parameter.allowed}")
    if not all(_local(key) for key in keys):
        for case, row in enumerate(table):
            try:
                scene_with(scene, keys, row)
            except SceneError as exc:
                found = cross_table_culprit(exc, [k.path for k in keys if k.index is None])
                if found is None:
                    raise SceneError(f"case {case}: {exc}") from None
                column = next(k for k, key in enumerate(keys) if key.path == found[0])
                raise SceneError(f"case {case}: {keys[column].name} = "
                                 f"{table[case, column]:g}, which {found[1]}") from None
    return keys, table


def read_cases_csv(path: str | Path) -> dict[str, list[str]]:
    """The columns of a cases CSV (a header of scene keys, one row per case; a UTF-8
    byte-order mark is read), as text for ``checked_cases``. InputError for a path that
    is not a regular file of at most ``MAX_CASES_BYTES``, SceneError for a table that
    is not one (no header, a row of another width)."""
    checked = check_input_file(path, "cases table", MAX_CASES_BYTES)
    try:
        text = checked.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise SceneError(f"cases table {str(path)[:80]!r}: not UTF-8 text") from None
    rows = [row for row in csv.reader(io.StringIO(text)) if any(c.strip() for c in row)]
    if not rows:
        raise SceneError(f"cases table {str(path)[:80]!r} is empty (expected a header of "
                         "scene keys, then one row per case)")
    header = [cell.strip() for cell in rows[0]]
    if any(not cell for cell in header) or len(set(header)) != len(header):
        raise SceneError(f"cases table {str(path)[:80]!r}: the header must name distinct "
                         "scene keys, one per column")
    columns: dict[str, list[str]] = {key: [] for key in header}
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise SceneError(f"cases table {str(path)[:80]!r}, row {line}: {len(row)} "
                             f"values for {len(header)} columns")
        for key, cell in zip(header, row, strict=True):
            columns[key].append(cell)
    return columns

"""The argparse types of the commands' arguments: numbers and vectors checked as they are
read, so that a bad value is a one-line usage error (exit 2) naming what was expected."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from typing import TypeVar

__all__ = ["add_scene_set_and_output", "target_type", "frame_type", "tolerance_type",
           "positive_seconds", "positive_int"]

N = TypeVar("N", int, float)


def _number(text: str, convert: Callable[[str], N], expected: str, valid: Callable[[N], bool],
            must: Callable[[N], str]) -> N:
    """``convert(text)``, or an ArgumentTypeError saying ``expected …`` (it does not read as
    a number) or ``must be …`` (it is not ``valid``)."""
    try:
        value = convert(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {expected}") from None
    if not valid(value):
        raise argparse.ArgumentTypeError(f"must be {must(value)}")
    return value


def _finite_numbers(text: str, count: int, names: str, expected: str) -> list[float]:
    """``count`` comma-separated finite numbers (``names`` in the messages)."""
    try:
        values = [float(part) for part in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {expected}, got {text[:40]!r}") from None
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"expected {names}, got {text[:40]!r}")
    return values


def target_type(text: str) -> list[float]:
    """argparse type of ``reach --tip``: three finite numbers X,Y,Z [m]."""
    return _finite_numbers(text, 3, "three finite numbers X,Y,Z", "X,Y,Z in metres")


def frame_type(text: str) -> list[list[float]]:
    """argparse type of ``reach --frame``: the tip directors d1 and d3 (six finite numbers);
    d2 = d3 × d1. Whether they are orthonormal is checked by ``reach`` (exit 2)."""
    values = _finite_numbers(text, 6, "six finite numbers D1X,D1Y,D1Z,D3X,D3Y,D3Z",
                             "D1X,D1Y,D1Z,D3X,D3Y,D3Z")
    d1, d3 = values[:3], values[3:]
    d2 = [d3[1] * d1[2] - d3[2] * d1[1], d3[2] * d1[0] - d3[0] * d1[2],
          d3[0] * d1[1] - d3[1] * d1[0]]
    return [d1, d2, d3]


def tolerance_type(text: str) -> float:
    """argparse type of ``rerun --tolerance``: a finite number of at least 0."""
    shown = repr(text[:40])
    return _number(text, float, f"a number, got {shown}",
                   lambda value: math.isfinite(value) and value >= 0.0,
                   lambda value: f"a finite number >= 0, got {shown}")


def positive_seconds(text: str) -> float:
    """argparse type of ``--worker-timeout``: a finite number of seconds > 0."""
    shown = repr(text[:40])
    return _number(text, float, f"seconds, got {shown}", lambda value: 0.0 < value < math.inf,
                   lambda value: f"a finite number > 0, got {shown}")


def positive_int(text: str) -> int:
    """argparse type of ``--workers``: a whole number of at least 1."""
    return _number(text, int, f"a whole number, got {text!r}", lambda value: value >= 1,
                   lambda value: f"at least 1, got {value}")


def add_scene_set_and_output(parser: argparse.ArgumentParser, kind: str) -> None:
    """``--set`` and ``-o`` of the commands that start from a scene and write an archive
    with its figure beside it (track, fit, reach)."""
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override a scene value first (repeatable)")
    parser.add_argument("-o", "--output", help=f"archive path (default: "
                        f"runs/<scene>-{kind}.nc); the figure goes beside it (.png)")

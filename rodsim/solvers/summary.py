"""Short summaries of results for a notebook or a prompt: a title and a few labelled rows,
as text (``__repr__``: at most ``MAX_LINES`` lines) or as an HTML table
(``_repr_html_``, which Jupyter shows). The result objects (``rodsim.solvers.result.
Result``, and the inverse tools' Track, Fit and Reach) say which rows."""

from __future__ import annotations

import html
from collections.abc import Sequence

import numpy as np

__all__ = ["MAX_LINES", "summary_text", "summary_html", "millimetres", "shortened"]

#: The most lines a text summary has (the title included).
MAX_LINES = 10
#: The longest value shown in a row (longer ones end with an ellipsis).
MAX_VALUE = 96


def shortened(text: str, limit: int = MAX_VALUE) -> str:
    """``text`` on one line, cut to ``limit`` characters with an ellipsis."""
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[:limit - 1] + "…"


def millimetres(point: np.ndarray) -> str:
    """A point [m] as 'x, y, z = … mm'."""
    return "x, y, z = " + ", ".join(f"{1e3 * float(v):.4g}" for v in point) + " mm"


def summary_text(title: str, rows: Sequence[tuple[str, str]]) -> str:
    """The title and up to MAX_LINES − 1 rows, one ``label: value`` a line."""
    kept = list(rows)[:MAX_LINES - 1]
    width = max((len(label) for label, _ in kept), default=0)
    return "\n".join([title, *(f"  {label:<{width}}  {shortened(value)}"
                               for label, value in kept)])


def summary_html(title: str, rows: Sequence[tuple[str, str]]) -> str:
    """The same rows as an HTML table with the title as its caption."""
    body = "".join(f"<tr><th style='text-align:left'>{html.escape(label)}</th>"
                   f"<td style='text-align:left'>{html.escape(shortened(value, 400))}</td>"
                   "</tr>" for label, value in rows)
    return (f"<table><caption style='text-align:left'><b>{html.escape(title)}</b></caption>"
            f"{body}</table>")

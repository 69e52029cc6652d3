"""Short summaries of results for a notebook or a prompt: a title and a few labelled rows,
as text (``__repr__``: at most ``MAX_LINES`` lines) or as an HTML table
(``_repr_html_``, which Jupyter shows) beside a small sketch of the shape (``sketch_svg``:
an inline SVG, drawn without matplotlib). The result objects (``rodsim.solvers.result.
Result``, the inverse tools' Track, Fit and Reach, Simulation and Modes) say which rows and
what the sketch draws."""

from __future__ import annotations

import html
from collections.abc import Sequence

import numpy as np

__all__ = ["MAX_LINES", "summary_text", "summary_html", "millimetres", "shortened",
           "sketch_svg", "SKETCH_SIZE"]

#: The most lines a text summary has (the title included).
MAX_LINES = 10
#: The longest value shown in a row (longer ones end with an ellipsis).
MAX_VALUE = 96
#: The sketch's largest width and height [px], its margin and the scale bar's row.
SKETCH_SIZE, SKETCH_MARGIN, BAR_ROW = (240, 160), 14, 10
#: The sketch's colours: the shapes, the faint paths (a tip's path), the marks (targets,
#: measured points).
SKETCH_COLOURS = ("#0072B2", "#999999", "#D55E00")


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


def _scale_bar(span: float) -> float:
    """A round length (1, 2 or 5 × 10^k m) of at most a third of ``span`` [m]."""
    power = 10.0 ** np.floor(np.log10(span / 3.0))
    return float(max(m * power for m in (1.0, 2.0, 5.0) if m * power <= span / 3.0))


def sketch_svg(lines: Sequence[np.ndarray], faint: Sequence[np.ndarray] = (),
               marks: Sequence[np.ndarray] = ()) -> str:
    """A small inline SVG of polylines ``lines`` (each (n, 3) [m], solid), ``faint`` ones
    (thin, dashed) and points ``marks`` ((n, 3) or (3,), small circles), in the plane of the
    two world axes along which they extend most (named in its corner), to equal scales
    with a scale bar; "" when there is nothing finite to draw."""
    groups = [[np.atleast_2d(np.asarray(a, float)) for a in group]
              for group in (lines, faint, marks)]
    points = [a for group in groups for a in group if a.size]
    if not points or not all(np.all(np.isfinite(a)) for a in points):
        return ""
    every = np.concatenate(points)
    lo, spans = every.min(axis=0), np.ptp(every, axis=0)
    largest = float(np.max(spans))
    if largest == 0.0:
        return ""
    a, b = sorted(int(k) for k in np.argsort(-spans, kind="stable")[:2])
    room = np.array(SKETCH_SIZE, float) - 2 * SKETCH_MARGIN - np.array([0.0, BAR_ROW])
    scale = float(min(room[0] / max(spans[a], 1e-9 * largest),
                      room[1] / max(spans[b], 1e-9 * largest)))
    width = spans[a] * scale + 2 * SKETCH_MARGIN
    drawing = max(spans[b] * scale, SKETCH_MARGIN)
    height = drawing + 2 * SKETCH_MARGIN + BAR_ROW  # the scale bar in a row of its own

    def xy(p: np.ndarray) -> list[tuple[float, float]]:
        return [(SKETCH_MARGIN + (q[a] - lo[a]) * scale,
                 SKETCH_MARGIN + drawing - (q[b] - lo[b]) * scale) for q in p]

    def polyline(p: np.ndarray, style: str) -> str:
        joined = " ".join(f"{x:.1f},{y:.1f}" for x, y in xy(p))
        return f"<polyline points='{joined}' fill='none' {style}/>"

    shape, path, mark = SKETCH_COLOURS
    drawn = [polyline(p, f"stroke='{path}' stroke-width='1' stroke-dasharray='3 2'")
             for p in groups[1] if len(p) > 1]
    drawn += [polyline(p, f"stroke='{shape}' stroke-width='2'") for p in groups[0] if len(p)]
    drawn += [f"<circle cx='{x:.1f}' cy='{y:.1f}' r='2.5' fill='{mark}'/>"
              for p in groups[2] for x, y in xy(p)]
    bar = _scale_bar(float(spans[a]) or largest)
    label = f"{1e3 * bar:g} mm" if bar < 1.0 else f"{bar:g} m"
    end = SKETCH_MARGIN + bar * scale
    drawn.append(f"<line x1='{SKETCH_MARGIN}' y1='{height - 6:.1f}' x2='{end:.1f}' "
                 f"y2='{height - 6:.1f}' stroke='black' stroke-width='1'/>"
                 f"<text x='{end + 4:.1f}' y='{height - 3:.1f}' font-size='9'>{label}</text>")
    plane = f"{'xyz'[a]}–{'xyz'[b]}"
    drawn.append(f"<text x='{width - 2:.1f}' y='10' font-size='9' text-anchor='end'>"
                 f"{plane}</text>")
    return (f"<svg xmlns='http://www.w3.org/2000/svg' width='{width:.0f}' "
            f"height='{height:.0f}' role='img'><title>shape in {plane}</title>"
            + "".join(drawn) + "</svg>")


def summary_html(title: str, rows: Sequence[tuple[str, str]], sketch: str = "") -> str:
    """The same rows as an HTML table with the title as its caption, and ``sketch``
    (``sketch_svg``) beside it when there is one."""
    body = "".join(f"<tr><th style='text-align:left'>{html.escape(label)}</th>"
                   f"<td style='text-align:left'>{html.escape(shortened(value, 400))}</td>"
                   "</tr>" for label, value in rows)
    table = (f"<table><caption style='text-align:left'><b>{html.escape(title)}</b></caption>"
             f"{body}</table>")
    if not sketch:
        return table
    return ("<div style='display:flex;gap:1.5em;align-items:flex-start'>"
            f"{table}{sketch}</div>")

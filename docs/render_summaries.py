"""The review images of the notebook summaries (docs/figures/repr-html-*-before.png and
-after.png): a result's rows as text (as its repr prints them; Jupyter shows them as a
table), and after, the inline SVG sketch of its ``_repr_html_`` beside them, its elements
(polyline, circle, line, text) drawn with matplotlib in the SVG's own pixel coordinates (no
SVG renderer needed). Run from the repository root:
``python docs/render_summaries.py result|track|simulation``."""

from __future__ import annotations

import re
import sys
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import rodsim  # noqa: E402

LINE, CHARACTER = 17.0, 7.2  # a text row's height and a character's width [px]


def attributes(tag: str) -> dict[str, str]:
    return dict(re.findall(r"(\w[\w-]*)='([^']*)'", tag))


def draw_svg(ax: Any, svg: str) -> None:
    """The sketch's elements on ``ax``, in the SVG's pixels (y down)."""
    head = attributes(re.match(r"<svg[^>]*>", svg)[0])
    width, height = float(head["width"]), float(head["height"])
    ax.set_xlim(0, width)
    ax.set_ylim(height, 0)
    ax.set_aspect("equal")
    ax.axis("off")
    ax.add_patch(plt.Rectangle((0, 0), width, height, fill=False, ec="0.85", lw=0.5))
    for tag in re.findall(r"<polyline[^>]*/>", svg):
        a = attributes(tag)
        points = np.array([[float(v) for v in p.split(",")] for p in a["points"].split()])
        dash = ((0, [float(v) for v in a["stroke-dasharray"].split()])
                if "stroke-dasharray" in a else "solid")
        ax.plot(points[:, 0], points[:, 1], color=a["stroke"],
                lw=float(a["stroke-width"]) * 0.75, ls=dash)
    for tag in re.findall(r"<circle[^>]*/>", svg):
        a = attributes(tag)
        ax.add_patch(plt.Circle((float(a["cx"]), float(a["cy"])), float(a["r"]),
                                color=a["fill"]))
    for tag in re.findall(r"<line[^>]*/>", svg):
        a = attributes(tag)
        ax.plot([float(a["x1"]), float(a["x2"])], [float(a["y1"]), float(a["y2"])],
                color=a["stroke"], lw=0.75)
    for tag, text in re.findall(r"(<text[^>]*>)([^<]*)</text>", svg):
        a = attributes(tag)
        ax.text(float(a["x"]), float(a["y"]), text, fontsize=float(a["font-size"]) * 0.75,
                ha="right" if a.get("text-anchor") == "end" else "left", va="baseline")


def render(result: Any, path: str, sketch: bool) -> None:
    """The summary of ``result`` as a PNG at ``path``: the rows, and the sketch when asked."""
    lines = repr(result).splitlines()
    text_width = max(len(line) for line in lines) * CHARACTER + 20
    text_height = len(lines) * LINE + 20
    svg = re.search(r"<svg.*</svg>", result._repr_html_(), re.DOTALL)
    assert svg, "no sketch"
    size = re.search(r"width='([\d.]+)' height='([\d.]+)'", svg[0])
    sketch_width, sketch_height = float(size[1]), float(size[2])
    width = text_width + (sketch_width + 30 if sketch else 0)
    height = max(text_height, sketch_height + 20 if sketch else 0)
    figure = plt.figure(figsize=(width / 100, height / 100), dpi=150)
    ax = figure.add_axes((0, 0, text_width / width, 1))
    ax.axis("off")
    ax.set_xlim(0, text_width)
    ax.set_ylim(height, 0)
    for k, line in enumerate(lines):
        ax.text(10, 20 + LINE * k, line, family="DejaVu Sans Mono", fontsize=9,
                weight="bold" if k == 0 else "normal", va="baseline")
    if sketch:
        draw_svg(figure.add_axes((
            (text_width + 15) / width, 1 - (sketch_height + 10) / height,
            sketch_width / width, sketch_height / height)), svg[0])
    figure.savefig(path, facecolor="white")
    plt.close(figure)


def main(which: str) -> None:
    if which == "result":
        result = rodsim.solve("tdcr-two-segment")
    elif which == "track":
        result = rodsim.track(rodsim.load_scene("tdcr-two-segment"),
                              {"s1a.tendon_string.tension": np.linspace(0.0, 4.0, 9)})
    elif which == "simulation":
        result = rodsim.simulate("table1-50g", 0.3, output_dt=0.01, overrides=["nodes=11"])
    else:
        raise SystemExit(f"usage: python {sys.argv[0]} result|track|simulation")
    for stage in ("before", "after"):
        render(result, f"docs/figures/repr-html-{which}-{stage}.png", stage == "after")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "")

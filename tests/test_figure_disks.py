"""Spacer disks in the figures (issue 36): a string tendon on spacers
(``spacers = true``) puts a disk on its catheter at each of its routing points, drawn
edge-on as a short segment perpendicular to the backbone in each projection
(rodsim/app/figures/spacer_disks.py). Checked against the model's own routing points and
the archive's positions, not against the figure's own computation."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest

import rodsim
from rodsim.app.figures import draw_figure, style
from rodsim.app.figures.projections import PROJECTIONS
from rodsim.app.figures.spacer_disks import DISK_MARGIN
from rodsim.core.terms.tendon_string import TendonString
from rodsim.io.run_dataset import run_dataset

SCENE = "tdcr-two-segment"  # six tendons on spacers, 10 mm pitch radius, bent out of x–y
PITCH = 0.01


@pytest.fixture(scope="module")
def solved():
    result = rodsim.solve(SCENE)
    assert result.success, result.message
    return result, run_dataset(result)


def routing_s(result) -> np.ndarray:
    """The arc lengths of every routing point of the tendons on spacers, from the model."""
    model = rodsim.build_model(SCENE)
    strings = [t for t in model.terms if isinstance(t, TendonString)]
    assert len(strings) == 6
    return np.unique(np.concatenate([t.points.s for t in strings]))


def test_a_disk_sits_at_each_routing_point_perpendicular_to_the_backbone(solved):
    result, ds = solved
    expected_s = routing_s(result)
    positions = ds["position"].values
    s = ds["s"].values
    # the backbone's unit tangent at each routing point: central differences of the nodes
    tangent = np.gradient(positions, s, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    at = np.stack([np.interp(expected_s, s, tangent[:, k]) for k in range(3)], axis=1)
    centres = np.stack([np.interp(expected_s, s, positions[:, k]) for k in range(3)], axis=1)
    with style():
        figure = draw_figure(ds)
        try:
            drawn = [(axes, [c for c in axes.collections if c.get_gid() == "disk:backbone"])
                     for axes in figure.axes if axes.get_xlabel().endswith("[m]")]
            legend = [t.get_text() for t in figure.legends[0].get_texts()]
        finally:
            plt.close(figure)
    assert len(drawn) == 3  # a 3D shape: three projections
    assert any(text.startswith(f"spacer disks ({len(expected_s)}") for text in legend)
    edge_on = 0
    for (_, (collection,)), (a, b) in zip(drawn, PROJECTIONS, strict=True):
        segments = collection.get_segments()
        assert len(segments) == len(expected_s) > 50
        for segment, centre, t in zip(segments, centres, at, strict=True):
            if len(segment) != 2:  # seen face-on: a ring around the centre
                np.testing.assert_allclose(segment.mean(axis=0), centre[[a, b]], atol=2e-3)
                continue
            edge_on += 1
            np.testing.assert_allclose(segment.mean(axis=0), centre[[a, b]], rtol=0,
                                       atol=1e-12)
            direction = segment[1] - segment[0]
            length = np.linalg.norm(direction)
            # the diameter: DISK_MARGIN times the pitch radius, or less when foreshortened
            assert 0.0 < length <= 2 * DISK_MARGIN * PITCH * (1 + 1e-9)
            projected = t[[a, b]]
            if np.linalg.norm(projected) > 0.3:
                cosine = direction @ projected / (length * np.linalg.norm(projected))
                assert abs(cosine) < 0.02, (a, b, cosine)
    assert edge_on > 100  # x–y and x–z see the backbone from the side


def test_the_3d_view_draws_the_disks_as_rings(solved):
    pytest.importorskip("plotly", reason="plotly is the optional extra rodsim[view3d]")
    from rodsim.app.figures.view3d import view_figure

    result, ds = solved
    (trace,) = [t for t in view_figure(ds).data if t.name == "spacer disks"]
    points = np.stack([np.asarray(trace[k], dtype=float) for k in "xyz"], axis=1)
    rings = np.split(points, np.flatnonzero(np.isnan(points[:, 0])) + 1)
    rings = [r[np.isfinite(r[:, 0])] for r in rings]
    rings = [r for r in rings if len(r)]
    assert len(rings) == len(routing_s(result))
    positions = ds["position"].values
    for ring in rings:  # each rim 1.2 × 10 mm from a centre on the backbone
        centre = ring[:-1].mean(axis=0)
        assert np.min(np.linalg.norm(positions - centre, axis=1)) < 0.6 * 0.4 / 60
        np.testing.assert_allclose(np.linalg.norm(ring - centre, axis=1),
                                   DISK_MARGIN * PITCH, rtol=1e-9)


def test_a_scene_without_spacers_draws_no_disk():
    ds = run_dataset(rodsim.solve("catheter-helical"))
    with style():
        figure = draw_figure(ds)
        try:
            assert not [a for a in figure.findobj() if str(a.get_gid()).startswith("disk:")]
        finally:
            plt.close(figure)

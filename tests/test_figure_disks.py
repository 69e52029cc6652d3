"""Spacer disks in the figures (issue 36): a string tendon on spacers
(``spacers = true``) puts a disk on its catheter at each of its routing points, drawn
edge-on as a short segment perpendicular to the backbone in each projection
(rodsim/app/figures/spacer_disks.py). Checked against the model's own routing points and
the archive's positions, not against the figure's own computation."""

from __future__ import annotations

import json

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


GIVEN = 0.015  # m: a disk_radius larger than the rule's 1.2 × 10 mm


def with_disk_radius(ds, radius: float, tendons: tuple[str, ...]):
    """The archive as if its scene had said ``disk_radius = radius`` on ``tendons`` (the
    disk size does not enter the model: the equilibrium is the same)."""
    raw = json.loads(ds.attrs["scene_json"])
    for name in tendons:
        raw["tendons"][name]["tendon_string"]["disk_radius"] = radius
    out = ds.copy()
    out.attrs["scene_json"] = json.dumps(raw)
    return out


ALL = ("s1a", "s1b", "s1c", "s2a", "s2b", "s2c")


def edge_on_lengths(ds) -> tuple[list[float], list[str]]:
    with style():
        figure = draw_figure(ds)
        try:
            lengths = [float(np.linalg.norm(segment[1] - segment[0]))
                       for axes in figure.axes
                       for c in axes.collections if c.get_gid() == "disk:backbone"
                       for segment in c.get_segments() if len(segment) == 2]
            legend = [t.get_text() for t in figure.legends[0].get_texts()]
        finally:
            plt.close(figure)
    return lengths, legend


def test_the_scenes_disk_radius_sizes_the_drawn_disks(solved):
    """``disk_radius`` on every tendon: each edge-on disk is 2 × disk_radius long in every
    projection (its diameter lies in the view's plane), the legend names the key; the 3D
    view's rings have that radius. Without it: 2 × 1.2 × the 10 mm pitch radius."""
    result, ds = solved
    lengths, legend = edge_on_lengths(with_disk_radius(ds, GIVEN, ALL))
    assert len(lengths) > 100
    np.testing.assert_allclose(lengths, 2 * GIVEN, rtol=1e-9)
    assert any(text.startswith("spacer disks") and text.endswith("= disk_radius)")
               for text in legend)
    default, legend = edge_on_lengths(ds)
    np.testing.assert_allclose(default, 2 * DISK_MARGIN * PITCH, rtol=1e-9)
    assert any("1.2 × routing offset" in text for text in legend)


def test_a_disk_is_as_large_as_the_largest_its_tendons_ask(solved):
    """disk_radius on the first segment's tendons only: the disks at their routing points
    (the first segment, shared with the second segment's tendons) take the key's radius,
    the largest asked; the disks beyond, on the second segment's tendons alone, keep the
    rule's 1.2 × 10 mm; the legend names both. The 3D view's rings follow the key."""
    pytest.importorskip("plotly", reason="plotly is the optional extra rodsim[view3d]")
    from rodsim.app.figures.scene_parts import scene_parts
    from rodsim.app.figures.view3d import view_figure

    result, ds = solved
    model = rodsim.build_model(SCENE)
    points = {t.tendon.name: t.points.s for t in model.terms if isinstance(t, TendonString)}
    on_first = np.unique(np.concatenate([points[n] for n in ("s1a", "s1b", "s1c")]))
    mixed = with_disk_radius(ds, GIVEN, ("s1a", "s1b", "s1c"))
    disks = scene_parts(mixed).disks
    expected = [GIVEN if np.any(np.isclose(d.s, on_first, rtol=0, atol=1e-12))
                else DISK_MARGIN * PITCH for d in disks]
    np.testing.assert_allclose([d.radius for d in disks], expected, rtol=1e-9)
    assert 10 < expected.count(GIVEN) < len(disks) - 10  # both kinds, many of each
    _, legend = edge_on_lengths(mixed)
    assert any("disk_radius or 1.2 × routing offset" in text for text in legend)
    (trace,) = [t for t in view_figure(with_disk_radius(ds, GIVEN, ALL)).data
                if t.name == "spacer disks"]
    points = np.stack([np.asarray(trace[k], dtype=float) for k in "xyz"], axis=1)
    rings = [r[np.isfinite(r[:, 0])] for r in
             np.split(points, np.flatnonzero(np.isnan(points[:, 0])) + 1)]
    for ring in (r for r in rings if len(r)):
        centre = ring[:-1].mean(axis=0)
        np.testing.assert_allclose(np.linalg.norm(ring - centre, axis=1), GIVEN, rtol=1e-9)


@pytest.mark.parametrize("value, said", [
    ("-0.01", ">= 0"), ("nan", "disk_radius"), ("inf", "disk_radius"),
    ("0.005", "outside the disks"), ("true", "disk_radius")])
def test_a_bad_disk_radius_is_refused_in_one_line(value, said, cli, capsys, tmp_path):
    code = cli(["run", SCENE, "--set", f"tendons.s1a.tendon_string.disk_radius={value}",
                "-o", str(tmp_path / "refused.nc")])
    err = capsys.readouterr().err
    assert code == 2 and said in err and "Traceback" not in err, err
    assert len(err.strip().splitlines()) == 1, err
    assert not list(tmp_path.iterdir())


def test_a_disk_radius_without_spacers_is_refused(cli, capsys, tmp_path):
    code = cli(["run", "catheter-helical", "--set",
                "tendons.helix.tendon_string.disk_radius=0.01", "-o", str(tmp_path / "x.nc")])
    err = capsys.readouterr().err
    assert code == 2 and "without spacers rides on no disks" in err, err
    assert len(err.strip().splitlines()) == 1

"""Geometry an obstacle draws itself with (figures and the 3-D view read it, the model
does not): the zero level of a gap function in a plane of the world axes, and triangulated
surfaces of the shapes the shipped obstacles are made of.

Every obstacle has an outline through ``zero_level`` (marching squares on a grid of
φ(p) in the plane: the surface φ = 0 cut by that plane, to a grid cell), so an obstacle
type added without a drawing of its own is still drawn; the shipped types give exact ones.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["zero_level", "box_grid", "sphere_mesh", "tube_mesh", "plane_patch",
           "GRID_SAMPLES"]

#: Grid points along each side of the plane a generic outline is sampled on.
GRID_SAMPLES = 161


def box_grid(view: tuple[int, int], level: float, lower: np.ndarray, upper: np.ndarray,
             samples: int = GRID_SAMPLES) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The grid's two axes (``samples`` each) and its points (samples, samples, 3): the
    box's face of the world axes ``view`` at depth ``level`` on the third axis."""
    a, b = view
    xs = np.linspace(lower[a], upper[a], samples)
    ys = np.linspace(lower[b], upper[b], samples)
    points = np.zeros((samples, samples, 3))
    points[..., a], points[..., b] = np.meshgrid(xs, ys, indexing="ij")
    points[..., 3 - a - b] = level
    return xs, ys, points


def zero_level(gap: Callable[[np.ndarray], np.ndarray], view: tuple[int, int], level: float,
               lower: np.ndarray, upper: np.ndarray, samples: int = GRID_SAMPLES
               ) -> list[np.ndarray]:
    """The curve φ = 0 of the gap function ``gap`` (points (n, 3) → φ (n,)) in the plane
    of the world axes ``view`` at depth ``level``, within the box ``lower``–``upper``: a
    list of segments, each (2, 3) world points (linear interpolation of φ along each grid
    edge; a cell crossed four times is split into two segments)."""
    xs, ys, points = box_grid(view, level, lower, upper, samples)
    phi = np.asarray(gap(points.reshape(-1, 3)), dtype=float).reshape(samples, samples)
    solid = phi <= 0.0
    # corners of cell (i, j) in order: (i, j), (i+1, j), (i+1, j+1), (i, j+1)
    corners = ((0, 0), (1, 0), (1, 1), (0, 1))
    code = np.zeros((samples - 1, samples - 1), dtype=int)
    for k, (di, dj) in enumerate(corners):
        code |= solid[di:samples - 1 + di, dj:samples - 1 + dj].astype(int) << k
    segments: list[np.ndarray] = []
    for i, j in zip(*np.nonzero((code != 0) & (code != 15)), strict=True):
        crossings = []
        for k in range(4):
            (di0, dj0), (di1, dj1) = corners[k], corners[(k + 1) % 4]
            p0, p1 = phi[i + di0, j + dj0], phi[i + di1, j + dj1]
            if (p0 <= 0.0) != (p1 <= 0.0):
                t = p0 / (p0 - p1)
                crossings.append(points[i + di0, j + dj0]
                                 + t * (points[i + di1, j + dj1] - points[i + di0, j + dj0]))
        for first in range(0, len(crossings) - 1, 2):
            segments.append(np.array(crossings[first:first + 2]))
    return segments


def sphere_mesh(center: np.ndarray, radius: float, rings: int = 16, sectors: int = 32
                ) -> tuple[np.ndarray, np.ndarray]:
    """A UV sphere: vertices (n, 3) and triangles (m, 3)."""
    theta = np.linspace(0.0, np.pi, rings + 1)
    phi = np.linspace(0.0, 2 * np.pi, sectors, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    vertices = center + radius * np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p),
                                           np.cos(t)], axis=-1).reshape(-1, 3)
    return vertices, _grid_triangles(rings + 1, sectors)


def tube_mesh(centre: np.ndarray, tangent: np.ndarray, radius: np.ndarray, sectors: int = 24
              ) -> tuple[np.ndarray, np.ndarray]:
    """A tube of ``radius`` (n,) around the curve ``centre`` (n, 3) with ``tangent`` (n, 3):
    rings carried along the curve by parallel transport (no twist of the wall's mesh)."""
    t = tangent / np.linalg.norm(tangent, axis=1, keepdims=True)
    seed = np.eye(3)[int(np.argmin(np.abs(t[0])))]
    normal = np.cross(t[0], seed)
    normals = np.empty_like(t)
    for k in range(len(t)):
        normal = normal - (normal @ t[k]) * t[k]
        normal /= np.linalg.norm(normal)
        normals[k] = normal
    binormals = np.cross(t, normals)
    angle = np.linspace(0.0, 2 * np.pi, sectors, endpoint=False)
    rings = (centre[:, None, :] + radius[:, None, None]
             * (np.cos(angle)[None, :, None] * normals[:, None, :]
                + np.sin(angle)[None, :, None] * binormals[:, None, :]))
    return rings.reshape(-1, 3), _grid_triangles(len(centre), sectors)


def plane_patch(point: np.ndarray, normal: np.ndarray, lower: np.ndarray,
                upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A square of the plane through ``point`` with unit ``normal``, centred on the box
    centre's projection, as wide as the box's diagonal: 4 vertices, 2 triangles."""
    centre = 0.5 * (lower + upper)
    centre = centre - ((centre - point) @ normal) * normal
    half = 0.5 * float(np.linalg.norm(upper - lower))
    seed = np.eye(3)[int(np.argmin(np.abs(normal)))]
    u = np.cross(normal, seed)
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    vertices = np.array([centre + half * (su * u + sv * v)
                         for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
    return vertices, np.array([[0, 1, 2], [0, 2, 3]])


def _grid_triangles(rows: int, columns: int) -> np.ndarray:
    """Triangles of a grid of ``rows`` × ``columns`` vertices closed around the columns."""
    i, j = np.meshgrid(np.arange(rows - 1), np.arange(columns), indexing="ij")
    a = i * columns + j
    b = i * columns + (j + 1) % columns
    c, d = a + columns, b + columns
    return np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3),
                           np.stack([a, d, c], -1).reshape(-1, 3)])

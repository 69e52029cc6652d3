"""A vessel: a tube of radius R(u) around a smooth centerline c(u); the rod stays inside.

Centerlines (``centerline``): ``straight`` (a cylinder), ``arc`` (a torus section), ``helix``,
or ``csv`` (a polyline ``x,y,z,radius`` in metres, from ``file`` or inline ``points``). Every
centerline is held as a C² cubic spline in a parameter u (arclength for the analytic curves,
cumulative chord length for a polyline): the analytic curves are interpolated at 256 knots
per turn with their exact end tangents (interpolation error ~ a (2π/256)⁴/384 ≈ 3e-9 of the
bend radius a), a polyline by the natural spline through its points and the radius by the
clamped spline (R' = 0 at the ends). Beyond its ends the tube continues straight along the
end tangent with the end radius, so a rod that leaves the vessel is still pushed back
smoothly.

Gap of a point p: u* the nearest centerline parameter, (p − c(u*)) · c'(u*) = 0, found by
Newton from a warm start (the previous node's u*: the rod's nodes are consecutive, so the
search walks along the centerline and costs O(1) per node, never all pairs); r = p − c(u*),
d = |r|, e = r/d, A = |c'|² − r · c''. Then

    φ = R(u*) − d,     ∂u*/∂p = c'/A,     ∇d = e,     ∇²d = (I − e eᵀ − c' c'ᵀ/A) / d,
    ∇²u* = (c'' c'ᵀ + c' c''ᵀ)/A² − A_u c' c'ᵀ/A³,  A_u = 3 c' · c'' − r · c''',
    ∇φ = R' ∂u*/∂p − e,  ∇²φ = R'' ∂u*/∂p ∂u*/∂pᵀ + R' ∇²u* − ∇²d

(exact where the nearest point is unique: the resolve step refuses a vessel that bends
tighter than its radius, R κ ≥ 1, where it would not be).
"""

from __future__ import annotations

import bisect
import math
import os
import stat
from pathlib import Path
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from rodsim.core.obstacles import Obstacle
from rodsim.core.obstacles._drawing import tube_mesh
from rodsim.core.schema import Parameter, SceneError, shown

CENTERLINES = ("straight", "arc", "helix", "csv")
#: Largest centerline csv read [bytes].
MAX_CENTERLINE_BYTES = 64 << 20

#: Spline knots per full turn of an analytic curve.
KNOTS_PER_TURN = 256
#: Newton iterations of the projection (converges in 2–4 from a warm start).
MAX_ITERATIONS = 40


class Tube(Obstacle):
    """A vessel around a centerline (see the module docstring)."""

    type = "tube"
    kernel = "contact_tube"
    example = {"centerline": "straight", "radius": 0.005, "start": [-0.01, 0.0, 0.0],
               "length": 0.2}
    encloses = True
    parameters = (
        Parameter("centerline", "str", None, "-",
                  "'straight', 'arc' (torus), 'helix' or 'csv' (polyline x,y,z,radius)",
                  choices=CENTERLINES),
        Parameter("radius", "float", 0.0, "m",
                  "inner radius of the vessel (analytic centerlines; a csv gives its own)",
                  0.0, 1e3),
        Parameter("start", "vector", [0.0, 0.0, 0.0], "m", "centerline start point",
                  -1e3, 1e3, length=3),
        Parameter("direction", "vector", [1.0, 0.0, 0.0], "-",
                  "centerline tangent at the start (straight, arc) or helix axis",
                  -1e3, 1e3, length=3),
        Parameter("length", "float", 0.1, "m", "length of a straight centerline", 0.0, 1e3,
                  exclusive_minimum=True),
        Parameter("bend_radius", "float", 0.05, "m",
                  "radius of the arc's circle, or of the helix", 0.0, 1e3,
                  exclusive_minimum=True),
        Parameter("bend_toward", "vector", [0.0, 1.0, 0.0], "-",
                  "direction from the start toward the arc's (or helix axis') centre",
                  -1e3, 1e3, length=3),
        Parameter("angle", "float", math.pi / 2, "rad", "angle the arc turns through",
                  0.0, 2 * math.pi, exclusive_minimum=True),
        Parameter("pitch", "float", 0.02, "m", "rise of the helix per turn", 0.0, 1e3),
        Parameter("turns", "float", 1.0, "-", "turns of the helix", 0.0, 1e3,
                  exclusive_minimum=True),
        Parameter("file", "str", "", "-",
                  "csv centerline: a file of rows x,y,z,radius [m] (relative to the scene "
                  "file, or a shipped data file); read into points when the scene is loaded "
                  "(the resolved scene keeps the points, not the name); replaces points"),
        Parameter("points", "vector", [], "m",
                  "csv centerline given inline (or read from file): x,y,z,radius per point, "
                  "flattened", -1e3, 1e3),
    )

    # ------------------------------------------------------------- scene
    @classmethod
    def resolve(cls, table: dict[str, Any], prefix: str) -> dict[str, Any]:
        kind = table["centerline"]
        if kind == "csv":
            if table["file"]:
                # read once: the resolved scene (and so an archive) holds the points, and a
                # later override of file reads the new file (a file replaces any points)
                table["points"] = _read_points(table["file"], prefix)
                table["file"] = ""
            if not table["points"]:
                raise SceneError(f"{prefix}: a csv centerline needs file = '<x,y,z,radius "
                                 "file>' (or points)")
            points = np.asarray(table["points"], dtype=float)
            if len(points) % 4:
                raise SceneError(f"{prefix}.points: {len(points)} values, not x,y,z,radius per "
                                 "point (a multiple of 4)")
            points = points.reshape(-1, 4)
            _check_points(points, prefix)
        else:
            if table["radius"] <= 0.0:
                raise SceneError(f"{prefix}.radius = {shown(table['radius'])}: the vessel "
                                 "needs a radius > 0 [m]", key=f"{prefix}.radius",
                                 value=table["radius"], reason="out of range")
            for key in ("direction", "bend_toward"):
                if float(np.linalg.norm(table[key])) == 0.0:
                    raise SceneError(f"{prefix}.{key} = {table[key]!r}: a zero vector; "
                                     "allowed: a non-zero vector")
            t = _unit(table["direction"])
            b = np.asarray(table["bend_toward"], dtype=float)
            b = b - (b @ t) * t
            if kind in ("arc", "helix") and float(np.linalg.norm(b)) < 1e-9:
                raise SceneError(f"{prefix}.bend_toward = {table['bend_toward']!r}: parallel "
                                 "to direction; allowed: a direction across it")
            if kind == "helix" and table["turns"] > 1.0 and table["pitch"] < 2 * table["radius"]:
                # a point and the one a turn later are one pitch apart: the lumens overlap
                raise SceneError(f"{prefix}.pitch = {shown(table['pitch'])}: the vessel's "
                                 f"turns overlap (radius {table['radius']!r} m); allowed: a "
                                 "pitch of at least twice the radius, or at most one turn",
                                 key=f"{prefix}.pitch", value=table["pitch"],
                                 reason="self-overlapping")
        tube = cls("", table)
        tube._check_bend(prefix, 20 if kind == "csv" else 2)
        return table

    def _check_bend(self, prefix: str, per_knot: int) -> None:
        """Refuse a vessel bending tighter than its radius (R κ ≥ 1): the nearest centerline
        point, and so the wall, is not unique there. Sampled ``per_knot`` times per knot: a
        csv's spline anywhere between its points; an analytic centerline's, of constant
        curvature and KNOTS_PER_TURN knots a turn, twice (20 took 9 s on a 1 000-turn
        helix)."""
        u = np.linspace(self.knots[0], self.knots[-1], per_knot * len(self.knots))
        c1, c2 = self._c(u, 1), self._c(u, 2)
        speed = np.linalg.norm(c1, axis=1)
        kappa = np.linalg.norm(np.cross(c1, c2), axis=1) / speed**3
        radius = self._r(u, 0)
        if np.min(radius) <= 0.0:
            i = int(np.argmin(radius))
            raise SceneError(f"{prefix}: the interpolated vessel radius reaches "
                             f"{radius[i]:.3g} m at {_where(self._c(u[i:i+1], 0)[0])}; "
                             "allowed: radius > 0 everywhere (add points)")
        bad = np.flatnonzero(radius * kappa >= 0.95)
        if len(bad):
            i = int(bad[0])
            raise SceneError(f"{prefix}: the vessel bends tighter than its radius at "
                             f"{_where(self._c(u[i:i+1], 0)[0])} (curvature radius "
                             f"{1 / kappa[i]:.3g} m, vessel radius {radius[i]:.3g} m)")

    # ------------------------------------------------------------- geometry
    def __init__(self, name: str, table: Any) -> None:
        super().__init__(name, table)
        kind = table["centerline"]
        if kind == "csv":
            points = np.asarray(table["points"], dtype=float).reshape(-1, 4)
            chord = np.linalg.norm(np.diff(points[:, :3], axis=0), axis=1)
            u = np.concatenate([[0.0], np.cumsum(chord)])
            center = CubicSpline(u, points[:, :3], bc_type="natural")
            radius = CubicSpline(u, points[:, 3], bc_type="clamped")
        else:
            u, c, dc = _analytic(table)
            center = CubicSpline(u, c, bc_type=((1, dc[0]), (1, dc[-1])))
            radius = CubicSpline(u, np.full(len(u), float(table["radius"])), bc_type="clamped")
        self.knots = u
        m = len(u) - 1
        # pieces: 0 = straight extension before u_0, 1..m the spline, m + 1 = after u_m
        self.starts = np.concatenate([[u[0]], u[:-1], [u[-1]]])
        coef = np.zeros((m + 2, 4, 3))
        coef[1:m + 1] = np.transpose(center.c[::-1], (1, 0, 2))
        rcoef = np.zeros((m + 2, 4))
        rcoef[1:m + 1] = radius.c[::-1].T
        for piece, at in ((0, u[0]), (m + 1, u[-1])):
            coef[piece, 0], coef[piece, 1] = center(at), center(at, 1)
            rcoef[piece, 0] = radius(at)
        self.coef, self.rcoef = coef, rcoef
        self.step = float(np.max(np.diff(u)))

    def narrowest(self) -> float:
        u = np.linspace(self.knots[0], self.knots[-1], 20 * len(self.knots))
        return float(np.min(self._r(u, 0)))

    def _sampled(self, count: int = 400) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """c(u), c'(u) and R(u) at ``count`` parameters spanning the centerline."""
        u = np.linspace(self.knots[0], self.knots[-1], count)
        return self._c(u, 0), self._c(u, 1), self._r(u, 0)

    def outline(self, view: tuple[int, int], level: float, lower: np.ndarray,
                upper: np.ndarray) -> list[np.ndarray]:
        """The vessel's wall seen across the view: the two curves c(u) ± R(u) n(u), n the
        in-view normal of the centerline (the outline of the vessel projected on the
        view's plane; exact for a centerline in that plane)."""
        a, b = view
        c, c1, radius = self._sampled()
        across = np.zeros_like(c1)
        across[:, a], across[:, b] = -c1[:, b], c1[:, a]
        across /= np.maximum(np.linalg.norm(across, axis=1, keepdims=True), 1e-300)
        return [c + radius[:, None] * across, c - radius[:, None] * across]

    def surface(self, lower: np.ndarray, upper: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray] | None:
        """The vessel's wall along its whole centerline."""
        c, c1, radius = self._sampled(200)
        return tube_mesh(c, c1, radius)

    def _piece(self, u: np.ndarray) -> np.ndarray:
        k = np.searchsorted(self.knots, u, side="right")
        return np.where(u < self.knots[0], 0, np.minimum(k, len(self.knots)))

    def _c(self, u: np.ndarray, order: int) -> np.ndarray:
        k = self._piece(u)
        t = (u - self.starts[k])[:, None]
        a = self.coef[k]
        return _poly(a, t, order)

    def _r(self, u: np.ndarray, order: int) -> np.ndarray:
        k = self._piece(u)
        t = u - self.starts[k]
        return _poly(self.rcoef[k], t, order)

    def project(self, points: np.ndarray) -> np.ndarray:
        """Nearest centerline parameter u* of each point: Newton on (c − p) · c' = 0 from the
        previous point's u* (the first from the nearest knot). On the spline a step is at most
        one knot interval (no jump to another branch of a bending vessel); on the straight
        extensions the step is Newton's exact one, stopped at the spline's end. The walk may
        take as many steps as the spline has knots: a node any distance along the vessel from
        the previous one is reached."""
        out = np.zeros(len(points))
        if not len(points):
            return out
        knots = self.knots[:-1]  # the starts of the spline's pieces, as the kernel scans them
        knots_c = self._c(knots, 0)
        u = float(knots[np.argmin(np.sum((knots_c - points[0]) ** 2, axis=1))])
        first, last = float(self.knots[0]), float(self.knots[-1])
        # One u at a time: the piece as _piece finds it (bisect_right is searchsorted's
        # side="right"), once per step, and c, c', c'' by _poly's operations in its order,
        # so the same numbers as _c at [u] without three array calls per step (they were
        # half of a contact track's time: the equilibrium stop's depth check projects
        # every node).
        knot_list, starts, pieces = self.knots.tolist(), self.starts.tolist(), len(self.knots)
        for i, p in enumerate(points):
            for iteration in range(MAX_ITERATIONS + len(self.knots)):
                k = 0 if u < first else min(bisect.bisect_right(knot_list, u), pieces)
                a0, a1, a2, a3 = self.coef[k]
                t = u - starts[k]
                c = a0 + t * (a1 + t * (a2 + t * a3))
                c1 = a1 + t * (2.0 * a2 + 3.0 * t * a3)
                c2 = 2.0 * a2 + 6.0 * t * a3
                r = p - c
                speed2 = float(c1 @ c1)
                a = speed2 - float(r @ c2)
                if a < 0.1 * speed2:
                    a = speed2
                newton = float(r @ c1) / a
                if u < first:  # on the straight extension Newton is exact: no step limit,
                    du = min(newton, first - u)  # but stop at the spline's start
                elif u > last:
                    du = max(newton, last - u)
                else:
                    du = min(max(newton, -self.step), self.step)
                u += du
                # Newton's own step, not the one taken: a step stopped at the spline's end
                # a round-off away is tiny though the point lies further on (the kernel's
                # _project, rodsim/core/kernels/contact_tube.py).
                if abs(newton) <= 1e-14 * self.step:
                    break
                if iteration >= MAX_ITERATIONS and abs(du) <= 1e-12 * self.step:
                    # Converged, but round-off keeps u stepping back and forth (a node at
                    # the spline's end): the walk took every knot of a 1 000-turn helix,
                    # 13 s of a scene's validation (issue 37).
                    break
            out[i] = u
        return out

    def gap(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        u = self.project(points)
        c, c1, c2, c3 = (self._c(u, k) for k in range(4))
        radius, r1, r2 = (self._r(u, k) for k in range(3))
        r = points - c
        d = np.maximum(np.linalg.norm(r, axis=1), 1e-30)
        e = r / d[:, None]
        speed2 = np.sum(c1 * c1, axis=1)
        a = speed2 - np.sum(r * c2, axis=1)
        a_u = 3.0 * np.sum(c1 * c2, axis=1) - np.sum(r * c3, axis=1)
        du = c1 / a[:, None]
        outer = np.einsum("ni,nj->nij", c1, c1)
        hess_d = (np.eye(3) - np.einsum("ni,nj->nij", e, e)
                  - outer / a[:, None, None]) / d[:, None, None]
        mixed = np.einsum("ni,nj->nij", c2, c1)
        hess_u = ((mixed + np.transpose(mixed, (0, 2, 1))) / (a**2)[:, None, None]
                  - (a_u / a**3)[:, None, None] * outer)
        phi = radius - d
        grad = r1[:, None] * du - e
        hess = (r2[:, None, None] * np.einsum("ni,nj->nij", du, du)
                + r1[:, None, None] * hess_u - hess_d)
        return phi, grad, hess

    def kernel_arguments(self) -> dict[str, Any]:
        return {"step": self.step, "starts": self.starts.copy(), "coef": self.coef.copy(),
                "rcoef": self.rcoef.copy()}


def _poly(a: np.ndarray, t: np.ndarray, order: int) -> np.ndarray:
    """The ``order``-th derivative of Σ_k a_k t^k (a: (n, 4, ...), t broadcast to a[:, 0])."""
    if order == 0:
        return a[:, 0] + t * (a[:, 1] + t * (a[:, 2] + t * a[:, 3]))
    if order == 1:
        return a[:, 1] + t * (2.0 * a[:, 2] + 3.0 * t * a[:, 3])
    if order == 2:
        return 2.0 * a[:, 2] + 6.0 * t * a[:, 3]
    return 6.0 * a[:, 3] + 0.0 * t


def _unit(v: Any) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _where(p: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:.6g}" for v in p) + ") m"


def _analytic(table: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Knots u (arclength), points c(u) and tangents c'(u) of an analytic centerline."""
    kind = table["centerline"]
    start = np.asarray(table["start"], dtype=float)
    t = _unit(table["direction"])
    if kind == "straight":
        u = np.array([0.0, float(table["length"])])
        return u, start + u[:, None] * t, np.tile(t, (2, 1))
    b = np.asarray(table["bend_toward"], dtype=float)
    b = _unit(b - (b @ t) * t)
    a = float(table["bend_radius"])
    if kind == "arc":
        angle = float(table["angle"])
        count = max(8, int(math.ceil(KNOTS_PER_TURN * angle / (2 * math.pi))))
        theta = np.linspace(0.0, angle, count + 1)
        c = start + a * (np.sin(theta)[:, None] * t + (1 - np.cos(theta))[:, None] * b)
        dc = np.cos(theta)[:, None] * t + np.sin(theta)[:, None] * b
        return a * theta, c, dc
    # helix about the axis t through start + a b, rising pitch per turn
    w = np.cross(t, b)
    rise = float(table["pitch"]) / (2 * math.pi)
    speed = math.hypot(a, rise)
    turns = float(table["turns"])
    count = max(8, int(math.ceil(KNOTS_PER_TURN * turns)))
    theta = np.linspace(0.0, 2 * math.pi * turns, count + 1)
    c = (start + a * b + a * (-np.cos(theta)[:, None] * b + np.sin(theta)[:, None] * w)
         + rise * theta[:, None] * t)
    dc = (a * (np.sin(theta)[:, None] * b + np.cos(theta)[:, None] * w) + rise * t) / speed
    return speed * theta, c, dc


def _read_points(file: str, prefix: str) -> list[float]:
    """The rows x,y,z,radius of a csv file, flattened (SceneError, one line, if unreadable)."""
    from importlib import resources

    path = Path(file)
    if not path.exists():
        shipped = Path(str(resources.files("rodsim.data"))) / file
        if shipped.exists():
            path = shipped
        else:
            raise SceneError(f"{prefix}.file = {shown(file)}: no such file (nor a shipped "
                             "data file)", key=f"{prefix}.file", value=file,
                             reason="no such file")
    rows: list[float] = []
    try:
        # Checked before opening: a FIFO would wait for a writer, a device never ends.
        if not stat.S_ISREG(os.stat(path).st_mode):
            raise SceneError(f"{prefix}.file = {shown(file)}: not a regular file",
                             key=f"{prefix}.file", value=file, reason="not a regular file")
        with open(path, "rb") as stream:
            data = stream.read(MAX_CENTERLINE_BYTES + 1)
        if len(data) > MAX_CENTERLINE_BYTES:
            raise SceneError(f"{prefix}.file = {shown(file)}: larger than "
                             f"{MAX_CENTERLINE_BYTES >> 20} MiB (a centerline csv of a few "
                             "thousand points is under 1 MiB)")
        text = data.decode("utf-8-sig")  # a byte-order mark, as spreadsheets write, is fine
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(f"{prefix}.file = {shown(file)}: cannot read it "
                         f"({type(exc).__name__})") from None
    for number, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        fields = [f.strip() for f in line.split(",")]
        try:
            values = [float(f) for f in fields]
        except ValueError:
            if not rows and any(c.isalpha() for c in line):
                continue  # a header line
            raise SceneError(f"{prefix}.file = {shown(file)}: line {number} is not four "
                             f"numbers x,y,z,radius: {shown(line)}") from None
        if len(values) != 4:
            raise SceneError(f"{prefix}.file = {shown(file)}: line {number} has "
                             f"{len(values)} values; allowed: x,y,z,radius")
        rows.extend(values)
    return rows


def _check_points(points: np.ndarray, prefix: str) -> None:
    if len(points) < 2:
        raise SceneError(f"{prefix}: a csv centerline needs at least 2 points, got "
                         f"{len(points)}")
    bad = np.flatnonzero(~np.all(np.isfinite(points), axis=1))
    if len(bad):
        raise SceneError(f"{prefix}: point {int(bad[0])} has a NaN or infinite value: "
                         f"{points[bad[0]].tolist()}")
    bad = np.flatnonzero(points[:, 3] <= 0.0)
    if len(bad):
        value = float(points[bad[0], 3])
        raise SceneError(f"{prefix}: point {int(bad[0])} has radius {value!r} m; allowed: "
                         "radius > 0")
    chord = np.linalg.norm(np.diff(points[:, :3], axis=0), axis=1)
    bad = np.flatnonzero(chord == 0.0)
    if len(bad):
        raise SceneError(f"{prefix}: points {int(bad[0])} and {int(bad[0]) + 1} coincide; "
                         "allowed: distinct consecutive points")

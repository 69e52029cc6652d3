"""A frictionless tendon pulled by a prescribed displacement: an elastic string whose free
length is set (not in the paper; issue 20, "displacement control").

A motor that winds a tendon in by d prescribes the tendon's free length ℓ* = ℓ₀ − d (ℓ₀ the
length of its rest path from the entry to the termination) rather than its tension. The
tendon is an elastic string of axial stiffness E A (``stiffness``) routed without friction
through the same points as a tension-controlled string (rodsim/core/terms/tendon_string.py):
its tension is T = (E A / ℓ*) (ℓ(x) − ℓ*) while it is taut and 0 when slack (ℓ ≤ ℓ*: a
tendon does not push), and it stores

    V = ½ (E A / ℓ*) max(0, ℓ(x) − ℓ*)²,
    ∂V/∂x = T ∇ℓ,   ∂²V/∂x² = T ∇²ℓ + (E A / ℓ*) ∇ℓ ∇ℓᵀ   (taut).

The first two are the tension-controlled string's at the tension T(x) — the same routing
points, chords and stencils, evaluated by that term's code — so at equilibrium the two
models agree exactly when the string's tension is set to T (tests/test_string_tendon.py).
The last is the tendon's own stiffness: it couples every coordinate along the tendon's path
(ℓ depends on all of them), so the term is one element holding all of them and its
Jacobian block is dense — m² entries for the m coordinates of the span (7 per node), and a
band as wide as the span. A scene refuses spans of more than ``MAX_SPAN_NODES`` nodes
(tension control has no such limit).

E A is physical, not a penalty: a tendon of 0.2 mm stainless steel wire has E A ≈ 6 kN, a
braided polymer line 1–5 kN; the stiffer the tendon, the closer the free length is to the
path's length. The term is a load for the solvers (static ramps it in with the other loads).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np

from rodsim.core.routing import string_span
from rodsim.core.schema import SceneError
from rodsim.core.tendon import Tendon
from rodsim.core.terms.base import KernelArguments, TendonTerm
from rodsim.core.terms.tendon_string import TendonString, TendonStringOptions

#: Most catheter nodes a displacement-controlled tendon may span (its dense Jacobian block
#: holds (7 n)² entries: 35 MB at 300 nodes).
MAX_SPAN_NODES = 300


class TendonStringDisplacement(TendonTerm):
    """V = ½ (E A / ℓ*) max(0, ℓ − ℓ*)²: a tendon pulled in by ``displacement``."""

    name = "tendon_string_displacement"
    figure_layer = "tendon"
    key = "tendon_string"
    Options = TendonStringOptions
    options: TendonStringOptions
    equation = "V = ½ (E A / ℓ*) (ℓ − ℓ*)₊² (Rucker & Webster 2011 loads; not in the paper)"
    #: How the tendon's table selects this variant of the key ``tendon_string``.
    selection = 'control = "displacement"'
    is_load = True
    parameters = TendonString.parameters

    @classmethod
    def selected_by(cls, owner: Mapping[str, Any]) -> bool:
        """The tendon's ``tendon_string.control`` is 'displacement'."""
        table = owner.get("tendon_string", {})
        return isinstance(table, Mapping) and table.get("control") == "displacement"

    @classmethod
    def check_scene(cls, options: Any, owner: Any, prefix: str) -> None:
        if options.friction != 0.0:
            raise SceneError(f"{prefix}.friction = {options.friction!r}: friction is "
                             "modelled on a tension-controlled string only; allowed: "
                             "friction = 0 with control = 'displacement'")
        for key in ("friction_points", "friction_profile", "friction_profile_s",
                    "static_friction", "static_friction_profile", "exact_jacobian"):
            if getattr(options, key):
                raise SceneError(f"{prefix}.{key} = {getattr(options, key)!r}: friction is "
                                 "modelled on a tension-controlled string only; allowed: "
                                 f"leave {key} unset with control = 'displacement'")
        if not options.stiffness > 0.0:
            raise SceneError(f"{prefix}.stiffness = {options.stiffness!r}: control = "
                             "'displacement' needs the tendon's axial stiffness E A; allowed: "
                             "a number > 0 [N] (0.2 mm steel wire: about 6e3)")

    def __init__(self, tendon: Tendon, options: TendonStringOptions) -> None:
        super().__init__(tendon, options)
        #: The same string under unit tension: the path, its chords and their stencils.
        self.string = TendonString(tendon, dataclasses.replace(options, tension=1.0))
        catheter = tendon.catheter
        start, end = string_span(options, catheter.length)
        span_nodes = int(np.sum((catheter.geometry.node_s >= start)
                                & (catheter.geometry.node_s <= end)))
        if span_nodes > MAX_SPAN_NODES:
            raise SceneError(
                f"tendons.{tendon.name}.tendon_string.control = 'displacement': the tendon "
                f"spans {span_nodes} nodes of {catheter.name!r}, more than {MAX_SPAN_NODES} "
                "(its stiffness couples every coordinate along it: a dense Jacobian block); "
                "allowed: fewer nodes, or control = 'tension'")
        chords = self.string.dofs
        span = np.unique(chords)
        self.dofs = span[None, :]
        #: Each chord's coordinates as positions in the span, (E, 28).
        self._chord_local = np.searchsorted(span, chords).astype(np.int64)
        m = len(span)
        self._chord_pairs = (self._chord_local[:, :, None] * m
                             + self._chord_local[:, None, :]).astype(np.int64)
        rest = np.zeros(catheter.layout.offset + catheter.layout.size)
        rest[catheter.layout.position_index] = catheter.rest_positions()
        rest[catheter.layout.quaternion_index] = catheter.rest_quaternions()
        #: ℓ₀, the rest path's length, and ℓ* = ℓ₀ − d, the free length [m].
        self.rest_length = self.string.length(rest)
        self.free_length = self.rest_length - float(options.displacement)
        if not self.free_length > 0.0:
            raise SceneError(
                f"tendons.{tendon.name}.tendon_string.displacement = "
                f"{options.displacement!r}: not shorter than the tendon's rest path "
                f"({self.rest_length:.6g} m); allowed: displacement < {self.rest_length:.6g}")
        #: E A / ℓ*, the tendon's stiffness [N/m].
        self.spring = float(options.stiffness) / self.free_length
        self._offset = float(np.mean(np.hypot(*self.string.points.offset.T)))
        self._span = end - start

    def kernel_arguments(self) -> KernelArguments:
        chord = self.string.kernel_arguments()
        return {"dofs": self.dofs, "chord_dofs": chord["dofs"], "weights": chord["weights"],
                "constant": chord["constant"], "forms": chord["forms"],
                "chord_local": self._chord_local, "chord_pairs": self._chord_pairs,
                "spring": self.spring, "free_length": self.free_length}

    def path_length(self, x: np.ndarray) -> float:
        """ℓ(x), the length of the tendon's path at the full state ``x`` [m]."""
        return self.string.length(x)

    def tension(self, x: np.ndarray) -> float:
        """T = (E A / ℓ*) max(0, ℓ(x) − ℓ*) at the full state ``x`` [N]."""
        return self.spring * max(0.0, self.path_length(x) - self.free_length)

    def tension_outcome(self, x: np.ndarray) -> float | None:
        return self.tension(x)

    def load_scale(self, x: np.ndarray) -> float:
        """An estimate of the tension [N]: the pull over the sum of the tendon's compliance
        ℓ*/(E A) and the catheter's, ρ² (span)/(E I) (a tension T bends the span to
        curvature T ρ / (E I), which shortens the path by about ρ² T span / (E I))."""
        pull = float(self.options.displacement)
        if pull <= 0.0:
            return 0.0
        bending = self.tendon.catheter.bending_stiffness
        return pull / (1.0 / self.spring + self._offset**2 * self._span / bending)

    def energy(self, x: np.ndarray) -> float:
        stretch = max(0.0, self.path_length(x) - self.free_length)
        return 0.5 * self.spring * stretch * stretch

    def _gradient(self, x: np.ndarray) -> np.ndarray:
        """∇ℓ on the span's coordinates, (m,)."""
        g = np.zeros(self.dofs.shape[1])
        np.add.at(g, self._chord_local, -self.string.element_forces(x))
        return g

    def element_forces(self, x: np.ndarray) -> np.ndarray:
        return -(self.tension(x) * self._gradient(x))[None, :]

    def element_jacobians(self, x: np.ndarray) -> np.ndarray:
        m = self.dofs.shape[1]
        tension = self.tension(x)
        jacobian = np.zeros((m, m))
        chords = self.string.element_jacobians(x)  # −∇²ℓ of each chord, unit tension
        np.add.at(jacobian, (self._chord_local[:, :, None], self._chord_local[:, None, :]),
                  tension * chords)
        if self.path_length(x) > self.free_length:
            g = self._gradient(x)
            jacobian -= self.spring * np.outer(g, g)
        return jacobian[None]

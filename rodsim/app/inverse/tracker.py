"""A tracker a control loop holds (``rodsim.Tracker``; docs/inverse.md, "A tracker"): the
equilibrium at each new set of actuation values, warm-started from the last, with the tip's
pose and its Jacobian with respect to those values.

``tracker = rodsim.Tracker(scene, keys)`` solves the scene at its own values of ``keys``
(cold, from rest); each ``tracker.step(values)`` then moves to the equilibrium at ``values``
the way ``track`` moves from one step to the next (``Continuation.walk``,
rodsim/app/inverse/continuation.py: a warm start from the last equilibrium and its
registration, from the tangent predictor x + (dx/dp) Δp of the last step's Jacobian, which
the tracker has computed anyway; the increment halved on a failed attempt), judges its
stability from the
factorisation the step's own verification made (``rodsim.core.stability.assess``, the
certificate first only after a certified step, as ``track``; the eigenvalues nearest zero
of a non-symmetric K from the last step's, rodsim/core/stability_tracking.py), and gives
the tip's
Jacobian d(tip)/d(values) by the implicit-function theorem (``equilibrium_sensitivity``,
rodsim/app/inverse/sensitivity.py) solved with that same factorisation: no second one. A
step that fails leaves the tracker at its last equilibrium and says why (``success`` False).

Predictor. The step starts from the tangent predictor R(x, X' δ) (X' = dx/dp the last
step's, R the integrator's own step from x) or, where that start is not at the equilibrium
already and the step goes along the line through the last two values, from the same plus
the path's curvature along that line that the equilibrium before the last shows
(``Tracker._predictor``), whichever has the smaller force residual on the step's model
(``Continuation.solve``: F once more where the first start is not converged). Measured over
200 steps of the tendon force 0 → 4 N on table3-catheter1: 1.6 iterations a step against
5.2 from the tangent alone; tdcr-two-segment (s1a 0 → 3 N): the tangent's start converged
at 110 of 200 steps and the curved one was never the smaller, so the same states (0.47
iterations a step).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from rodsim.app.inverse.continuation import Continuation, EquilibriumFailure
from rodsim.app.inverse.parameter_keys import numeric_keys, scene_with
from rodsim.app.inverse.sensitivity import equilibrium_sensitivity
from rodsim.core.model import Model
from rodsim.core.scene import Scene
from rodsim.core.schema import SceneError
from rodsim.core.stability import Stability, assess
from rodsim.core.stability_tracking import NearestModes
from rodsim.solvers import DEFAULT_INTEGRATOR, integrator_named

__all__ = ["Tracker", "TrackerStep", "ALONG"]

#: A step's increment of values lies along the last one's when it differs from a multiple of
#: it by at most this, relative (the second-order predictor, ``Tracker._predictor``).
ALONG = 1e-12


@dataclass(frozen=True)
class TrackerStep:
    """One step of a ``Tracker``: ``success`` and ``message``; the equilibrium
    (``state``, free coordinates; ``positions`` of the tracked rod (N, 3) [m]); the tip's
    ``tip`` [m] and ``tip_quaternion`` (its last segment's, q4 real); ``tip_jacobian``
    d(tip)/d(values) (3, P) and ``quaternion_jacobian`` (4, P), one column per key in the
    tracker's order, per unit of the key; the ``stability`` verdict; ``iterations`` (Newton
    and chord) and ``halvings`` (failed attempts). A failed step holds the last
    equilibrium's values (the tracker stays there) and no Jacobian (NaN)."""

    success: bool
    message: str
    values: np.ndarray
    state: np.ndarray
    positions: np.ndarray
    tip: np.ndarray
    tip_quaternion: np.ndarray
    tip_jacobian: np.ndarray
    quaternion_jacobian: np.ndarray
    stability: Stability | None
    iterations: int
    halvings: int


class Tracker:
    """Equilibria for a control loop (module docstring).

    Parameters
    ----------
    scene
        A Scene, a path or a shipped scene name (``rodsim.load_scene``).
    keys
        The actuation values (numeric scene keys as for ``track``'s ramps: a tension, a
        base's insertion, ``KEY[i]`` for a vector component).
    integrator
        ``static`` (the default) or another registered integrator.
    rod
        The rod whose tip is reported (default: the first).

    Raises
    ------
    SceneError
        For bad keys.
    EquilibriumFailure
        When the scene's own values have no equilibrium.
    """

    def __init__(self, scene: Any, keys: Sequence[str], integrator: str = DEFAULT_INTEGRATOR,
                 rod: str | None = None) -> None:
        from rodsim.app.api import load_scene, solve

        self.scene = load_scene(scene)
        integrator_named(integrator)
        self.keys = numeric_keys(self.scene, list(keys))
        self.rod = rod or next(iter(self.scene.rods))
        if self.rod not in self.scene.rods:
            raise SceneError(f"rod {self.rod!r}: no such rod; the scene's rods are "
                             + ", ".join(self.scene.rods))
        first = solve(self.scene, integrator)
        if not first.success:
            raise EquilibriumFailure(f"the scene's own values have no equilibrium: "
                                     f"{first.message}")
        self.values = np.array([key.value(self.scene) for key in self.keys])
        self.continuation = Continuation(Model(first.scene), first.state, integrator)
        self._certified = True
        #: The verdicts' eigenvectors nearest zero, from one step to the next
        #: (rodsim/core/stability_tracking.py).
        self._modes = NearestModes()
        #: dx/d(values) (n, P) at the last equilibrium (its step's Jacobian): the next
        #: step's tangent predictor. None before the first step and after a failed one.
        self._tangent: np.ndarray | None = None
        #: (the equilibrium before the last, its values minus the last's), for the
        #: predictor's second-order term; None before the second step and after a failure.
        self._last: tuple[np.ndarray, np.ndarray] | None = None

    def _checked(self, values: Any) -> tuple[np.ndarray, Scene]:
        """``values`` as finite numbers in range, one per key, and the scene at them;
        SceneError (the rules across tables are checked by that scene)."""
        row = np.asarray(values, dtype=float).reshape(-1)
        if row.shape != (len(self.keys),) or not np.all(np.isfinite(row)):
            raise SceneError(f"a step needs {len(self.keys)} finite values, one per key ("
                             + ", ".join(k.name for k in self.keys) + ")")
        for key, value in zip(self.keys, row, strict=True):
            low, high = key.bounds()
            if not low <= value <= high:
                raise SceneError(f"{key.name} = {value:g}: out of range; allowed: "
                                 f"{key.parameter.allowed}")
        return row, scene_with(self.scene, self.keys, row)

    def _predictor(self, row: np.ndarray
                   ) -> tuple[np.ndarray, Callable[[], np.ndarray] | None]:
        """The start of the step to the values ``row``, from the last equilibrium x at the
        values p (module docstring, "Predictor"): R(x, X' δ), δ = row − p, X' = dx/dp and
        R the integrator's own step from x (``Continuation.predicted``); plus, when δ lies
        along the line to the equilibrium before, x₋ at p₋ (δ = s d, d = p − p₋), the
        second-order term s² r with r = x₋ − R(x, −X' d): the path's curvature along d
        that the linear predictor missed at x₋ — made only where the step asks for it (a
        start not at the equilibrium already, ``Continuation.solve``)."""
        continuation, tangent = self.continuation, self._tangent
        assert tangent is not None
        delta = row - self.values
        start = continuation.predicted(self.scene, tangent @ delta)
        if self._last is None:
            return start, None
        before, back = self._last  # x₋ and p₋ − p = −d
        size = float(back @ back)
        s = -float(delta @ back) / size if size > 0.0 else 0.0
        if s == 0.0 or np.abs(delta + s * back).max() > ALONG * np.abs(delta).max():
            return start, None
        scene = self.scene

        def curved() -> np.ndarray:
            remainder = before - continuation.predicted(scene, tangent @ back)
            return start + (s * s) * remainder
        return start, curved

    def step(self, values: Any) -> TrackerStep:
        """Move to the equilibrium at ``values`` (one per key) and return it with the tip's
        pose, Jacobian and stability; SceneError for values out of range (nothing moves)."""
        row, scene = self._checked(values)
        continuation = self.continuation
        predictor = alternative = None
        if self._tangent is not None and continuation.takes_predictor:
            predictor, alternative = self._predictor(row)
        previous_x, previous_values = continuation.x, self.values
        ok, iterations, halvings, message = continuation.walk(self.scene, self.keys,
                                                              self.values, row, predictor,
                                                              alternative, scene)
        model, x = continuation.model, continuation.x
        layout = model.rods[self.rod].layout
        full = model.full(x)
        if not ok:
            self._tangent, self._last = None, None
            nan = np.full((3, len(self.keys)), np.nan)
            return TrackerStep(False, message, self.values.copy(), x.copy(),
                               full[layout.position_index], full[layout.position_index[-1]],
                               full[layout.quaternion_index[-1]], nan,
                               np.full((4, len(self.keys)), np.nan), None, iterations,
                               halvings)
        self._last = (previous_x, previous_values - row) if previous_x is not None else None
        self.values = row
        factored = continuation.factorisation()
        verdict = assess(model, x, factored, self._certified, self._modes)
        self._certified = verdict.stable and np.isnan(verdict.min_eigenvalue)
        self._tangent, derivative = equilibrium_sensitivity(
            model, x, self.keys, factored[1] if factored is not None else None, row)
        return TrackerStep(True, message or "converged", row.copy(), x.copy(),
                           full[layout.position_index], full[layout.position_index[-1]],
                           full[layout.quaternion_index[-1]],
                           derivative[layout.position_index[-1]],
                           derivative[layout.quaternion_index[-1]], verdict, iterations,
                           halvings)

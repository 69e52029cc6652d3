"""Sensitivities of an equilibrium to scene parameters, by the implicit-function theorem.

At an equilibrium F(x, p) = 0, so J dx/dp = −∂F/∂p with J = ∂F/∂x the model's analytic
Jacobian. J is factored once (band Cholesky of −J for a conservative model, band LU
otherwise, SuperLU for wide bands: ``LinearSolver.factorized``) and solved for every
parameter. ∂F/∂p is a central difference of F alone at the fixed state x — never of
re-solved equilibria: the model of the scene with p ± h, with the same registration and the
same order of the free coordinates (``Model.with_values``: only the terms whose options
change are rebuilt, else ``Model.with_scene``), evaluated at x: the
fourth-order central difference (F at p ± h/2 and p ± h), or the third-order one-sided one
for a parameter at the edge of its allowed range (F(x, p) is then the equilibrium's
residual, ~0). Step: h = 1e-6 |p| (1e-6 in the parameter's unit at p = 0). F is linear in
loads, moduli, penalties and tendon forces, but not in a base position: moving the clamped
node by h changes F by O((h/l)²) relative to its first-order change (l the segment length),
and the second-order central difference left an error of 8e-5 on the rigid translation an
origin shift must give (table1-50g, h = 1 µm, l = 3 mm); the fourth-order one brings it
below 1e-8. A key whose terms' force is its value times their force at value 1
(``Term.linear_unit``: a frictionless string tendon's tension) takes that unit force
itself (``unit_forces``, rodsim/core/value_change.py): no difference at all.

Parameters that move the rest state (a rod's length, its origin, a lumen offset) keep the
layout of the free coordinates, and F of the perturbed model is evaluated at the same free
coordinates x (world-frame positions and quaternions): dx/dp is then the derivative of the
equilibrium's world-frame coordinates, which is what re-solving at p ± h would give. The
clamped coordinates (a rod's base) move with such parameters; their derivative is the
derivative of the rest state. Parameters that change the discretisation (``nodes``) or the
free-coordinate layout are refused (rodsim/app/inverse/parameter_keys.py).

The tendon registration (a tendon point's parent node) is discrete: the sensitivity is taken
at the registration of the equilibrium, as is every derivative of a piecewise-smooth model.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from rodsim.app.inverse.parameter_keys import NumericKey, numeric_keys, scene_with
from rodsim.core.model import Model
from rodsim.core.schema import SceneError
from rodsim.core.value_change import force_change, unit_forces
from rodsim.solvers.linear import LinearSolver
from rodsim.solvers.result import Result

__all__ = ["Sensitivity", "sensitivity", "equilibrium_sensitivity", "registered_model",
           "SensitivityError", "RELATIVE_STEP", "LINEAR_STEP"]

#: Relative step of the central difference of F in each parameter.
RELATIVE_STEP = 1e-6
#: Relative step of the one-point difference of F in a parameter it is linear in
#: (``Term.linear_in``): exact but for round-off, which a longer step divides (tdcr-two-
#: segment's tension: F(p + h) + F(p − h) − 2 F(p) is 2.5e-10 of the change at h = 1e-6 p,
#: 2.5e-13 at 1e-3 p: round-off alone).
LINEAR_STEP = 1e-2


class SensitivityError(ValueError):
    """The sensitivity cannot be computed (a singular Jacobian)."""


@dataclass(frozen=True)
class Sensitivity:
    """Derivatives of an equilibrium with respect to parameters.

    ``state`` is d(free coordinates)/dp, shape (n, P); ``positions[rod]`` (P, N, 3) [m per
    unit of p] and ``quaternions[rod]`` (P, N − 1, 4) the same for every rod, clamped
    coordinates included. ``keys`` are the parameters' full keys, ``values`` their values.
    """

    keys: list[str]
    units: list[str]
    values: np.ndarray
    state: np.ndarray
    positions: dict[str, np.ndarray]
    quaternions: dict[str, np.ndarray]

    def tip(self, rod: str | None = None) -> np.ndarray:
        """d(tip of ``rod``)/dp, shape (P, 3) (default: the first rod)."""
        return self.positions[rod or next(iter(self.positions))][:, -1, :]


def registered_model(model: Model, x: np.ndarray) -> Model:
    """``model`` with the registration of the equilibrium ``x`` (exact, no hysteresis)."""
    return model.reregistered(x, exact=True) or model


def _stencil(key: NumericKey, value: float) -> list[tuple[float, float]]:
    """(point, weight) pairs of the fourth-order central difference of ``key`` at ``value``
    (the third-order one-sided one at the edge of the allowed range): the derivative of F is
    Σ weight × F(x, point)."""
    h = RELATIVE_STEP * abs(value) if value != 0.0 else RELATIVE_STEP
    low, high = key.bounds()
    offsets: tuple[float, ...]
    weights: tuple[float, ...]
    if value - h >= low and value + h <= high:
        offsets, weights = (-h, -h / 2, h / 2, h), (1.0, -8.0, 8.0, -1.0)
        scale = 6.0 * h
    elif value + h <= high:
        offsets, weights, scale = (0.0, h / 2, h), (-3.0, 4.0, -1.0), h
    else:
        offsets, weights, scale = (0.0, -h / 2, -h), (3.0, -4.0, 1.0), h
    return [(value + offset, weight / scale) for offset, weight in zip(offsets, weights,
                                                                         strict=True)]


def _linear_column(model: Model, x: np.ndarray, keys: Sequence[NumericKey],
                   values: Sequence[float], column: int) -> np.ndarray | None:
    """−∂F/∂p of the key ``keys[column]`` where the key is an option of terms whose force
    is linear in it (``Term.linear_in``: a tendon's tension without friction, an actuation
    force): minus their units' forces where each is c times its unit's, c the key's value
    (``Term.linear_unit``: a string tendon's tension; ``unit_forces``), else one
    difference of F — exact there, up to round-off, as the stencil is; None otherwise (the
    stencil)."""
    parts = keys[column].path.split(".")
    if keys[column].index is not None or len(parts) != 4 or parts[0] not in ("rods",
                                                                             "tendons"):
        return None
    owner = (parts[0], parts[1], parts[2])
    indices = [index for index, key in enumerate(model.term_keys) if key == owner]
    unit = unit_forces(model, parts[3], indices, x) if indices else None
    if unit is not None:
        return -unit
    value = values[column]
    h = LINEAR_STEP * abs(value) if value != 0.0 else LINEAR_STEP
    low, high = keys[column].bounds()
    point = value + h if value + h <= high else value - h
    if point < low:
        return None
    moved = list(values)
    moved[column] = point
    scene = scene_with(model.scene, keys, moved)
    made = model.terms_with_values(scene)
    if made is None or not made[1] or not all(model.terms[index].linear_in(parts[3])
                                             for index in made[1]):
        return None
    change = force_change(model, scene, x, made)
    return None if change is None else -change / (point - value)


def equilibrium_sensitivity(model: Model, x: np.ndarray, keys: Sequence[NumericKey],
                            solve: Callable[[np.ndarray], np.ndarray] | None = None,
                            values: Sequence[float] | np.ndarray | None = None
                            ) -> tuple[np.ndarray, np.ndarray]:
    """(dx/dp (n, P), d(full state)/dp (full size, P)) at the equilibrium ``x`` of
    ``model`` (which must carry the registration of ``x``), by the method of the module
    docstring. ``solve``: J at ``x`` already factored (a solve of J X = B: the verification
    of the solve that found ``x``, ``RunState.factorisation_at``), else J is factored
    here; ``values``: the keys' values in ``model``'s scene, if the caller knows them. Raises
    SensitivityError when J is singular and SceneError when a parameter change alters the
    model's layout.

    A change of the options of some terms alone (a load, a tendon force: ``Model.with_values``
    rebuilds those terms) is differenced on those terms (``force_change``,
    rodsim/core/value_change.py), on one point where the terms' force is linear in it
    (``_linear_column``); any other builds the perturbed model."""
    scene = model.scene
    base_values = (list(values) if values is not None
                   else [key.value(scene) for key in keys])
    force_at_x: np.ndarray | None = None
    rhs = np.zeros((model.n, len(keys)))
    rest = np.zeros((model.full_size, len(keys)))
    reference = np.zeros((model.full_size, len(keys)))
    for column, key in enumerate(keys):
        value = base_values[column]
        linear = _linear_column(model, x, keys, base_values, column)
        if linear is not None:
            rhs[:, column] = linear
            continue
        # Σ weight = 0: summing weight × (F(p_i) − F(p)) keeps a parameter F does not depend
        # on at an exact zero (no round-off of F's own size divided by h).
        for point, weight in _stencil(key, value):
            if point == value:
                continue
            moved = list(base_values)
            moved[column] = point
            try:
                perturbed_scene = scene_with(scene, keys, moved)
                change = force_change(model, perturbed_scene, x)
                if change is not None:  # the same rest state and reference: no change there
                    rhs[:, column] -= weight * change
                    continue
                perturbed = model.with_values(perturbed_scene)
            except SceneError:
                raise
            except ValueError as exc:
                raise SceneError(f"{key.name}: {exc}; it has no derivative") from None
            if force_at_x is None:
                force_at_x = model.force(x)
            rhs[:, column] -= weight * (perturbed.force(x) - force_at_x)
            rest[:, column] += weight * (perturbed.rest_full - model.rest_full)
            reference[:, column] += weight * (perturbed.reference - model.reference)
    if solve is None:
        solver = LinearSolver(model.pattern, model.pattern_rows, model.pattern_cols,
                              (model.band.lower, model.band.upper), model.conservative)
        solve = solver.factorized(model.jacobian_data(x))
    dx = solve(rhs) if solve is not None else None
    if dx is None or not np.all(np.isfinite(dx)):
        raise SensitivityError("the Jacobian at this state is singular: no sensitivity")
    dx = dx.reshape(model.n, len(keys))
    full = rest
    # The free coordinates are offsets from the rest state (Model.reference): the positions'
    # derivative adds the rest state's own.
    full[model.free] = dx + reference[model.free]
    return dx, full


def sensitivity(result: Result, params: Sequence[str], *, model: Model | None = None
                ) -> Sensitivity:
    """d(positions, quaternions)/d(param) at the equilibrium of ``result`` for each numeric
    scene key in ``params`` (short forms as for ``--set``; ``KEY[i]`` for a vector
    component), by the implicit-function theorem (module docstring).

    ``model``: the result's scene's model, if already built. Raises SceneError for a key
    that is not a differentiable numeric parameter, ValueError for a failed result, and
    SensitivityError for a singular Jacobian.
    """
    if not result.success:
        raise ValueError(f"the result is not an equilibrium: {result.message}")
    keys = numeric_keys(result.scene, params)
    if model is None or model.scene is not result.scene:
        model = Model(result.scene)
    model = registered_model(model, result.state)
    dx, full = equilibrium_sensitivity(model, result.state, keys)
    positions = {name: np.moveaxis(full[rod.layout.position_index], -1, 0)
                 for name, rod in model.rods.items()}
    quaternions = {name: np.moveaxis(full[rod.layout.quaternion_index], -1, 0)
                   for name, rod in model.rods.items()}
    return Sensitivity([k.name for k in keys], [k.unit for k in keys],
                       np.array([k.value(result.scene) for k in keys]), dx, positions,
                       quaternions)

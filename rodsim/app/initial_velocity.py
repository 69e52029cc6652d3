"""Initial velocities of a run in physical time (issue 33 item 4; docs/dynamics.md,
"Initial state and programs").

``rodsim.simulate(..., initial_velocity=...)`` starts the run from its initial state (the
rest state, an equilibrium or a solved Result) with a velocity instead of at rest. The
velocity is one of:

- a 3-vector (v_x, v_y, v_z) [m/s]: every free node moves with it, no segment turns (a
  rigid translation of the free part; a held node keeps still);
- the physical velocities u = (v, ω) of rodsim/solvers/physical/coordinates.py, p + 3 s
  numbers: each free position coordinate's rate [m/s] in the model's free order, then each
  free segment's body-frame angular velocity (ω₁, ω₂, ω₃) [rad/s] on its directors;
- the rates ẋ of the model's n free coordinates (positions [m/s], quaternion rates [1/s]):
  a mode's ``vectors`` times ω, for instance. The quaternion rates are turned into the
  body rates ω_k = (2/|q|²) (B_k q) · q̇ (Eq. 13 inverted); a part of q̇ along q (a change
  of the quaternion's norm) is no motion and is dropped.

The three are told apart by their length (n = p + 4 s > p + 3 s when a segment is free);
any other length, or a value that is not finite, is a one-line SceneError before any work.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rodsim.core.model import Model
from rodsim.core.schema import SceneError
from rodsim.solvers.physical.coordinates import PhysicalCoordinates

__all__ = ["initial_rates", "position_axes", "velocity_text", "parse_velocity"]

VelocityLike = Sequence[float] | np.ndarray


def position_axes(model: Model) -> np.ndarray:
    """The axis (0, 1, 2) of every free position coordinate, in the order of
    ``PhysicalCoordinates.positions``."""
    free_of = np.full(model.full_size, -1)
    free_of[model.free] = np.arange(model.n)
    axes = []
    for rod in model.rods.values():
        index = free_of[rod.layout.position_index]
        axis = np.broadcast_to(np.arange(3), index.shape)
        axes.append(axis.ravel()[index.ravel() >= 0])
    return np.concatenate(axes) if axes else np.zeros(0, dtype=int)


def _array(velocity: VelocityLike) -> np.ndarray:
    try:
        value = np.asarray(velocity, dtype=float)
    except (TypeError, ValueError):
        raise SceneError("initial_velocity: expected a 3-vector [m/s] or a vector of "
                         "numbers") from None
    if value.ndim != 1:
        raise SceneError(f"initial_velocity: expected a flat vector, got shape "
                         f"{value.shape}")
    if not np.all(np.isfinite(value)):
        raise SceneError("initial_velocity: every number must be finite")
    return value


def initial_rates(model: Model, coordinates: PhysicalCoordinates, x: np.ndarray,
                  velocity: VelocityLike | None) -> tuple[np.ndarray, np.ndarray]:
    """(v (p,), ω (s, 3)) of ``velocity`` (module docstring) at the free coordinates ``x``
    (unit quaternions); zeros for None. SceneError (one line) for a bad length or value."""
    p, s = len(coordinates.positions), len(coordinates.quaternions)
    if velocity is None:
        return np.zeros(p), np.zeros((s, 3))
    value = _array(velocity)
    if len(value) == 3:
        return value[position_axes(model)], np.zeros((s, 3))
    if len(value) == p + 3 * s:
        return value[:p].copy(), value[p:].reshape(s, 3).copy()
    if len(value) == model.n:
        v, w = coordinates.rates(x, value)
        return v, w
    raise SceneError(f"initial_velocity: {len(value)} numbers; allowed 3 (a uniform "
                     f"velocity [m/s]), {p + 3 * s} (each free position coordinate's rate "
                     f"and each free segment's body rates) or {model.n} (the rates of the "
                     "free coordinates)")


def velocity_text(velocity: VelocityLike | None) -> str:
    """How the run's initial velocity is written in its archive ("" for at rest)."""
    if velocity is None:
        return ""
    value = np.asarray(velocity, dtype=float)
    if len(value) == 3:
        return (" with the uniform initial velocity "
                f"({value[0]:.6g}, {value[1]:.6g}, {value[2]:.6g}) m/s")
    return (f" with an initial velocity field (largest rate {np.max(np.abs(value)):.6g}, "
            f"{len(value)} numbers)")


def parse_velocity(text: str) -> tuple[float, float, float]:
    """``VX,VY,VZ`` → the 3-vector [m/s]; ValueError (one line) for anything else."""
    parts = text.split(",")
    try:
        numbers = [float(part) for part in parts]
    except ValueError:
        numbers = []
    if len(numbers) != 3 or not all(np.isfinite(numbers)):
        raise ValueError(f"--initial-velocity {text[:60]!r}: expected VX,VY,VZ (three finite "
                         "numbers, m/s)")
    return numbers[0], numbers[1], numbers[2]

"""Quaternion algebra of the CORDE discretisation (paper §2.1, Eqs. 2–5).

Quaternions are stored in the paper's order ``(q1, q2, q3, q4)``: ``q1..q3`` imaginary,
``q4`` real. Every director of Eq. (2) is a quadratic form of ``q``:
``d_k[m] = q · A[k, m] q`` with a constant symmetric 4×4 matrix ``A[k, m]``. That makes the
director gradient ``∂d_k[m]/∂q = 2 A[k, m] q`` and its Hessian ``2 A[k, m]`` exact and
cheap, which is what the analytic Jacobians of the energy terms are built on.

The directors are *not* normalised: ``|d_k| = |q|²``. In rodsim, as in the paper, the unit
norm of ``q`` is held by the centerline penalty Eq. (9) (which asks ``|d3| = 1``), or by an
explicit algebraic constraint in the IDA integrator.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "B",
    "B0",
    "DIRECTOR_FORMS",
    "directors",
    "director",
    "director_gradient",
    "from_rotation_matrix",
    "rest_quaternion",
]


def _directors_formula(q: np.ndarray) -> np.ndarray:
    """Eq. (2) as printed, for one quaternion: rows are d1, d2, d3."""
    q1, q2, q3, q4 = q
    return np.array(
        [
            [q1**2 - q2**2 - q3**2 + q4**2, 2 * (q1 * q2 + q3 * q4), 2 * (q1 * q3 - q2 * q4)],
            [2 * (q1 * q2 - q3 * q4), -(q1**2) + q2**2 - q3**2 + q4**2, 2 * (q2 * q3 + q1 * q4)],
            [2 * (q1 * q3 + q2 * q4), 2 * (q2 * q3 - q1 * q4), -(q1**2) - q2**2 + q3**2 + q4**2],
        ]
    )


def _quadratic_forms() -> np.ndarray:
    """Recover the symmetric matrices A[k, m] of Eq. (2) by polarisation (exact for quadratics)."""
    eye = np.eye(4)
    forms = np.zeros((3, 3, 4, 4))
    for a in range(4):
        forms[:, :, a, a] = _directors_formula(eye[a])
        for b in range(a + 1, 4):
            mixed = _directors_formula(eye[a] + eye[b]) - _directors_formula(eye[a])
            mixed -= _directors_formula(eye[b])
            forms[:, :, a, b] = forms[:, :, b, a] = 0.5 * mixed
    return forms


#: ``DIRECTOR_FORMS[k, m]`` is the 4×4 symmetric matrix with ``d_{k+1}[m] = q·A q`` (Eq. 2).
DIRECTOR_FORMS: np.ndarray = _quadratic_forms()

#: Eq. (4): skew-symmetric matrices giving the material strains ``u_k ∝ (B_k q)·q'``.
B: np.ndarray = np.array(
    [
        [[0, 0, 0, 1], [0, 0, 1, 0], [0, -1, 0, 0], [-1, 0, 0, 0]],
        [[0, 0, -1, 0], [0, 0, 0, 1], [1, 0, 0, 0], [0, -1, 0, 0]],
        [[0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1], [0, 0, -1, 0]],
    ],
    dtype=float,
)

#: Eq. (5): the same matrices with respect to the reference frame (angular velocities).
B0: np.ndarray = np.array(
    [
        [[0, 0, 0, 1], [0, 0, -1, 0], [0, 1, 0, 0], [-1, 0, 0, 0]],
        [[0, 0, 1, 0], [0, 0, 0, 1], [-1, 0, 0, 0], [0, -1, 0, 0]],
        [[0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 1], [0, 0, -1, 0]],
    ],
    dtype=float,
)


# The contractions below are written as matrix products against flattened constant forms:
# numpy's einsum does not call BLAS for them and was 15-60x slower at N = 4000
# (commit 7a14443).
_FORM_COLUMNS = [np.ascontiguousarray(forms.reshape(12, 4).T) for forms in DIRECTOR_FORMS]


def _form_products(q: np.ndarray, k: int) -> np.ndarray:
    """A[k, m] q for m = 0, 1, 2: shape (..., 3, 4)."""
    return (q @ _FORM_COLUMNS[k]).reshape(q.shape[:-1] + (3, 4))


def directors(q: np.ndarray) -> np.ndarray:
    """Directors of Eq. (2) for quaternions ``q`` of shape (..., 4).

    Returns an array of shape (..., 3, 3) whose ``[..., k, :]`` is ``d_{k+1}``.
    """
    return np.stack([director(q, k) for k in range(3)], axis=-2)


def director(q: np.ndarray, k: int) -> np.ndarray:
    """Director ``d_{k+1}`` (``k`` = 0, 1, 2) of quaternions ``q`` (..., 4) -> (..., 3):
    component m is qᵀ A[k, m] q."""
    return np.matmul(_form_products(q, k), q[..., :, None])[..., 0]


def director_gradient(q: np.ndarray, k: int) -> np.ndarray:
    """Jacobian ``∂d_{k+1}/∂q`` of shape (..., 3, 4): row ``m`` is ``2 A[k, m] q``."""
    return 2.0 * _form_products(q, k)


def form_combination(weights: np.ndarray, forms: np.ndarray) -> np.ndarray:
    """Σ_m weights[..., m] forms[m] for constant (3, 4, 4) forms: shape (..., 4, 4)."""
    return (weights @ forms.reshape(3, 16)).reshape(weights.shape[:-1] + (4, 4))


def from_rotation_matrix(rotation: np.ndarray) -> np.ndarray:
    """Unit quaternion (q1, q2, q3, q4) whose directors (Eq. 2) are the columns of ``rotation``.

    ``rotation[:, k]`` is ``d_{k+1}``; ``rotation`` must be a proper rotation matrix.
    """
    r = np.asarray(rotation, dtype=float)
    trace = np.trace(r)
    # Shepperd's method: pick the largest diagonal term for numerical stability.
    candidates = np.array([r[0, 0], r[1, 1], r[2, 2], trace])
    i = int(np.argmax(candidates))
    q = np.empty(4)
    if i == 3:
        q[3] = 0.5 * np.sqrt(1.0 + trace)
        f = 0.25 / q[3]
        q[0] = (r[2, 1] - r[1, 2]) * f
        q[1] = (r[0, 2] - r[2, 0]) * f
        q[2] = (r[1, 0] - r[0, 1]) * f
    else:
        j, k = (i + 1) % 3, (i + 2) % 3
        q[i] = 0.5 * np.sqrt(1.0 + r[i, i] - r[j, j] - r[k, k])
        f = 0.25 / q[i]
        q[3] = (r[k, j] - r[j, k]) * f
        q[j] = (r[j, i] + r[i, j]) * f
        q[k] = (r[k, i] + r[i, k]) * f
    return q / np.linalg.norm(q)


def rest_quaternion() -> np.ndarray:
    """Orientation of an undeformed rod in the world frame.

    rodsim's convention (docs/model.md): the rod points along +x, so ``d3 = +x``; ``d1 = +y``
    lies in the bending plane and ``d2 = +z`` points out of it. This is the cyclic frame
    (y, z, x), i.e. the quaternion (½, ½, ½, ½).
    """
    return from_rotation_matrix(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]))

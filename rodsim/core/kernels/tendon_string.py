"""Kernel of ``rodsim.core.terms.tendon_string``: V = T ℓ, one element per chord of the
tendon's path between routing points A and B (28 coordinates: r_m, r_{m+1}, Q_0, Q_1 of A,
then of B). For a point with weights (c0, c1, w0, w1), constant quaternion q_c and forms G_m,

    q = w0 Q_0 + w1 Q_1 + q_c,  n = |q|²,  g_m = qᵀ G_m q,  p = c0 r_m + c1 r_{m+1} + g / n,
    ∂p/∂q = 2 G q / n − 2 g qᵀ / n²,
    ∂²p_m/∂q² = 2 G_m/n − 4 (G_m q qᵀ + q qᵀ G_m)/n² − 2 g_m I/n² + 8 g_m q qᵀ/n³;

with d = p_B − p_A, u = d/|d|: F = −T Jdᵀ u and ∂F/∂x = −T [Jdᵀ (I − u uᵀ) Jd / |d|
+ Σ_m u_m (∂²p_B[m] − ∂²p_A[m])], Jd = [−J_A, J_B].

How ∂F/∂x is built (issue 35 item 4: the dense 28 × 28 element product and its scatter
were most of a solve): each point's q, n, G_m q and g are computed once; a chord's Jd is
taken on its distinct coordinates only — the groups with a weight, the knot quaternion and
the node the two points share counted once with the sum of both columns (18 of the 28 at a
point on a node), so each Jacobian slot the chord touches gets one addition; Jdᵀ P Jd
(P = T (I − u uᵀ)/|d|) is formed on and above the diagonal and mirrored; the curvature
Σ_m u_m ∂²p[m] is contracted with u before it is built,
2 G_u/n − 4 (v qᵀ + q vᵀ)/n² − 2 γ I/n² + 8 γ q qᵀ/n³ with G_u = Σ_m u_m G_m, v = G_u q,
γ = Σ_m u_m g_m. F and the energy are the sums they were; ∂F/∂x moved by round-off
(the sums are grouped differently).

With friction μ > 0 each chord carries its own tension τ_e in place of T — the capstan
profile with the stored history ``profile`` (rodsim/core/tendon_friction.py: the entry's
turn from d3 to the path's tangent d3 + ρ′_y d1 + ρ′_z d2 (d_k = qᵀ A_k q / n of the entry
point, ρ′ = ``entry_slope``) and on, the turns at the points, split at the entry (blended
continuously with its plain angle by the kink's size and its share out of the plane) and
at the points ``split`` marks, the actuator's bounds) —
and the Jacobian is the one at frozen τ_e plus, on a chord up to which the path turns one
way in one plane from a held entry frame, f ⊗ ∂τ_e/∂x with ∂τ_e/∂x = (∂τ_e/∂Θ_e) ∂ψ_e/∂x,
ψ_e = ∠(d3, u_e) (rodsim/core/terms/tendon_string.py, "Friction"): the chord elements; the
span element (rodsim/core/kernels/tendon_string_span.py: ``exact_jacobian``, or a μ that
varies) takes the frozen part from here (``own`` False) and adds the whole coupling. With
μ = 0 every τ_e is T and the coupling is skipped: the frictionless numbers, bitwise.

The string tendons of one catheter are evaluated in one call (``evaluate_group``,
rodsim/core/kernel_group.py), which sums the element Jacobians of the chords the tendons
share coordinates on (between the same two nodes) before writing them into the CSC data.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rodsim.core.kernels._scatter import add_force
from rodsim.core.kernels._string_block import add_upper, subtract_curvature, subtract_frozen
from rodsim.core.kernels.tendon_string_path import (
    _curvature,
    _one_way_coupling,
    _points,
    _points_into,
    _tensions,
    path_length,
)


@njit(cache=True, inline="always")
def _unique_columns(dofs: np.ndarray, weights: np.ndarray, e: int, point: int,
                    jd: np.ndarray, local: np.ndarray, merged: np.ndarray, knot: np.ndarray,
                    group_first: np.ndarray, group_start: np.ndarray,
                    source: np.ndarray) -> int:
    """Chord e's Jd on its distinct coordinates (its points' weights in rows ``point`` and
    ``point + 1`` of ``weights``): the groups (a node's position, a knot's
    quaternion) with a weight, a group the two points share (the knot between them, a
    node) taken once with the sum of both points' columns of Jd. Fills ``merged`` (3, ·)
    with those columns, ``local`` with a local column of each (its slot in the element's
    target map) and ``knot`` (2, 2) with the first merged column of each point's knot
    quaternion (−1 without a weight); returns the count. ``source`` (28, 2) gets the column
    of Jd each merged column was taken from and the one added to it (−1: none), for
    ``_merged_columns`` to repeat on another chord of the same coordinates. ``group_first`` and
    ``group_start`` (8,) are scratch: the local column opening each group, and its first
    merged column. The other columns of Jd are
    exact zeros, and so are their rows and columns of the element Jacobian."""
    count = 0
    groups = 0
    for side in range(2):
        for kind in range(4):
            if kind >= 2:
                knot[side, kind - 2] = -1
            if weights[point + side, kind] == 0.0:
                continue
            size = 3 if kind < 2 else 4
            first = 14 * side + (3 * kind if kind < 2 else 6 + 4 * (kind - 2))
            start = -1
            for other in range(groups):
                o = group_first[other]
                o_size = 3 if (o % 14) < 6 else 4
                if o_size == size and dofs[e, o] == dofs[e, first]:
                    start = group_start[other]
                    break
            if start < 0:
                start = count
                group_first[groups] = first
                group_start[groups] = start
                groups += 1
                for a in range(size):
                    local[count + a] = first + a
                    source[count + a, 0] = first + a
                    source[count + a, 1] = -1
                    for m in range(3):
                        merged[m, count + a] = jd[m, first + a]
                count += size
            else:
                for a in range(size):
                    source[start + a, 1] = first + a
                    for m in range(3):
                        merged[m, start + a] += jd[m, first + a]
            if kind >= 2:
                knot[side, kind - 2] = start
    return count


@njit(cache=True, inline="always")
def _merged_columns(jd: np.ndarray, source: np.ndarray, count: int,
                    merged: np.ndarray) -> None:
    """``_unique_columns``' merged columns of another chord with the same coordinates and
    weighted groups, from the ``source`` it recorded: the same sums in the same order."""
    for k in range(count):
        first, second = source[k, 0], source[k, 1]
        for m in range(3):
            merged[m, k] = jd[m, first]
        if second >= 0:
            for m in range(3):
                merged[m, k] += jd[m, second]


@njit(cache=True)
def evaluate(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
             forms: np.ndarray, tension: float, friction: float, profile: np.ndarray,
             weighted: bool, mu_in: np.ndarray, mu_out: np.ndarray,
             entry_forms: np.ndarray, entry_slope: np.ndarray, split: np.ndarray,
             scale: float, want_force: bool,
             force: np.ndarray, force_target: np.ndarray, want_jacobian: bool,
             jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    """F and ∂F/∂x of every chord of one tendon (``_evaluate_tendon``)."""
    _evaluate_tendon(x, dofs, weights, constant, forms, tension, friction, profile, weighted,
                     mu_in, mu_out, entry_forms, entry_slope, split, scale, want_force, force,
                     force_target, want_jacobian, jacobian, jacobian_target, True)


@njit(cache=True, inline="always")
def _chord_block(merged: np.ndarray, u: np.ndarray, pull: float, length: float, count: int,
                 knot: np.ndarray, forms: np.ndarray, a_point: int, q: np.ndarray,
                 n: np.ndarray, gq: np.ndarray, g: np.ndarray, weights: np.ndarray,
                 pj: np.ndarray, proj: np.ndarray, block: np.ndarray,
                 curvature: np.ndarray) -> None:
    """Minus a chord's element Jacobian at frozen tension, on its distinct columns, into
    ``block``: Jdᵀ P Jd plus its points' curvature, as ``_evaluate_tendon`` builds it (for
    ``evaluate_group``'s chords with the friction coupling)."""
    factor = pull / length
    for a in range(3):
        for b in range(3):
            proj[a, b] = ((1.0 if a == b else 0.0) - u[a] * u[b]) * factor
    for k in range(count):
        j0, j1, j2 = merged[0, k], merged[1, k], merged[2, k]
        for a in range(3):
            pj[a, k] = proj[a, 0] * j0 + proj[a, 1] * j1 + proj[a, 2] * j2
    for k in range(count):
        j0, j1, j2 = merged[0, k], merged[1, k], merged[2, k]
        for j in range(k, count):
            value = j0 * pj[0, j] + j1 * pj[1, j] + j2 * pj[2, j]
            block[k, j] = value
            block[j, k] = value
    for side in range(2):
        point = a_point + side
        _curvature(forms, point, u, q, n, gq, g, pull if side == 1 else -pull, curvature)
        for a in range(2):
            ka = knot[side, a]
            if ka < 0:
                continue
            for b in range(2):
                kb = knot[side, b]
                if kb < 0:
                    continue
                weight = weights[point, 2 + a] * weights[point, 2 + b]
                for i in range(4):
                    for j in range(4):
                        block[ka + i, kb + j] += weight * curvature[i, j]


@njit(cache=True, inline="always")
def _chord(p: np.ndarray, jac: np.ndarray, a_point: int, u: np.ndarray,
           jd: np.ndarray) -> float:
    """The chord from point ``a_point`` to the next: u = d/|d| and Jd = [−J_A, J_B] in
    place; returns |d|."""
    length = 0.0
    for m in range(3):
        u[m] = p[a_point + 1, m] - p[a_point, m]
        length += u[m] * u[m]
    length = np.sqrt(length)
    for m in range(3):
        u[m] /= length
        for a in range(14):
            jd[m, a] = -jac[a_point, m, a]
            jd[m, 14 + a] = jac[a_point + 1, m, a]
    return length


@njit(cache=True, inline="always")
def _chord_force(jd: np.ndarray, u: np.ndarray, pull: float, out: np.ndarray) -> None:
    """A chord's force −τ Jdᵀ u into ``out`` (28,)."""
    for a in range(28):
        value = 0.0
        for m in range(3):
            value += jd[m, a] * u[m]
        out[a] = -pull * value


@njit(cache=True, inline="always")
def _add_coupled(summed: np.ndarray, unit_force: np.ndarray, gradient: np.ndarray,
                 block: np.ndarray, scale: float, count: int) -> None:
    """``summed`` += a chord with the friction coupling: f ⊗ ∂τ/∂x minus its block at
    frozen tension (``_chord_block``), times the tendon's scale."""
    for k in range(count):
        f = unit_force[k]
        for j in range(count):
            summed[k, j] += scale * (f * gradient[j] - block[k, j])


@njit(cache=True, inline="always")
def _group_tensions(x: np.ndarray, chord_start: np.ndarray, point_start: np.ndarray,
                    dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
                    forms: np.ndarray, tension: np.ndarray, friction: np.ndarray,
                    profile: np.ndarray, weighted: np.ndarray, mu_in: np.ndarray,
                    mu_out: np.ndarray, entry_forms: np.ndarray, entry_slope: np.ndarray,
                    split: np.ndarray, scales: np.ndarray, p: np.ndarray, jac: np.ndarray,
                    q: np.ndarray, n: np.ndarray, gq: np.ndarray, g: np.ndarray,
                    chord_tension: np.ndarray, rate: np.ndarray, axis: np.ndarray,
                    slide: np.ndarray, term_of: np.ndarray, active: np.ndarray) -> None:
    """``evaluate_group``'s first pass, tendon by tendon: each chord's tendon
    (``term_of``), whether the tendon adds anything (``active``), and for those that do
    their points' geometry and their chords' tensions (``_points_into``, ``_tensions``), in
    place."""
    for t in range(tension.shape[0]):
        c0, c1 = chord_start[t], chord_start[t + 1]
        p0, p1 = point_start[t], point_start[t + 1]
        for c in range(c0, c1):
            term_of[c] = t
        if scales[t] == 0.0 or tension[t] == 0.0:
            continue  # scaled away, or a slack tendon: every entry is zero
        active[t] = True
        _points_into(x, dofs[c0:c1], weights[p0:p1], constant[p0:p1], forms[p0:p1],
                     p[p0:p1], jac[p0:p1], q[p0:p1], n[p0:p1], gq[p0:p1], g[p0:p1])
        _tensions(x, dofs[c0:c1], weights[p0:p1], constant[p0:p1], entry_forms,
                  entry_slope[t], split[p0:p1], p[p0:p1], tension[t], friction[t],
                  profile[c0:c1], weighted[t], mu_in[c0:c1], mu_out[c0:c1],
                  chord_tension[c0:c1], rate[c0:c1], axis[t], slide[c0:c1])


@njit(cache=True, inline="always")
def _add_block(jacobian: np.ndarray, target: np.ndarray, local: np.ndarray, count: int,
               block: np.ndarray) -> None:
    """A summed block on a chord's distinct columns into the CSC data, each entry once."""
    for k in range(count):
        row = target[local[k]]
        for j in range(count):
            jacobian[row[local[j]]] += block[k, j]


@njit(cache=True, inline="always")
def _symmetric(shared_order: np.ndarray, start: int, stop: int, rate: np.ndarray) -> bool:
    """Whether no chord of a set has the friction coupling (its rate is 0): the set's
    block is then symmetric and summed on and above its diagonal (``_string_block``)."""
    for position in range(start, stop):
        if rate[shared_order[position]] != 0.0:
            return False
    return True


@njit(cache=True, inline="always")
def _add_forces(force: np.ndarray, force_target: np.ndarray, chord_start: np.ndarray,
                active: np.ndarray, chord_force: np.ndarray, scales: np.ndarray) -> None:
    """The chords' forces of the active tendons into F, tendon by tendon, chord by chord
    (the order of one call per tendon)."""
    for t in range(active.shape[0]):
        if active[t]:
            for c in range(chord_start[t], chord_start[t + 1]):
                add_force(force, force_target, c, chord_force[c], scales[t])


@njit(cache=True)
def evaluate_group(x: np.ndarray, chord_start: np.ndarray, point_start: np.ndarray,
                   shared_order: np.ndarray, shared_start: np.ndarray,
                   dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
                   forms: np.ndarray, tension: np.ndarray, friction: np.ndarray,
                   profile: np.ndarray, weighted: np.ndarray, mu_in: np.ndarray,
                   mu_out: np.ndarray, entry_forms: np.ndarray, entry_slope: np.ndarray,
                   split: np.ndarray, scales: np.ndarray, want_force: bool,
                   force: np.ndarray, force_target: np.ndarray, want_jacobian: bool,
                   jacobian: np.ndarray, jacobian_target: np.ndarray) -> None:
    """F and ∂F/∂x of the tendons of a group in one call (``TendonString.group_arguments``:
    tendon t's rows are chords ``chord_start[t]`` to ``chord_start[t + 1]`` and points
    ``point_start[t]`` to ``point_start[t + 1]`` of the stacked arrays). A tendon whose
    scale or tension is 0 adds nothing, as its own call would.

    The chords of the group that lie on the same coordinates with the same weighted groups
    (the tendons of a catheter between the same two nodes: ``shared_order`` lists the
    chords so, each such set from ``shared_start[i]`` to ``shared_start[i + 1]``) have the
    same distinct columns and Jacobian slots: their element Jacobians are summed in one
    local block, which is written into the CSC data once (on tdcr-two-segment 60 writes of
    18 × 18 entries for the 270 chords of the six tendons). A chord's Jdᵀ P Jd and
    curvature, with its tendon's scale taken into P's factor and the curvature's, are
    subtracted from that block as they are formed (no block of its own), on and above its
    diagonal where no chord of the set has the friction coupling (the block is symmetric,
    each entry written into both of its CSC slots: rodsim/core/kernels/_string_block.py);
    a chord with the coupling builds its own (``_chord_block``) and adds it with the
    coupling into the full block. The
    distinct columns are found on a set's first chord and repeated on the others
    (``_merged_columns``). Each chord's force is the one ``evaluate`` computes and is added
    in the order of one call per tendon (tendon by tendon, chord by chord): F bitwise as one
    call per tendon; ∂F/∂x to round-off (the sums are grouped differently)."""
    terms = tension.shape[0]
    chords_all = dofs.shape[0]
    points_all = weights.shape[0]
    p = np.empty((points_all, 3))
    jac = np.empty((points_all, 3, 14))
    q = np.empty((points_all, 4))
    n = np.empty(points_all)
    gq = np.empty((points_all, 3, 4))
    g = np.empty((points_all, 3))
    chord_tension = np.empty(chords_all)
    rate = np.zeros(chords_all)
    axis = np.zeros((terms, 3))
    term_of = np.empty(chords_all, dtype=np.int64)
    active = np.zeros(terms, dtype=np.bool_)
    _group_tensions(x, chord_start, point_start, dofs, weights, constant, forms, tension,
                    friction, profile, weighted, mu_in, mu_out, entry_forms, entry_slope,
                    split, scales, p, jac, q, n, gq, g, chord_tension, rate, axis,
                    np.empty(chords_all), term_of, active)
    chord_force = np.empty((chords_all, 28))
    local = np.empty(28, dtype=np.int64)
    knot = np.empty((2, 2), dtype=np.int64)
    group_first = np.empty(8, dtype=np.int64)
    group_start = np.empty(8, dtype=np.int64)
    source = np.empty((28, 2), dtype=np.int64)
    jd = np.empty((3, 28))
    merged = np.empty((3, 28))
    pj = np.empty((3, 28))
    block = np.empty((28, 28))
    summed = np.empty((28, 28))
    curvature = np.empty((4, 4))
    u = np.empty(3)
    proj = np.empty((3, 3))
    slope = np.empty(3)
    gradient = np.empty(28)
    unit_force = np.empty(28)
    for shared in range(shared_start.shape[0] - 1):
        count = 0
        members = 0
        target_chord = 0
        upper = _symmetric(shared_order, shared_start[shared], shared_start[shared + 1], rate)
        for position in range(shared_start[shared], shared_start[shared + 1]):
            c = shared_order[position]
            t = term_of[c]
            if not active[t]:
                continue
            scale = scales[t]
            a_point = point_start[t] + c - chord_start[t]
            pull = chord_tension[c]
            length = _chord(p, jac, a_point, u, jd)
            if want_force:
                _chord_force(jd, u, pull, chord_force[c])
            if not want_jacobian:
                continue
            if members == 0:
                count = _unique_columns(dofs, weights, c, a_point, jd, local, merged, knot,
                                        group_first, group_start, source)
                summed[:count, :count] = 0.0
            else:
                _merged_columns(jd, source, count, merged)
            members += 1
            target_chord = c
            coupled = False
            if rate[c] != 0.0:
                coupled = _one_way_coupling(merged, u, length, axis[t], rate[c], count,
                                            slope, gradient, unit_force)
            if coupled:
                _chord_block(merged, u, pull, length, count, knot, forms, a_point, q, n, gq,
                             g, weights, pj, proj, block, curvature)
                _add_coupled(summed, unit_force, gradient, block, scale, count)
                continue
            subtract_frozen(merged, u, scale * pull / length, count, pj, proj, summed,
                            upper)
            for side in range(2):
                subtract_curvature(forms, a_point + side, side, u, q, n, gq, g, weights, knot,
                                   scale * pull if side == 1 else -(scale * pull), curvature,
                                   summed, upper)
        if members > 0 and upper:
            add_upper(jacobian, jacobian_target, target_chord, local, count, summed)
        elif members > 0:
            _add_block(jacobian, jacobian_target[target_chord], local, count, summed)
    if want_force:
        _add_forces(force, force_target, chord_start, active, chord_force, scales)


@njit(cache=True)
def _evaluate_tendon(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray,
                     constant: np.ndarray, forms: np.ndarray, tension: float, friction: float,
                     profile: np.ndarray, weighted: bool, mu_in: np.ndarray,
                     mu_out: np.ndarray, entry_forms: np.ndarray, entry_slope: np.ndarray,
                     split: np.ndarray, scale: float, want_force: bool, force: np.ndarray,
                     force_target: np.ndarray, want_jacobian: bool, jacobian: np.ndarray,
                     jacobian_target: np.ndarray, own: bool) -> None:
    """F and ∂F/∂x of every chord (module docstring); without ``own`` the Jacobian at
    frozen tensions only (the span element adds the whole coupling itself). A chord's
    Jacobian is built from its small parts on its distinct coordinates
    (``_unique_columns``: up to 18 of the 28, the knot and the node its two points share
    taken once): M = Jdᵀ P Jd, P = T (I − u uᵀ)/|d|,
    on and above the diagonal and mirrored (the product is symmetric), plus each point's
    curvature T Σ_m u_m ∂²p[m] (``_curvature``, from the point's q, n, G q and g), minus
    the friction coupling's outer product; each entry is written once."""
    if tension == 0.0:
        return  # a slack tendon: every entry is zero (its tension is a factor of each)
    chords = dofs.shape[0]
    local_force = np.empty(28)
    local = np.empty(28, dtype=np.int64)
    knot = np.empty((2, 2), dtype=np.int64)
    group_first = np.empty(8, dtype=np.int64)
    group_start = np.empty(8, dtype=np.int64)
    source = np.empty((28, 2), dtype=np.int64)
    jd = np.empty((3, 28))
    merged = np.empty((3, 28))
    pj = np.empty((3, 28))
    block = np.empty((28, 28))
    curvature = np.empty((4, 4))
    u = np.empty(3)
    proj = np.empty((3, 3))
    p, jac, q, n, gq, g = _points(x, dofs, weights, constant, forms)
    chord_tension = np.empty(chords)
    rate = np.zeros(chords)
    axis = np.zeros(3)
    _tensions(x, dofs, weights, constant, entry_forms, entry_slope, split, p, tension,
              friction, profile, weighted, mu_in, mu_out, chord_tension, rate, axis,
              np.empty(chords))
    slope = np.empty(3)
    gradient = np.empty(28)
    unit_force = np.empty(28)
    for e in range(chords):
        pull = chord_tension[e]
        length = _chord(p, jac, e, u, jd)
        if want_force:
            _chord_force(jd, u, pull, local_force)
            add_force(force, force_target, e, local_force, scale)
        if not want_jacobian:
            continue
        count = _unique_columns(dofs, weights, e, e, jd, local, merged, knot, group_first,
                                group_start, source)
        _chord_block(merged, u, pull, length, count, knot, forms, e, q, n, gq, g, weights, pj,
                     proj, block, curvature)
        coupled = False
        if own and rate[e] != 0.0:
            coupled = _one_way_coupling(merged, u, length, axis, rate[e], count, slope,
                                        gradient, unit_force)
        target = jacobian_target[e]
        for k in range(count):
            row = target[local[k]]
            if coupled:
                f = unit_force[k]
                for j in range(count):
                    jacobian[row[local[j]]] += scale * (f * gradient[j] - block[k, j])
            else:
                for j in range(count):
                    jacobian[row[local[j]]] -= scale * block[k, j]


@njit(cache=True)
def energy(x: np.ndarray, dofs: np.ndarray, weights: np.ndarray, constant: np.ndarray,
           forms: np.ndarray, tension: float, friction: float, profile: np.ndarray,
           weighted: bool, mu_in: np.ndarray, mu_out: np.ndarray,
           entry_forms: np.ndarray, entry_slope: np.ndarray, split: np.ndarray) -> float:
    """T Σ |p_{k+1} − p_k| (frictionless; with friction the model asks for no energy)."""
    if tension == 0.0:
        return 0.0
    return tension * path_length(x, dofs, weights, constant, forms)

"""The necessity judge's LA-RRT loop, compiled: the same run as :meth:`solver.planning.la_rrt.LaRrt.solve`.

The judge (:mod:`solver.validation.judge`) runs LA-RRT with pushes until its first
solution or until a budget of collision queries is spent, thousands of times
per dataset. In Python most of that time was the loop's own bookkeeping, not
collision checking; here the loop of :class:`~solver.planning.la_rrt.LaRrt` for that
case (staircase extensions, goal roots drawn without a goal source, until the
first solution) runs as one compiled call. It makes the same random draws in
the same order from the same numpy Generator (numba's Generator methods share
the generator's state and reproduce numpy's streams), the same collision
queries in the same order, and the same floating-point operations, so every
verdict, path and query count equals the Python loop's: the puzzles stay
byte-identical (``tests/test_judge_loop.py`` compares both loops).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from solver.collision.kernels import _pair_collides, _poses, _state_valid, check_states
from solver.planning._judge_motion import count_bound, motion_buffers, motion_hit_in

_REACHED, _ADVANCED, _TRAPPED = 0, 1, 2  # as in solver.planning.la_rrt


@njit(cache=True, nogil=True)
def nearest_node(states, tree, size, query, weights):
    """:func:`~solver.collision.kernels.nearest_l1` of ``states[tree][:size]``: the lowest index of the nodes
    nearest ``query`` in weighted L1, each distance the same sum in the same order. Every node's sum is taken
    whole: nearest_l1 stops a sum once it reaches the best, which never changes the answer (the partial sums
    only grow) but costs a mispredicted branch a node, and the scan was a third of a failing search's time."""
    best, best_distance = 0, np.inf
    for i in range(size):
        distance = 0.0
        for j in range(query.shape[0]):
            distance += weights[j] * abs(states[tree, i, j] - query[j])
        if distance < best_distance:
            best, best_distance = i, distance
    return best


@njit(cache=True, nogil=True)
def _draw(rng, lower, upper, limit_probability):
    n = lower.shape[0]
    u = rng.random(3 * n)
    values = lower + (upper - lower) * u[:n]
    for j in range(n):
        if u[n + j] < limit_probability:
            values[j] = upper[j] if u[2 * n + j] < 0.5 else lower[j]
    return values


@njit(cache=True, nogil=True)
def _add(states, parents, sizes, tree, state, parent):
    k = sizes[tree]
    states[tree, k] = state
    parents[tree, k] = parent
    sizes[tree] = k + 1
    return k


@njit(cache=True, nogil=True)
def _branch(states, parents, tree, node):
    count, k = 0, node
    while k >= 0:
        count += 1
        k = parents[tree, k]
    out = np.empty((count, states.shape[2]))
    k = node
    for i in range(count - 1, -1, -1):
        out[i] = states[tree, k]
        k = parents[tree, k]
    return out


@njit(cache=True, nogil=True)
def connection_path(states, parents, growing, new, other, reached):
    """The path through a connection (LaRrt._path): the start tree's branch to its node, then the goal
    tree's branch from its node back to its root, the joined node once."""
    a = _branch(states, parents, growing, new)
    b = _branch(states, parents, other, reached)
    if growing == 1:
        a, b = b, a
    path = np.empty((a.shape[0] + b.shape[0] - 1, states.shape[2]))
    path[:a.shape[0]] = a
    for i in range(b.shape[0] - 1):
        path[a.shape[0] + i] = b[b.shape[0] - 2 - i]
    return path


@njit(cache=True, nogil=True)
def new_trees(start, capacity):
    """The two trees of a run (states, parents, sizes): the start tree holds ``start``, the goal tree nothing."""
    states = np.empty((2, capacity, start.shape[0]))
    parents = np.empty((2, capacity), dtype=np.int64)
    sizes = np.zeros(2, dtype=np.int64)
    _add(states, parents, sizes, 0, start, -1)
    return states, parents, sizes


@njit(cache=True, nogil=True)
def run(rng, start, lower, upper, goal_columns, goal_values, weights, extension_range, steps, fine_steps,
        factor_columns, factor_sizes, pair_objects, object_factor, limit_probability, single_probability,
        goal_root_probability, goal_attempts, max_pushes, push_attempts, budget, queries, capacity,
        kin_int, kin_float, n_links, shape_link, shape_nv, shape_center, shape_radius, shape_verts,
        shape_normals, shape_extent, pairs, tol, pair_columns, shape_rho):
    """LA-RRT with pushes from ``start`` until a connection whose path holds at ``fine_steps`` or
    until ``queries`` reach ``budget``, in one call. Returns (path or an empty array, iterations,
    queries, clipped). ``factor_columns`` (F, k) lists each factor's state columns (padded with -1,
    ``factor_sizes`` of them); ``pair_objects`` (P, 2) the object of each collision pair's shapes,
    numbered in name order; ``object_factor`` the factor of each object (-1: it has none)."""
    states, parents, sizes = new_trees(start, capacity)
    path, iterations, queries, clipped, _, _ = resume(
        rng, states, parents, sizes, 0, 0, 0, 1, budget, lower, upper, goal_columns, goal_values, weights,
        extension_range, steps, fine_steps, factor_columns, factor_sizes, pair_objects, object_factor,
        limit_probability, single_probability, goal_root_probability, goal_attempts, max_pushes, push_attempts,
        queries, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center, shape_radius,
        shape_verts, shape_normals, shape_extent, pairs, tol, pair_columns, shape_rho)
    return path, iterations, queries, clipped


@njit(cache=True, nogil=True)
def resume(rng, states, parents, sizes, iterations, clipped, growing, other, stop, lower, upper, goal_columns,
           goal_values, weights, extension_range, steps, fine_steps, factor_columns, factor_sizes, pair_objects,
           object_factor, limit_probability, single_probability, goal_root_probability, goal_attempts, max_pushes,
           push_attempts, queries, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
           shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol, pair_columns, shape_rho):
    """The loop of :func:`run` from the trees and counters a call before left, until a path is found
    or ``queries`` reach ``stop`` (the budget, or a step towards it). Returns (path or an empty array,
    iterations, queries, clipped, growing, other), the counters to resume from. ``stop`` is tested
    only at the top of an iteration, as the budget is, so a run cut into pieces at any stops makes
    the same iterations, draws and queries as one call of :func:`run`: the caller gets control back
    between pieces (a Ctrl-C is then handled at once, not after the whole run)."""
    d = states.shape[2]
    candidates = np.empty((goal_attempts, d))
    # One set of buffers for every motion check and push test of this call (a motion beyond count_bound's
    # samples, a fine path check, gets its own): allocations were a fifth of a push's time.
    mf, mi, ml = motion_buffers(count_bound(lower, upper, steps), d, n_links, pairs.shape[0], shape_link.shape[0])
    work = np.empty((5, n_links))
    centres = np.empty((2, shape_link.shape[0]))
    n_objects = object_factor.shape[0]
    touched = np.empty(n_objects, dtype=np.bool_)
    pushable = np.empty(n_objects, dtype=np.int64)
    blocked = np.empty(d)
    while queries < stop:
        iterations += 1
        # -- a goal root (LaRrt._wants_goal_root, _add_goal_root without a goal source)
        if sizes[1] == 0 or rng.random() < goal_root_probability:
            uniform = rng.random(goal_attempts * d)
            picks = rng.integers(0, sizes[0], goal_attempts)
            for batch in range(2):
                for i in range(goal_attempts):
                    for j in range(d):
                        if batch == 0:
                            candidates[i, j] = lower[j] + (upper[j] - lower[j]) * uniform[i * d + j]
                        else:
                            candidates[i, j] = states[0, picks[i], j]
                    for g in range(goal_columns.shape[0]):
                        candidates[i, goal_columns[g]] = goal_values[g]
                queries += 1
                valid = check_states(candidates, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
                                     shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol)
                found = -1
                for i in range(goal_attempts):
                    if valid[i]:
                        found = i
                        break
                if found >= 0:
                    _add(states, parents, sizes, 1, candidates[found].copy(), -1)
                    break
        if sizes[1] == 0:
            growing = 0
        sample = _draw(rng, lower, upper, limit_probability)
        near = nearest_node(states, growing, sizes[growing], sample, weights)
        single = rng.random() < single_probability
        status, new, queries = _staircase(
            rng, states, parents, sizes, growing, near, sample, extension_range, single, lower, upper, weights, steps,
            factor_columns, factor_sizes, pair_objects, object_factor, max_pushes, push_attempts, queries,
            kin_int, kin_float, n_links, shape_link, shape_nv, shape_center, shape_radius, shape_verts,
            shape_normals, shape_extent, pairs, tol, pair_columns, shape_rho, mf, mi, ml, work, centres, touched,
            pushable, blocked)
        if new != near and sizes[other] > 0:
            target = states[growing, new].copy()
            status, reached, queries = _staircase(
                rng, states, parents, sizes, other, nearest_node(states, other, sizes[other], target, weights),
                target, np.inf, False, lower, upper, weights, steps, factor_columns, factor_sizes, pair_objects,
                object_factor, max_pushes, push_attempts, queries, kin_int, kin_float, n_links, shape_link,
                shape_nv, shape_center, shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol,
                pair_columns, shape_rho, mf, mi, ml, work, centres, touched, pushable, blocked)
            if status == _REACHED:
                path = connection_path(states, parents, growing, new, other, reached)
                holds = True
                for i in range(path.shape[0] - 1):
                    queries += 1
                    if motion_hit_in(mf, mi, ml, path[i], path[i + 1], fine_steps, kin_int, kin_float, n_links,
                                     shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
                                     shape_extent, pairs, tol, pair_columns, shape_rho) >= 0:
                        holds = False
                        break
                if holds:
                    return path, iterations, queries, clipped, growing, other
                clipped += 1
        if sizes[1] > 0:
            growing, other = other, growing
    return np.empty((0, d)), iterations, queries, clipped, growing, other


@njit(cache=True, nogil=True)
def _staircase(rng, states, parents, sizes, tree, node, target, budget, single, lower, upper, weights, steps,
               factor_columns, factor_sizes, pair_objects, object_factor, max_pushes, push_attempts, queries,
               kin_int, kin_float, n_links, shape_link, shape_nv, shape_center, shape_radius, shape_verts,
               shape_normals, shape_extent, pairs, tol, pair_columns, shape_rho, mf, mi, ml, work, centres, touched,
               candidates, blocked):
    """LaRrt._staircase with LaRrt._push_blocker: returns (status, last node added or ``node``, queries).
    ``mf``, ``mi``, ``ml``: motion_hit_in's buffers; ``work`` (5, links), ``centres``, ``touched``,
    ``candidates`` (per object) and ``blocked`` (a state): the push's, every entry written before it is read."""
    n_factors = factor_sizes.shape[0]
    current = states[tree, node].copy()
    order = rng.permutation(n_factors)
    queue = np.empty(n_factors + max_pushes, dtype=np.int64)  # a pushed factor is queued again at most once a push
    head, tail = 0, 0
    for k in range(1 if single else n_factors):
        queue[tail] = order[k]
        tail += 1
    pushes = 0
    moved = np.zeros(n_factors, dtype=np.bool_)
    while head < tail:
        f = queue[head]
        head += 1
        count = factor_sizes[f]
        distance = 0.0
        for k in range(count):
            c = factor_columns[f, k]
            distance += abs(target[c] - current[c]) * weights[c]
        if distance <= 1e-12:
            continue
        partial = distance > budget
        values = np.empty(count)
        scale = budget / distance
        for k in range(count):
            c = factor_columns[f, k]
            values[k] = current[c] + (target[c] - current[c]) * scale if partial else target[c]
        following = current.copy()
        for k in range(count):
            following[factor_columns[f, k]] = values[k]
        queries += 1
        hit = motion_hit_in(mf, mi, ml, current, following, steps, kin_int, kin_float, n_links, shape_link,
                            shape_nv, shape_center, shape_radius, shape_verts, shape_normals, shape_extent, pairs,
                            tol, pair_columns, shape_rho)
        if hit >= 0:
            if pushes >= max_pushes:
                return _TRAPPED, node, queries
            # -- LaRrt._push_blocker: move aside the movable object the move hits
            for j in range(current.shape[0]):
                blocked[j] = current[j] + hit * (following[j] - current[j])
            queries += 1
            if _touches_static(blocked, f, moved, pair_objects, object_factor, touched, work, kin_int,
                               kin_float, shape_link, shape_nv, shape_center, shape_radius, shape_verts,
                               shape_normals, shape_extent, pairs, tol):
                return _TRAPPED, node, queries
            n_candidates = 0
            static = False
            for o in range(object_factor.shape[0]):  # objects are numbered in name order, as sorted() sees them
                if touched[o]:
                    g = object_factor[o]
                    if g < 0:
                        static = True
                    elif g != f and not moved[g]:
                        candidates[n_candidates] = g
                        n_candidates += 1
            if static or n_candidates == 0:
                return _TRAPPED, node, queries
            g = candidates[rng.integers(0, n_candidates)]
            size = factor_sizes[g]
            low = np.empty(size)
            high = np.empty(size)
            for k in range(size):
                low[k] = lower[factor_columns[g, k]]
                high[k] = upper[factor_columns[g, k]]
            pushed = False
            aside = current
            for _ in range(push_attempts):
                aside = current.copy()
                drawn = _draw(rng, low, high, 2 / 3)
                for k in range(size):
                    aside[factor_columns[g, k]] = drawn[k]
                freed = aside.copy()
                for k in range(count):
                    freed[factor_columns[f, k]] = values[k]
                if not _state_valid(aside, kin_int, kin_float, work[0], work[1], work[2], work[3], work[4], centres,
                                    True, shape_link, shape_nv, shape_center, shape_radius, shape_verts,
                                    shape_normals, shape_extent, pairs, tol):
                    continue  # (an unmoved check, not a query: LaRrt's is_valid is not counted either)
                queries += 1
                if motion_hit_in(mf, mi, ml, aside, freed, steps, kin_int, kin_float, n_links, shape_link, shape_nv,
                                 shape_center, shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol,
                                 pair_columns, shape_rho) >= 0:
                    continue
                queries += 1
                if motion_hit_in(mf, mi, ml, current, aside, steps, kin_int, kin_float, n_links, shape_link, shape_nv,
                                 shape_center, shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol,
                                 pair_columns, shape_rho) >= 0:
                    continue
                pushed = True
                break
            if not pushed:
                return _TRAPPED, node, queries
            node = _add(states, parents, sizes, tree, aside, node)
            current = aside
            pushes += 1
            if not single:
                queued = False
                for k in range(head, tail):
                    if queue[k] == g:
                        queued = True
                        break
                if not queued:
                    queue[tail] = g
                    tail += 1
            following = current.copy()
            for k in range(count):
                following[factor_columns[f, k]] = values[k]
        node = _add(states, parents, sizes, tree, following, node)
        current = following
        moved[f] = True
        if partial:
            return _ADVANCED, node, queries
        budget -= distance
    return _REACHED, node, queries


@njit(cache=True, nogil=True)
def _touches_static(q, f, moved, pair_objects, object_factor, touched, work, kin_int, kin_float, shape_link,
                    shape_nv, shape_center, shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol):
    """LaRrt._push_blocker's colliding pairs at ``q`` (pair_hits'), as far as they decide the push: True where
    one touches a static object (the push is trapped, whatever else collides); else ``touched`` marks every
    object a colliding pair touches among those that could be pushed (a factor other than ``f``, not
    ``moved``). Only those objects' marks are read after, so a pair is tested only while one of its objects
    is static or such an object not yet marked, by pair_hits' own test."""
    _poses(q, kin_int, kin_float, work[0], work[1], work[2], work[3], work[4], True)
    touched[:] = False
    for p in range(pairs.shape[0]):
        oa, ob = pair_objects[p, 0], pair_objects[p, 1]
        ga, gb = object_factor[oa], object_factor[ob]
        wanted = ga < 0 or gb < 0
        if not wanted and not touched[oa] and ga != f and not moved[ga]:
            wanted = True
        if not wanted and not touched[ob] and gb != f and not moved[gb]:
            wanted = True
        if not wanted:
            continue
        if _pair_collides(pairs[p, 0], pairs[p, 1], work[0], work[1], work[2], work[3], shape_link, shape_nv,
                          shape_center, shape_radius, shape_verts, shape_normals, shape_extent, tol, tol):
            if ga < 0 or gb < 0:
                return True
            touched[oa] = True
            touched[ob] = True
    return False

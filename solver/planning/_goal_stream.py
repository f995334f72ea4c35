"""The goal sampler's search for its next state (:meth:`solver.planning.goal_sampling.GoalSampler.next`), compiled.

Where a run's goal region is hard to reach (a lockbox with a lock fixed), the second necessity judge spends
its whole budget here: blocks of uniform candidates, then min-conflicts repairs of a few checked states
each, ten thousand small calls a run in Python. Here one call finds the next state. It draws the same
numbers from the sampler's numpy Generator in the same order (numba's Generator methods share its state
and reproduce numpy's streams: a (rows, columns) block is the same stream as rows * columns numbers), asks
the same kernels the same questions (the validity of a batch, the colliding pairs of one state, of each
of a batch) and pays the same checks to the same budgets, so the stream (its states, checks, candidates
and where a run's budget cut it) is the Python sampler's (``tests/test_compiled_second_judge.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from solver.collision.kernels import _pair_collides, _poses, _unpacked, check_states, pair_hits_packed

# Counters of a stream, one int64 array shared with Python between calls.
NEXT, ROWS, CANDIDATES, CHECKED, REPAIRED, BUDGET_SPENT, CUT, STATES, SPENT, RUN_SPENT = range(10)
COUNTERS = 10
# The sampler's settings and its run's limits, one int64 array.
CAPACITY, BUDGET, BATCH, ROUNDS, DRAWS, HAS_RUN, RUN_BUDGET, RUN_ENDED = range(8)


@njit(cache=True, nogil=True, inline="always")
def _spend(counters, limits, states):
    """GoalSampler._spend: charge ``states`` checks to the sampler's budget and its run's; False (the stream
    ends) when either does not hold them."""
    if counters[CHECKED] + states > limits[BUDGET]:
        counters[BUDGET_SPENT] = 1
        return False
    if limits[HAS_RUN] and (limits[RUN_ENDED] or counters[RUN_SPENT] >= limits[RUN_BUDGET]
                            or counters[RUN_SPENT] + states > limits[RUN_BUDGET]):
        counters[CUT] = 1
        return False
    counters[CHECKED] += states
    counters[RUN_SPENT] += states
    counters[SPENT] += states
    return True


@njit(cache=True, nogil=True)
def _pair_count(hits, pair_objects, seen):
    """How many distinct object pairs ``hits`` holds (the size of ``colliding_objects``'s set)."""
    seen[:] = False
    count = 0
    for p in range(hits.shape[0]):
        if hits[p]:
            a, b = pair_objects[p, 0], pair_objects[p, 1]
            if a > b:
                a, b = b, a
            if not seen[a, b]:
                seen[a, b] = True
                count += 1
    return count


@njit(cache=True, nogil=True)
def _draw_hits(draws, hits, columns, size, ints, floats, pair_columns):
    """The colliding pairs of each of ``draws`` (:func:`~solver.collision.kernels.pair_hits_rows`'s answer), where
    every draw is the state whose pairs are ``hits`` with only ``columns[:size]`` changed: a pair that none of
    them moves keeps its answer (its shapes' poses are computed from the same numbers), the others are tested
    as ``pair_hits_rows`` tests them."""
    (kin_int, kin_float, shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
     shape_extent, pairs, tol, poses) = _unpacked(ints, floats)
    x, y, c, s, yaws = poses[0], poses[1], poses[2], poses[3], poses[4]
    moved = np.empty(pairs.shape[0], dtype=np.int64)
    n_moved = 0
    for p in range(pairs.shape[0]):
        for k in range(size):
            if pair_columns[p, columns[k]]:
                moved[n_moved] = p
                n_moved += 1
                break
    rows = np.empty((draws.shape[0], pairs.shape[0]), dtype=np.bool_)
    for i in range(draws.shape[0]):
        rows[i] = hits
        if n_moved == 0:
            continue
        _poses(draws[i], kin_int, kin_float, x, y, c, s, yaws, False)
        for m in range(n_moved):
            p = moved[m]
            rows[i, p] = _pair_collides(pairs[p, 0], pairs[p, 1], x, y, c, s, shape_link, shape_nv, shape_center,
                                        shape_radius, shape_verts, shape_normals, shape_extent, tol, tol)
    return rows


@njit(cache=True, nogil=True)
def _repair(rng, candidate, counters, limits, lower, upper, free_columns, free_sizes, object_free, pair_objects,
            seen, ints, floats, pair_columns):
    """GoalSampler._repair of ``candidate``: the repaired state, or an empty array when the repair fails or
    a budget ends. ``object_free`` holds each object's row of ``free_columns`` (objects numbered in name
    order; -1: no joint the goal leaves free). A draw is valid exactly when none of its pairs collides
    (``check_states`` skips only pairs that test would find apart), so its validity and its colliding
    pairs come from one pair test (:func:`_draw_hits`); the checks are paid as the Python repair pays them."""
    d = candidate.shape[0]
    none = np.empty(0)
    state = candidate.copy()
    if not _spend(counters, limits, 1):
        return none
    hits = pair_hits_packed(state, ints, floats)
    count = _pair_count(hits, pair_objects, seen)
    n_draws = limits[DRAWS]
    involved = np.empty(object_free.shape[0], dtype=np.int64)
    touched = np.empty(object_free.shape[0], dtype=np.bool_)
    for _ in range(limits[ROUNDS]):
        touched[:] = False
        for p in range(hits.shape[0]):
            if hits[p]:
                touched[pair_objects[p, 0]] = True
                touched[pair_objects[p, 1]] = True
        n_involved = 0
        for o in range(object_free.shape[0]):  # in name order, as sorted() lists them
            if touched[o] and object_free[o] >= 0:
                involved[n_involved] = o
                n_involved += 1
        if n_involved == 0:
            return none  # only pinned goal joints or static parts collide: no repair can help
        row = object_free[involved[rng.integers(0, n_involved)]]
        size = free_sizes[row]
        draws = np.empty((n_draws, d))
        for i in range(n_draws):
            draws[i] = state
        u = rng.random(n_draws * size)
        for i in range(n_draws):
            for k in range(size):
                c = free_columns[row, k]
                draws[i, c] = lower[c] + (upper[c] - lower[c]) * u[i * size + k]
        if not _spend(counters, limits, n_draws):
            return none
        rows = _draw_hits(draws, hits, free_columns[row], size, ints, floats, pair_columns)
        for i in range(n_draws):
            if not rows[i].any():
                return draws[i].copy()
        for _ in range(n_draws):  # each draw's colliding pairs, paid one by one
            if not _spend(counters, limits, 1):
                return none
        best, best_count = 0, -1
        for i in range(n_draws):
            found = _pair_count(rows[i], pair_objects, seen)
            if best_count < 0 or found < best_count:
                best, best_count = i, found
        if best_count <= count:  # sideways moves too: plateaus are common
            state = draws[best].copy()
            hits = rows[best].copy()
            count = best_count
    return none


@njit(cache=True, nogil=True)
def next_state(rng, block, valid, counters, limits, lower, upper, goal_columns, goal_values, free_columns,
               free_sizes, object_free, pair_objects, n_objects, ints, floats, pair_columns):
    """GoalSampler.next: the stream's next new state, or an empty array once it is exhausted. ``block`` and
    ``valid`` hold the current block of candidates (``counters[ROWS]`` of them, the next at
    ``counters[NEXT]``); a new block is drawn into them. ``counters[SPENT]`` gets the checks this call paid."""
    (kin_int, kin_float, shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
     shape_extent, pairs, tol, _) = _unpacked(ints, floats)
    n_links = ints[0]
    d = lower.shape[0]
    seen = np.empty((n_objects, n_objects), dtype=np.bool_)
    counters[SPENT] = 0
    while not (counters[STATES] >= limits[CAPACITY] or counters[BUDGET_SPENT] or counters[CUT]):
        if counters[NEXT] == counters[ROWS]:
            batch = limits[BATCH]
            if not _spend(counters, limits, batch):
                break
            u = rng.random(batch * d)
            for i in range(batch):
                for j in range(d):
                    block[i, j] = lower[j] + (upper[j] - lower[j]) * u[i * d + j]
                for g in range(goal_columns.shape[0]):
                    block[i, goal_columns[g]] = goal_values[g]
            valid[:] = check_states(block, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
                                    shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol)
            counters[ROWS] = batch
            counters[NEXT] = 0
        k = counters[NEXT]
        counters[NEXT] += 1
        counters[CANDIDATES] += 1
        if valid[k]:
            state = block[k].copy()
        else:
            state = _repair(rng, block[k], counters, limits, lower, upper, free_columns, free_sizes, object_free,
                            pair_objects, seen, ints, floats, pair_columns)
            if state.shape[0] == 0:
                continue
            counters[REPAIRED] += 1
        counters[STATES] += 1
        return state
    return np.empty(0)

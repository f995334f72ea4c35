"""RRT-Connect compiled, for the short legs of a routed re-plan (:meth:`OmplValidator._replan_routed`).

A routed re-plan (Move N Times) cuts the target's way into legs of about a metre and plans each one as a
small problem of its own: the target alone first (every other joint held), then every joint in a window
around the leg. Through OMPL each leg paid a Python callback per collision query (state checks, motion
checks, goal samples): about 6 microseconds a query, while the compiled kernels answer most in about 1.
Most of those queries were spent by the legs the target cannot finish alone (the door in the way), each to
its whole budget. Here the whole search runs in one compiled call.

This is our own RRT-Connect, not OMPL's, written after OMPL's ``RRTConnect::solve``: the start and goal trees
take turns to extend towards a uniform draw (by at most 0.2 x the space's largest extent, Euclidean), the
other tree then connects towards the new node until it is trapped or reaches it; the goal tree gets a new root
(a goal sample) when it is empty (drawn until one is valid) or when fewer goals were drawn so far than half
its size (drawn once); a state added to the start tree is checked by the motion to it, one added to the goal
tree by its own validity and then the motion from it. Every query counts against the budget (checked before
each iteration, as OMPL checks its termination condition), so the answer is the same on any machine. Its
random numbers come from the caller's numpy Generator; a goal sample puts the goal joints at their goal values
and every other free joint anywhere within limits. Nearest nodes are found by a scan (OMPL uses a GNAT; both
find the nearest). Joints with equal lower and upper limits are held there: the target alone is the puzzle's
own model with every other joint held, so no model is built per held configuration.

A motion is judged by :func:`~solver.collision.skipping_move.motion_ends` (:func:`_skipping_free`): the same
samples and verdicts as a check of every sample (:func:`_motion_free`), those where every pair is proven apart
skipped, after its middle sample (and, for a motion to a new state of the start tree, that state) is asked
alone: a failed extension usually ends in a wall or crosses one. Only the verdicts feed the search, so its
random numbers and paths are those of the check of every sample, at about a third of the cost (Move N Times
n = 3). :func:`shortcut` and :func:`first_colliding_motion` judge a path's motions the same way.

The validator's main solve stays OMPL's RRT-Connect (:func:`solver.planning.ompl_setup.rrt_connect`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numba import njit

from phyrogen_core.maker import SolveResult
from solver.collision.kernels import _motion_hit, _state_valid, _unpacked
from solver.collision.model import CollisionModel
from solver.collision.skipping_move import motion_ends
from solver.planning.problem import Problem

_TRAPPED, _ADVANCED, _REACHED = range(3)
_EXTENT_SHARE = 0.2
"""OMPL's default range of RRT-Connect: this share of the space's largest extent."""


@njit(cache=True, nogil=True)
def _valid(q, model, centres):
    """``state_valid_packed`` on the model unpacked once (the same test on the same numbers)."""
    (kin_int, kin_float, shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
     shape_extent, pairs, tol, poses) = model
    return _state_valid(q, kin_int, kin_float, poses[0], poses[1], poses[2], poses[3], poses[4], centres, False,
                        shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals, shape_extent,
                        pairs, tol)


@njit(cache=True, nogil=True)
def _motion_free(a, b, steps, model, n_links, pair_columns):
    """Not ``motion_collides_packed`` (the same checks)."""
    (kin_int, kin_float, shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
     shape_extent, pairs, tol, _poses) = model
    hit, _ = _motion_hit(a, b, steps, kin_int, kin_float, n_links, shape_link, shape_nv, shape_center,
                         shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol, pair_columns)
    return hit == 0


@njit(cache=True, nogil=True)
def _skipping_free(a, b, steps, model, n_links, pair_columns, rho, scratch):
    """:func:`_motion_free`'s verdict found by :func:`~solver.collision.skipping_move.motion_ends` (the same
    samples, those where every pair is proven apart skipped); ``scratch``: its (1, d) rows and hits."""
    (kin_int, kin_float, shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
     shape_extent, pairs, tol, _poses) = model
    starts, ends, out, hits = scratch
    for j in range(a.shape[0]):
        starts[0, j] = a[j]
        ends[0, j] = b[j]
    motion_ends(starts, ends, steps, False, out, hits, kin_int, kin_float, n_links, shape_link, shape_nv,
                shape_center, shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol, pair_columns, rho)
    return hits[0] < 0.0


@njit(cache=True, nogil=True)
def _middle_valid(a, b, steps, model, centres, q):
    """Whether the middle sample of the motion from ``a`` (valid) to ``b`` is valid: the sample
    ``motion_ends`` and ``_motion_free`` test there, computed as they compute it."""
    count = 1
    for j in range(a.shape[0]):
        need = int(math.ceil(abs(b[j] - a[j]) / steps[j]))
        if need > count:
            count = need
    k = count // 2
    if k < 1:
        return True
    t = k / count
    for j in range(a.shape[0]):
        q[j] = a[j] + (b[j] - a[j]) * t
    return _valid(q, model, centres)


@njit(cache=True, nogil=True)
def _extension_free(a, b, b_valid, steps, model, n_links, pair_columns, centres, rho, scratch):
    """:func:`_motion_free`'s verdict on the motion from ``a`` (valid) to ``b`` (known valid when ``b_valid``):
    ``b``, then the middle sample, then the rest by skipping. A failed extension usually ends in a wall or
    crosses one; the samples are the same, so the verdict is."""
    if not b_valid and not _valid(b, model, centres):
        return False
    return (_middle_valid(a, b, steps, model, centres, scratch[2][0])
            and _skipping_free(a, b, steps, model, n_links, pair_columns, rho, scratch))


@njit(cache=True, nogil=True)
def _grow(states, parents, sizes, tree, target, max_distance, is_start, steps, model, n_links, pair_columns,
          centres, counted, rho, scratch):
    """OMPL's ``growTree``: extend ``tree`` from its node nearest ``target`` towards it; (status, node)."""
    size = sizes[tree]
    if size == states.shape[1]:
        return _TRAPPED, 0  # no room left (never reached within the budget: see connect)
    d = target.shape[0]
    best, best_distance = 0, np.inf
    for i in range(size):
        total = 0.0
        for j in range(d):
            delta = states[tree, i, j] - target[j]
            total += delta * delta
        if total < best_distance:
            best, best_distance = i, total
    near = states[tree, best]
    distance = math.sqrt(best_distance)
    new = states[tree, size]
    reach = True
    if distance > max_distance:
        share = max_distance / distance
        same = True
        for j in range(d):
            new[j] = near[j] + (target[j] - near[j]) * share
            same = same and new[j] == near[j]
        if same:
            return _TRAPPED, best
        reach = False
    else:
        for j in range(d):
            new[j] = target[j]
    counted[0] += 1
    if is_start:
        valid = _extension_free(near, new, False, steps, model, n_links, pair_columns, centres, rho, scratch)
    else:
        valid = _valid(new, model, centres)
        if valid:
            counted[0] += 1
            valid = _extension_free(new, near, True, steps, model, n_links, pair_columns, centres, rho, scratch)
    if not valid:
        return _TRAPPED, best
    parents[tree, size] = best
    sizes[tree] = size + 1
    return (_REACHED if reach else _ADVANCED), size


@njit(cache=True, nogil=True)
def connect(rng, start, goal_columns, goal_values, lower, upper, steps, budget, ints, floats, pair_columns, rho):
    """RRT-Connect from ``start`` to the states with ``goal_columns`` at ``goal_values``, each joint within
    ``lower``/``upper`` (a joint with equal limits is held there), motions checked every ``steps``, until a
    path is found or ``budget`` queries are spent (``start`` is assumed valid: the caller checks it).
    Returns (the path's states, start to goal, an empty array when none, queries spent)."""
    d = start.shape[0]
    model = _unpacked(ints, floats)
    n_links = ints[0]
    centres = np.empty((2, ints[2]))
    extent = 0.0
    free = np.zeros(d, dtype=np.bool_)
    for j in range(d):
        extent += (upper[j] - lower[j]) ** 2
        free[j] = upper[j] > lower[j]
    for k in range(goal_columns.shape[0]):
        free[goal_columns[k]] = False
    max_distance = _EXTENT_SHARE * math.sqrt(extent)
    # Every node costs a query, and one iteration's connection adds at most 1 / share nodes past the budget.
    room = budget + int(math.ceil(1.0 / _EXTENT_SHARE)) + 4
    states = np.empty((2, room, d))
    parents = np.empty((2, room), dtype=np.int64)
    sizes = np.zeros(2, dtype=np.int64)
    states[0, 0] = start
    parents[0, 0] = -1
    sizes[0] = 1
    counted = np.zeros(1, dtype=np.int64)
    sampled_goals = 0
    start_turn = True
    draw = np.empty(d)
    scratch = (np.empty((1, d)), np.empty((1, d)), np.empty((1, d)), np.empty(1))
    while counted[0] < budget:
        tree = 0 if start_turn else 1
        start_turn = not start_turn
        if sizes[1] == 0 or sampled_goals < sizes[1] // 2:
            # A new goal root: drawn until valid while the goal tree is empty, else drawn once.
            while counted[0] < budget:
                root = states[1, sizes[1]]
                for j in range(d):
                    root[j] = lower[j] + (upper[j] - lower[j]) * rng.random() if free[j] else start[j]
                for k in range(goal_columns.shape[0]):
                    root[goal_columns[k]] = goal_values[k]
                sampled_goals += 1
                counted[0] += 1
                if _valid(root, model, centres):
                    parents[1, sizes[1]] = -1
                    sizes[1] += 1
                    break
                if sizes[1] > 0:
                    break
            if sizes[1] == 0:
                break
        for j in range(d):
            draw[j] = lower[j] + (upper[j] - lower[j]) * rng.random() if upper[j] > lower[j] else start[j]
        status, added = _grow(states, parents, sizes, tree, draw, max_distance, tree == 0, steps, model, n_links,
                              pair_columns, centres, counted, rho, scratch)
        if status == _TRAPPED:
            continue
        other = 1 - tree
        reached = states[tree, added].copy()
        status, last = _grow(states, parents, sizes, other, reached, max_distance, other == 0, steps, model,
                             n_links, pair_columns, centres, counted, rho, scratch)
        while status == _ADVANCED:
            status, last = _grow(states, parents, sizes, other, reached, max_distance, other == 0, steps, model,
                                 n_links, pair_columns, centres, counted, rho, scratch)
        if status != _REACHED:
            continue
        start_node, goal_node = (added, last) if tree == 0 else (last, added)
        # Start tree from its root to the meeting state, then the goal tree from the node after the
        # meeting state (its copy there is left out) to its root, a goal sample.
        in_start, node = 0, start_node
        while node >= 0:
            in_start += 1
            node = parents[0, node]
        in_goal, node = 0, parents[1, goal_node]
        while node >= 0:
            in_goal += 1
            node = parents[1, node]
        path = np.empty((in_start + in_goal, d))
        k, node = in_start, start_node
        while node >= 0:
            k -= 1
            path[k] = states[0, node]
            node = parents[0, node]
        k, node = in_start, parents[1, goal_node]
        while node >= 0:
            path[k] = states[1, node]
            k += 1
            node = parents[1, node]
        return path, counted[0]
    return np.empty((0, d)), counted[0]


@njit(cache=True, nogil=True)
def _shortcut_kept(states, steps, ints, floats, pair_columns, rho):
    """The rows :meth:`OmplValidator._shortcut` keeps (from each kept state, the farthest later one a free
    motion reaches, tried farthest first) and the motions it checks, in one compiled call (``states``: a
    leg's path, every state valid)."""
    model = _unpacked(ints, floats)
    d = states.shape[1]
    scratch = (np.empty((1, d)), np.empty((1, d)), np.empty((1, d)), np.empty(1))
    centres = np.empty((2, ints[2]))
    kept = np.empty(states.shape[0], dtype=np.int64)
    kept[0] = 0
    count, checks, i = 1, 0, 0
    while i < states.shape[0] - 1:
        j = states.shape[0] - 1
        while j > i + 1:
            checks += 1
            # A path's states are valid: the motion's middle sample first, as an extension asks.
            if _extension_free(states[i], states[j], True, steps, model, ints[0], pair_columns, centres, rho,
                               scratch):
                break
            j -= 1
        kept[count] = j
        count += 1
        i = j
    return kept[:count], checks


def shortcut(model: CollisionModel, states: np.ndarray, steps: np.ndarray) -> tuple[np.ndarray, int]:
    """``states`` (C-contiguous float64) with every state dropped that a straight motion from an earlier one
    can skip, greedily, farthest first, motions checked as ``model.check_motion`` checks them (the same
    verdicts); the motions checked."""
    ints, floats, pair_columns = model.packed
    kept, checks = _shortcut_kept(states, steps, ints, floats, pair_columns, model._shape_rho)
    return states[kept], int(checks)


@njit(cache=True, nogil=True)
def _first_colliding(states, steps, ints, floats, pair_columns, rho):
    """:func:`first_colliding_motion`, motions judged by :func:`_skipping_free`, in one compiled call."""
    model = _unpacked(ints, floats)
    d = states.shape[1]
    scratch = (np.empty((1, d)), np.empty((1, d)), np.empty((1, d)), np.empty(1))
    for i in range(states.shape[0] - 1):
        if not _skipping_free(states[i], states[i + 1], steps, model, ints[0], pair_columns, rho, scratch):
            return i
    return -1


def first_colliding_motion(model: CollisionModel, states: np.ndarray, steps: np.ndarray) -> int:
    """``model.first_colliding_motion(states, steps)``: the index of the first motion of ``states``
    (C-contiguous float64) that ``model.check_motion`` finds colliding, or -1; the same verdicts, the samples
    where every pair is proven apart skipped (a certificate's long motions are mostly far from everything)."""
    ints, floats, pair_columns = model.packed
    return int(_first_colliding(states, steps, ints, floats, pair_columns, model._shape_rho))


def rrt_connect_leg(problem: Problem, budget: int, rng: np.random.Generator, resolution: float,
                    held: Sequence[int] = ()) -> SolveResult:
    """:func:`connect` on ``problem`` (a leg: its start, goal joints and window), the joints ``held``
    (columns) kept at their start values; like :func:`solver.planning.ompl_setup.rrt_connect`, a path of
    states in the problem's joint order and the queries spent, nothing spent when the start collides."""
    model = problem.model
    start = np.ascontiguousarray(problem.start, dtype=np.float64)
    if not model.is_valid(start):
        return SolveResult(False)
    lower = np.array(problem.lower, dtype=np.float64)
    upper = np.array(problem.upper, dtype=np.float64)
    held = list(held)
    lower[held] = upper[held] = start[held]
    columns = np.array(list(problem.goal_columns), dtype=np.int64)
    values = np.array([problem.goal_columns[c] for c in columns], dtype=np.float64)
    ints, floats, pair_columns = model.packed
    path, checks = connect(rng, start, columns, values, lower, upper, model.motion_steps(resolution), int(budget),
                           ints, floats, pair_columns, model._shape_rho)
    if not len(path):
        return SolveResult(False, (), int(checks))
    return SolveResult(True, tuple(map(tuple, path.tolist())), int(checks))

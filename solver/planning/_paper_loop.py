"""The paper's LA-RRT loop until its first solution, compiled: the second necessity judge's run.

The second judge (:func:`solver.validation.judge.attempt_second`) runs LA-RRT as the paper defines it
(:data:`~solver.planning.la_rrt_settings.PAPER_SETTINGS`: isolated steps, RRT-Connect's connect, goal roots
by the half-tree rule from the run's goal sampler) to its full budget of checks wherever an object is
necessary; in Python each check cost about 20 microseconds of bookkeeping. Here the loop of
:meth:`solver.planning.la_rrt.LaRrt.solve` for that case runs compiled: the draws, the nearest nodes, the
isolated steps (:func:`~solver.planning._isolated_step.isolated_moves`), the connect and the check of a found
path at fine resolution. It draws the same numbers from the same numpy Generator in the same order, makes
the same checks in the same order on the same numbers and adds the same nodes, so its verdict, path,
iterations and checks are the Python loop's (``tests/test_compiled_second_judge.py``). The goal sampler
stays in Python's hands (itself compiled, :mod:`solver.planning._goal_stream`): the loop returns when it
wants a goal root the sampler may still give, at most a few times a run.

A step's length is the L1 distance of two states, a sum the Python loop leaves to numpy (BLAS's dot
product); the compiled loop adds the terms in order from zero. The two agree exactly where the weights are
all one (no rounding in the products) and numpy sums in that order, which :func:`sums_in_order` asks of
numpy on this machine; elsewhere the Python loop runs.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numba import njit

from solver.collision.kernels import _unpacked
from solver.planning._isolated_step import _REACHED, _motion_length, compiled_piece, isolated_moves_in
from solver.planning._judge_loop import connection_path, nearest_node
from solver.planning._judge_motion import count_bound, motion_buffers, motion_hit_in

# Why a call returned (its first value).
STOPPED, GOAL_WANTED, NEED_ROOM, FOUND = range(4)
# Counters of a run, one int64 array shared with Python between calls.
ITERATIONS, GOAL_DRAWS, CLIPPED, GROWING, SPENT, CONNECTIONS, MID_ITERATION = range(7)
COUNTERS = 7


@njit(cache=True, nogil=True)
def _distance(a, b, weights):
    """``float(np.abs(b - a) @ weights)``, summed in order from zero."""
    total = 0.0
    for j in range(a.shape[0]):
        total += abs(b[j] - a[j]) * weights[j]
    return total


@njit(cache=True, nogil=True)
def _isolate(rng, states, parents, sizes, tree, node, target, extension_range, weights, random_order, by_length,
             factor_columns, factor_sizes, steps, ints, floats, pair_columns, shape_rho, mf, mi, ml):
    """LaRrt._isolate: (status, last node added or ``node``, checks)."""
    if sizes[tree] + factor_sizes.shape[0] > states.shape[1]:
        raise RuntimeError("an LA-RRT tree outgrew the room made for one iteration")
    current = states[tree, node]
    distance = _distance(current, target, weights)
    if distance <= 1e-12:
        return _REACHED, node, 0
    reach = distance <= extension_range
    if reach:
        end = target
    else:
        scale = extension_range / distance
        end = np.empty(current.shape[0])
        for j in range(current.shape[0]):
            end[j] = current[j] + (target[j] - current[j]) * scale
    status, node, size, checks = isolated_moves_in(rng, states[tree], parents[tree], sizes[tree], node, end, reach,
                                                   random_order, by_length, factor_columns, factor_sizes, steps, ints,
                                                   floats, pair_columns, shape_rho, True, mf, mi, ml)
    sizes[tree] = size
    return status, node, checks


@njit(cache=True, nogil=True)
def resume(rng, states, parents, sizes, counters, stop, budget, goals_exhausted, room, lower, upper,
           limit_probability, weights, extension_range, random_order, by_length, factor_columns, factor_sizes,
           steps, fine_steps, ints, floats, pair_columns, shape_rho):
    """The loop of LaRrt.solve (isolated steps, half-tree goal roots, until the first path that holds at
    ``fine_steps``) from where a call before left it (``counters``; trees ``states``, ``parents``, ``sizes``,
    the start tree 0), until ``counters[SPENT]`` reaches ``stop`` at the top of an iteration (the budget, or a
    piece of it: pieces make the same run as one call). Returns (why, path or an empty array): STOPPED;
    GOAL_WANTED, the iteration wants a goal root and the sampler is not ``goals_exhausted`` (the caller adds
    it and resumes mid-iteration); NEED_ROOM, a tree might outgrow ``room`` nodes this iteration; FOUND."""
    d = states.shape[2]
    growing = counters[GROWING]
    # motion_hit_in's buffers, once a call (a longer motion, a fine path check, gets its own)
    mf, mi, ml = motion_buffers(count_bound(lower, upper, steps), d, ints[0], ints[4], ints[2])
    while counters[MID_ITERATION] or counters[SPENT] < min(stop, budget):
        if not counters[MID_ITERATION]:
            counters[GROWING] = growing  # (for the call that resumes)
            if sizes[0] + room > states.shape[1] or sizes[1] + room > states.shape[1]:
                return NEED_ROOM, np.empty((0, d))
            counters[ITERATIONS] += 1
            if sizes[1] == 0 or counters[GOAL_DRAWS] < sizes[1] // 2:
                if not goals_exhausted:
                    counters[MID_ITERATION] = 1
                    return GOAL_WANTED, np.empty((0, d))
                counters[GOAL_DRAWS] += 1  # (an exhausted sampler gives nothing and costs nothing)
        counters[MID_ITERATION] = 0
        if sizes[1] == 0:
            growing = 0
        other = 1 - growing
        u = rng.random(3 * d)  # LaRrt._draw
        sample = lower + (upper - lower) * u[:d]
        for j in range(d):
            if u[d + j] < limit_probability:
                sample[j] = upper[j] if u[2 * d + j] < 0.5 else lower[j]
        near = nearest_node(states, growing, sizes[growing], sample, weights)
        _, new, checks = _isolate(rng, states, parents, sizes, growing, near, sample, extension_range, weights,
                                  random_order, by_length, factor_columns, factor_sizes, steps, ints, floats,
                                  pair_columns, shape_rho, mf, mi, ml)
        counters[SPENT] += checks
        if new != near and sizes[other] > 0:
            target = states[growing, new].copy()
            status, reached = 1, -1
            while status == 1:  # RRT-Connect's connect: step until reached or trapped
                node = nearest_node(states, other, sizes[other], target, weights)
                status, reached, checks = _isolate(rng, states, parents, sizes, other, node, target, extension_range,
                                                   weights, random_order, by_length, factor_columns, factor_sizes,
                                                   steps, ints, floats, pair_columns, shape_rho, mf, mi, ml)
                counters[SPENT] += checks
            if status == _REACHED:
                counters[CONNECTIONS] += 1
                path = connection_path(states, parents, growing, new, other, reached)
                if _holds(path, fine_steps, by_length, ints, floats, pair_columns, shape_rho, mf, mi, ml, counters):
                    counters[GROWING] = growing
                    return FOUND, path
                counters[CLIPPED] += 1
        if sizes[1] > 0:
            growing = other
    counters[GROWING] = growing
    return STOPPED, np.empty((0, d))


@njit(cache=True, nogil=True)
def _holds(path, fine_steps, by_length, ints, floats, pair_columns, shape_rho, mf, mi, ml, counters):
    """Whether each segment of ``path`` holds at ``fine_steps``, checked in order until one fails (each check
    paid into ``counters[SPENT]``, as a :class:`~solver.planning.anytime.CheckCounter` pays it): motion_hit_in,
    motion_collision's verdict with fewer pair tests."""
    (kin_int, kin_float, shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
     shape_extent, pairs, tol, _) = _unpacked(ints, floats)
    n_links = ints[0]
    for i in range(path.shape[0] - 1):
        counters[SPENT] += _motion_length(path[i], path[i + 1], fine_steps) if by_length else 1
        if motion_hit_in(mf, mi, ml, path[i], path[i + 1], fine_steps, kin_int, kin_float, n_links, shape_link,
                         shape_nv, shape_center, shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol,
                         pair_columns, shape_rho) >= 0:
            return False
    return True


@functools.cache
def sums_in_order(dimension: int) -> bool:
    """Whether numpy's ``np.abs(x) @ np.ones(dimension)`` on this machine adds the terms in order from zero
    (BLAS's dot product does below 16 terms on x86-64; a kernel that splits the sum does not), asked on
    numbers whose sum shows the order."""
    if not 1 <= dimension < 16:
        return False
    rng = np.random.default_rng(dimension)
    ones = np.ones(dimension)
    for _ in range(64):
        x = rng.standard_normal(dimension) * 10.0 ** rng.integers(-8, 9, dimension)
        if float(np.abs(x) @ ones) != float(_distance(np.zeros(dimension), x, ones)):
            return False
    return True


def room_per_iteration(n_factors: int, range_fraction: float) -> int:
    """The most nodes one iteration adds to a tree: a step adds one node per factor, and a connect takes at
    most 1/``range_fraction`` steps of the range before the last (no state is farther from another than the
    space's extent)."""
    return n_factors * (math.ceil(1.0 / range_fraction) + 4)


def applies(planner, recorder, until_first: bool, benchmark: bool) -> bool:
    """Whether :func:`run` makes ``planner``'s run (a :class:`~solver.planning.la_rrt.LaRrt`) with ``recorder``:
    until the first solution, the judges' rule (not the benchmark's), isolated steps compiled
    (``planner._compiled_step``), half-tree goal roots from a goal source, unit weights summed in order, and a
    recorder whose run only its checks end (a check budget, no clock, no CPU budget, no progress interval),
    counting through the planner's model."""
    settings = planner.settings
    return (until_first and not benchmark and planner.compiled_loop and planner._compiled_step is not None
            and settings.extension == "isolate" and settings.goal_root_rule == "half_tree"
            and planner.goals is not None and recorder.budget_checks is not None
            and recorder.time_limit == math.inf and recorder.budget_cpu is None
            and not math.isfinite(recorder.interval) and recorder.counter is planner.model
            and bool(np.all(planner.weights == 1.0)) and sums_in_order(len(planner.problem.start)))


def run(planner, recorder):
    """LaRrt.solve's loop from its first iteration (the start checked and added, not in the goal), compiled:
    the same run and the same :class:`~solver.planning.anytime.PlanResult`."""
    from solver.planning import la_rrt

    problem, settings, counter = planner.problem, planner.settings, recorder.counter
    counter_model, random_order, by_length, factor_columns, factor_sizes, steps, ints, floats, pair_columns = \
        planner._compiled_step
    # the collision model the packed arrays are of (step_arguments'): its shapes' reach for motion_hit_in
    shape_rho = (counter_model._model if counter_model is not None else planner.model)._shape_rho
    d = len(problem.start)
    room = room_per_iteration(len(factor_sizes), settings.range_fraction)
    states = np.empty((2, max(1024, 4 * room), d))
    parents = np.empty((2, states.shape[1]), dtype=np.int64)
    sizes = np.zeros(2, dtype=np.int64)
    states[0, 0], parents[0, 0], sizes[0] = problem.start, -1, 1
    counters = np.zeros(COUNTERS, dtype=np.int64)
    counters[GOAL_DRAWS] = planner.goal_draws
    goals = planner.goals
    lower = np.ascontiguousarray(problem.lower, dtype=np.float64)
    upper = np.ascontiguousarray(problem.upper, dtype=np.float64)
    weights = np.ascontiguousarray(planner.weights, dtype=np.float64)
    if not recorder.expired():
        recorder.sample(1)  # (the first iteration's progress sample; later ones record nothing on this recorder)
    before = counter.checks - recorder.checks()
    path = None
    while True:
        counters[SPENT] = counter.checks - before
        stop = min(recorder.budget_checks, int(counters[SPENT]) + la_rrt.COMPILED_PIECE_QUERIES)
        why, found = compiled_piece(
            resume, planner.rng, states, parents, sizes, counters, stop, recorder.budget_checks,
            bool(getattr(goals, "exhausted", False)), room, lower, upper, settings.limit_probability, weights,
            planner.range, random_order, by_length, factor_columns, factor_sizes, steps, planner.fine_steps, ints,
            floats, pair_columns, shape_rho)
        counter.checks = before + int(counters[SPENT])
        if why == GOAL_WANTED:  # LaRrt._add_goal_root with a goal source
            counters[GOAL_DRAWS] += 1
            state = goals.next()
            if state is not None:
                planner.goal_states.append(state)
                k = sizes[1]
                states[1, k], parents[1, k], sizes[1] = state, -1, k + 1
        elif why == NEED_ROOM:
            states = np.concatenate([states, np.empty_like(states)], axis=1)
            parents = np.concatenate([parents, np.empty_like(parents)], axis=1)
        elif why == FOUND:
            path = found
            break
        elif counters[SPENT] >= recorder.budget_checks:
            break
    planner.iterations, planner.goal_draws = int(counters[ITERATIONS]), int(counters[GOAL_DRAWS])
    planner.connections += int(counters[CONNECTIONS])
    recorder.clipped += int(counters[CLIPPED])
    if path is None:
        recorder.expired()  # the loop's last test: it records why the run ended
    elif not recorder.offer(path):
        raise RuntimeError("the compiled LA-RRT loop returned a path its recorder refuses")
    return recorder.result(planner.iterations)

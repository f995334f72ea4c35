"""LA-RRT's isolated step (:meth:`solver.planning.la_rrt.LaRrt._isolate`), its moves compiled.

The second necessity judge and the benchmark's "LA-RRT" extend their trees with isolated steps:
tens of thousands a Continuous Space puzzle, each a handful of one-factor motion checks. In Python
most of a step was its own bookkeeping (which factors change, their order, a copy and a call per
move); here the moves of one step run as one compiled call. It draws the same factor order from the
same numpy Generator (numba's ``permutation`` shares the generator's state and reproduces numpy's
stream), makes the same motion checks in the same order on the same numbers and adds the same nodes,
so every run (the judges' verdicts, the benchmark's journal: checks, iterations, cost) is what the
Python step made (``tests/test_isolated_step.py`` compares both).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from solver.collision.kernels import _unpacked, motion_collision
from solver.collision.model import CollisionModel
from solver.planning._judge_motion import motion_hit_in
from solver.planning.anytime import CheckCounter

_REACHED, _ADVANCED, _TRAPPED = 0, 1, 2  # as in solver.planning.la_rrt


@njit(cache=True, nogil=True)
def _motion_length(a, b, steps):
    """:func:`solver.planning.anytime.motion_length`: the resolution steps of the longest joint move, at least 1."""
    if a.shape[0] == 0:
        return 1
    longest = np.abs(b[0] - a[0]) / steps[0]
    for j in range(1, a.shape[0]):
        move = np.abs(b[j] - a[j]) / steps[j]
        if move > longest:
            longest = move
    return max(1, int(math.ceil(longest)))


@njit(cache=True, nogil=True)
def isolated_moves(rng, states, parents, size, node, end, reach, random_order, by_length, factor_columns,
                   factor_sizes, steps, ints, floats, pair_columns):
    """The moves of one isolated step from tree node ``node`` to ``end``: each factor that changes, one after
    another (in a random order when ``random_order``, else by factor), added to the tree (``states``,
    ``parents``, ``size`` nodes; room for one node per factor beyond it) only when every move is free.
    Returns (status, last node added or ``node``, the tree's new size, checks): checks as a
    :class:`~solver.planning.anytime.CheckCounter` charges the motions (their length with ``by_length``,
    else one each); ``reach`` says whether ``end`` is the step's target (reached) or short of it. The
    collision model comes packed (``CollisionModel._pack``: the same numbers, fewer arguments to pass)."""
    return isolated_moves_in(rng, states, parents, size, node, end, reach, random_order, by_length, factor_columns,
                             factor_sizes, steps, ints, floats, pair_columns, floats[:0], False, floats[:0], ints[:0],
                             np.empty(0, dtype=np.bool_))


@njit(cache=True, nogil=True)
def isolated_moves_in(rng, states, parents, size, node, end, reach, random_order, by_length, factor_columns,
                      factor_sizes, steps, ints, floats, pair_columns, shape_rho, skipping, mf, mi, ml):
    """:func:`isolated_moves`; with ``skipping`` each motion checked by
    :func:`~solver.planning._judge_motion.motion_hit_in` (``shape_rho``, buffers ``mf``, ``mi``, ``ml``): the
    colliding sample motion_collision finds, or none, so the same verdicts with fewer pair tests."""
    (kin_int, kin_float, shape_link, shape_nv, shape_center, shape_radius, shape_verts, shape_normals,
     shape_extent, pairs, tol, _) = _unpacked(ints, floats)
    n_links = ints[0]
    current = states[node]
    n_factors = factor_sizes.shape[0]
    changed = np.empty(n_factors, dtype=np.int64)
    n_changed = 0
    for f in range(n_factors):
        for k in range(factor_sizes[f]):
            c = factor_columns[f, k]
            if end[c] != current[c]:
                changed[n_changed] = f
                n_changed += 1
                break
    order = rng.permutation(n_changed) if random_order else np.arange(n_changed)
    corners = np.empty((n_changed, current.shape[0]))
    state = current.copy()
    checks = 0
    for i in range(n_changed):
        f = changed[order[i]]
        following = state.copy()
        for k in range(factor_sizes[f]):
            c = factor_columns[f, k]
            following[c] = end[c]
        checks += _motion_length(state, following, steps) if by_length else 1
        if skipping:
            hit = motion_hit_in(mf, mi, ml, state, following, steps, kin_int, kin_float, n_links, shape_link,
                                shape_nv, shape_center, shape_radius, shape_verts, shape_normals, shape_extent, pairs,
                                tol, pair_columns, shape_rho)
        else:
            hit = motion_collision(state, following, steps, kin_int, kin_float, n_links, shape_link, shape_nv,
                                   shape_center, shape_radius, shape_verts, shape_normals, shape_extent, pairs, tol,
                                   pair_columns)
        if hit >= 0:
            return _TRAPPED, node, size, checks
        corners[i] = following
        state = following
    for i in range(n_changed):
        states[size] = corners[i]
        parents[size] = node
        node = size
        size += 1
    return (_REACHED if reach else _ADVANCED), node, size, checks


def factor_table(columns: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Each factor's state columns as the compiled loops read them: (F, k) padded with -1, and their counts."""
    factor_sizes = np.array([len(c) for c in columns], dtype=np.int64)
    factor_columns = np.full((len(columns), max(factor_sizes, default=1)), -1, dtype=np.int64)
    for f, factor in enumerate(columns):
        factor_columns[f, :len(factor)] = factor
    return factor_columns, factor_sizes


def step_arguments(settings, model, columns: list[np.ndarray], steps: np.ndarray) -> tuple | None:
    """What :func:`isolated_moves` needs beyond a step's own values, where it makes a run's isolated
    steps (the model our collision model, counted by a :class:`CheckCounter` or not; no
    straight-segment check): None where the Python step runs."""
    if settings.extension != "isolate" or settings.check_isolated_segment:
        return None
    counter = model if type(model) is CheckCounter else None
    real = counter._model if counter is not None else model
    if type(real) is not CollisionModel:
        return None
    factor_columns, factor_sizes = factor_table(columns)
    return (counter, settings.factor_order != "fixed", counter is not None and counter.by_length,
            factor_columns, factor_sizes, steps, real._packed_int, real._packed_float, real._pair_columns)


def compiled_piece(function, *arguments):
    """``function(*arguments)``, a compiled call; a signal handler's exception raised as itself.

    A signal that lands while compiled code runs has its Python handler run as the call returns,
    and numba then reports ``SystemError: ... returned a result with an exception set``, the
    handler's exception (``phyrogen.cli.Interrupted``) its cause: that is re-raised, so the
    command ends as interrupted (exit 130 / 143), not as a bug."""
    try:
        return function(*arguments)
    except SystemError as exc:
        if isinstance(exc.__cause__, KeyboardInterrupt):
            raise exc.__cause__ from None
        raise

"""The compiled path checks give the verdicts of the checks they replaced (dense points, one motion at a time,
every pair at every state, Python's heapq A*), on fresh puzzles' certificates pushed into collisions."""

from __future__ import annotations

import heapq
import math
from dataclasses import replace

import numpy as np
import pytest

from phyrogen_core.objects import build_chain
from solver.collision.model import CollisionModel
from solver.pipelines.generation import generate_here
from solver.planning.problem import (
    DEFAULT_RESOLUTION,
    FINE_RESOLUTION,
    collision_model,
    densify,
    path_is_valid,
    segment_points,
)
from solver.validation.route_grid import grid_path


@pytest.fixture(scope="module", params=[("rooms", 9950001), ("continuous_space", 9950002), ("grid_world", 9950003)])
def puzzle(request):
    generator, seed = request.param
    return generate_here(generator, seed)


def _paths(puzzle, count: int = 12):
    """The certificate, then copies of it shaken by up to 1 (joint units), kept within the limits."""
    chain = build_chain(puzzle.objects)
    certificate = np.array(puzzle.certificate, dtype=float)
    rng = np.random.default_rng(7)
    for k in range(count):
        shaken = certificate + (rng.random(certificate.shape) - 0.5) * (0.0, 0.3, 0.03, 1.0)[k % 4]
        yield np.ascontiguousarray(np.clip(shaken, chain.lower_limits, chain.upper_limits))


def test_path_checks_agree_with_the_dense_check_and_motion_by_motion(puzzle):
    model = CollisionModel(build_chain(puzzle.objects))
    colliding = 0
    for states in _paths(puzzle):
        for resolution in (FINE_RESOLUTION, DEFAULT_RESOLUTION):
            steps = model.motion_steps(resolution)
            dense = int(np.count_nonzero(~model.check_prepared(segment_points(states, steps)[0])))
            assert model.path_collisions(states, steps) == dense
            assert model.path_collisions(states, steps, stop=True) == min(dense, 1)
            assert model.path_free(states, steps) == (dense == 0) == path_is_valid(model, states, steps)
            first = next((i for i in range(len(states) - 1)
                          if not model.check_motion(states[i], states[i + 1], steps)), -1)
            assert model.first_colliding_motion(states, steps) == first
            colliding += dense > 0
    assert colliding > 0  # the control: some shaken paths collide, so the agreement is not one of empty answers


def test_a_blocker_pairs_are_those_of_every_pair_test(puzzle):
    chain = build_chain(puzzle.objects)
    model = CollisionModel(chain)
    found = 0
    for states in _paths(puzzle, 6):
        dense = densify(states, model.motion_steps(DEFAULT_RESOLUTION))
        for blocker, columns in chain.factors.items():
            frozen = dense.copy()
            frozen[:, list(columns)] = 0.0
            expected = {pair for pair in model.colliding_objects(frozen) if blocker in pair}
            assert model.colliding_objects_with(frozen, blocker) == expected
            found += len(expected)
    assert found > 0


def test_kept_models_are_the_ones_asked_for(puzzle):
    chain = build_chain(puzzle.objects)
    model = collision_model(chain)
    assert collision_model(chain) is model
    assert collision_model(chain, tolerance=0.01) is not model  # another tolerance: another model
    copies = [replace(o) for o in puzzle.objects]  # equal objects, other instances
    assert collision_model(build_chain(copies)) is not model  # another chain, however equal
    assert collision_model(chain, tolerance=0.01).tolerance == 0.01


def test_chains_of_the_same_objects_are_one():
    objects = generate_here("lockbox_random", 9950011, None).objects
    chain = build_chain(objects)
    assert build_chain(list(objects)) is chain  # the same instances, in any sequence: the kept chain
    copies = [replace(o) for o in objects]
    other = build_chain(copies)
    assert other is not chain and other == chain  # equal objects, other instances: an equal chain of their own
    assert build_chain(objects[::-1]) is not chain  # another order: another chain
    assert build_chain(objects, "renamed") is not chain and build_chain(objects, "renamed").name == "renamed"


def _heapq_grid_path(free, roomy, start, end):
    """The A* the compiled one replaced (Python's heapq), kept here as the reference."""
    width, height = free.shape
    cost, open_ = np.where(roomy, 1.0, 4.0).ravel().tolist(), free.ravel().tolist()
    source, sink = start[0] * height + start[1], end[0] * height + end[1]

    def estimate(i, j):
        dx, dy = abs(i - end[0]), abs(j - end[1])
        return max(dx, dy) + 0.41421356237309515 * min(dx, dy)

    best, came, done, queue = {source: 0.0}, {}, set(), [(estimate(*start), source)]
    while queue:
        _, cell = heapq.heappop(queue)
        if cell == sink:
            break
        if cell in done:
            continue
        done.add(cell)
        i, j = divmod(cell, height)
        for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)):
            a, b = i + di, j + dj
            if not (0 <= a < width and 0 <= b < height) or not open_[a * height + b]:
                continue
            if di and dj and not (open_[a * height + j] and open_[i * height + b]):
                continue
            step = (1.4142135623730951 if di and dj else 1.0) * cost[a * height + b]
            if best[cell] + step < best.get(a * height + b, math.inf):
                best[a * height + b] = best[cell] + step
                came[a * height + b] = cell
                heapq.heappush(queue, (best[cell] + step + estimate(a, b), a * height + b))
    if sink not in best:
        return None
    way = [sink]
    while way[-1] != source:
        way.append(came[way[-1]])
    return np.array([divmod(c, height) for c in reversed(way)], dtype=np.int64)


def test_the_compiled_grid_path_is_heapqs():
    rng = np.random.default_rng(9950004)
    ways = blocked = 0
    for _ in range(300):
        width, height = (int(v) for v in rng.integers(1, 40, size=2))
        free = rng.random((width, height)) > rng.random() * 0.6
        roomy = free & (rng.random((width, height)) > rng.random() * 0.5)
        cells = np.argwhere(free)
        if len(cells) == 0:
            continue
        start, end = (tuple(int(v) for v in cells[rng.integers(len(cells))]) for _ in range(2))
        expected, found = _heapq_grid_path(free, roomy, start, end), grid_path(free, roomy, start, end)
        if expected is None:
            assert found is None
            blocked += 1
        else:
            assert found is not None and np.array_equal(found, expected)
            ways += 1
    assert ways > 50 and blocked > 20  # both answers occur: the control that the cases differ

"""The geometric necessity proof for targets that move in the plane (solver.validation.region_proof).

Every proof here has its control: the doors of fresh Rooms and Move N Times puzzles are proven
necessary at the top rung, and the same doors left free, taken out, or with the goal moved into
the target's start room are not; wherever the proof holds, the first judge with ten times its
budget fails too, and a proof that forgets the judge's tolerance is caught by the same check (it
claims a Rooms door blocks at a shrink where the judge gets through). Work is bounded by counts
(queries, cells), never seconds. Seeds 7461-7464 are used by no other test.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from phyrogen_core.chain import Geometry
from phyrogen_core.geometry import Box, Pose
from phyrogen_core.maker import BY_GEOMETRY
from phyrogen_core.objects import Motion, PuzzleObject, build_chain
from phyrogen_core.puzzle import Goal
from phyrogen_core.registry import get_generator
from solver.pipelines.generation import generate_here
from solver.validation import region_proof
from solver.validation.judge import JUDGE_BUDGET, MARGIN_LEVELS, attempt_fixed
from solver.validation.validator import OmplValidator

TOP = MARGIN_LEVELS[0]


@functools.cache
def _made(generator: str, seed: int, params: tuple[tuple[str, str], ...]):
    return generate_here(generator, seed, get_generator(generator).parse_params(dict(params)))


def _puzzle(generator: str, seed: int, **params):
    """A fresh puzzle (made once per test session), its doors and its interlock margin."""
    spec = get_generator(generator)
    puzzle = _made(generator, seed, tuple(sorted((k, str(v)) for k, v in params.items())))
    doors = [o.name for o in puzzle.objects if o.is_movable and o.name != puzzle.goal.target]
    return puzzle, doors, spec.parse_params({k: str(v) for k, v in params.items()}).interlock_margin


FRESH = [("rooms", 7461, {}), ("rooms", 7462, {}), ("move_n_times", 7463, {"n": 3}), ("move_n_times", 7464, {"n": 3})]


@pytest.mark.parametrize("generator, seed, params", FRESH)
def test_the_doors_of_fresh_puzzles_are_proven_at_the_top_rung_and_not_when_free_removed_or_the_goal_is_home(
        generator, seed, params):
    puzzle, doors, margin = _puzzle(generator, seed, **params)
    objects, goal = puzzle.objects, puzzle.goal
    assert doors
    for door in doors:
        assert region_proof.proves(objects, goal, [door], TOP * margin)
        kept = tuple(o for o in objects if o.name != door)
        assert not region_proof.proves(kept, goal, [], TOP * margin)  # control: the door taken out
    assert not region_proof.proves(objects, goal, [], TOP * margin)  # control: every door free to open
    target = next(o for o in objects if o.name == goal.target)
    x, y = target.joint_names[:2]
    home = Goal(goal.target, {x: 0.05, y: -0.05})  # in the start room (pocket), beside the start
    assert not any(region_proof.proves(objects, home, [door], TOP * margin) for door in doors)


def _judge_fails(objects, goal, fixed, shrink) -> bool:
    attempt = attempt_fixed(build_chain(objects), goal, fixed, shrink, 10 * JUDGE_BUDGET, np.random.default_rng(7))
    return not attempt.solved


def _consistent(proof, objects, goal, doors, shrinks) -> bool:
    """Whether, wherever ``proof`` holds, the first judge with ten times its budget fails too."""
    return all(_judge_fails(objects, goal, [door], shrink)
               for door in doors for shrink in shrinks if proof(objects, goal, [door], shrink))


@pytest.mark.slow
@pytest.mark.parametrize("generator, seed, params", [FRESH[0], FRESH[2]])
def test_wherever_the_proof_holds_the_first_judge_with_ten_times_its_budget_fails(generator, seed, params):
    puzzle, doors, margin = _puzzle(generator, seed, **params)
    shrinks = (TOP * margin, 5 * margin, 6 * margin)  # up to where a Rooms door no longer blocks the robot
    assert _consistent(region_proof.proves, puzzle.objects, puzzle.goal, doors, shrinks)


@pytest.mark.slow
def test_a_proof_without_the_judges_tolerance_is_caught(monkeypatch):
    puzzle, doors, margin = _puzzle("rooms", 7461)
    # At 5x the margin (0.05 m) the robot (0.375 wide) slips through a closed door's 0.2 m gap with
    # 0.025 m to spare in the judge's model; the judge finds the way.
    door = doors[0]
    assert not region_proof.proves(puzzle.objects, puzzle.goal, [door], 5 * margin)
    assert not _judge_fails(puzzle.objects, puzzle.goal, [door], 5 * margin)
    monkeypatch.setattr(region_proof, "shrunk_tolerance", lambda shrink: 1e-6)  # broken: the tolerance forgotten
    assert region_proof.proves(puzzle.objects, puzzle.goal, [door], 5 * margin)
    assert not _consistent(region_proof.proves, puzzle.objects, puzzle.goal, [door], (5 * margin,))


def test_the_validator_records_a_proven_door_by_geometry_with_no_search_and_the_judges_margin():
    puzzle, doors, margin = _puzzle("rooms", 7462)
    proven = OmplValidator(np.random.default_rng(0))
    verdict = proven.necessity(puzzle.objects, puzzle.goal, doors[:1], margin)
    assert verdict.how == BY_GEOMETRY and verdict.margin == TOP * margin
    assert proven.verdicts[-1].queries == 0 and proven.verdicts[-1].second_checks == 0
    judges = OmplValidator(np.random.default_rng(0))
    judges.prover = None  # control: the judges alone spend their search and find the same margin
    alone = judges.necessity(puzzle.objects, puzzle.goal, doors[:1], margin)
    assert alone.margin == verdict.margin and alone.how != BY_GEOMETRY and judges.verdicts[-1].queries > 0


# -- a room drawn by hand -----------------------------------------------------------------
def _box(name: str, x: float, y: float, size, z: float | None = None, motion=Motion.FIXED, limits=(), yaw=0.0):
    geometry = (Geometry(Box(size)),)
    return PuzzleObject(name, motion, Pose.planar(x, y, size[2] / 2 if z is None else z, yaw), geometry, geometry,
                        limits=limits)


def _room(gap: float = 0.0, wall_z: float | None = None, offset: float = 0.0, motion=Motion.R2):
    """A 0.4 x 0.6 box target (its frame ``offset`` metres from its centre along x) in a 2 x 2 m room
    of 0.1 m walls, its goal 1.5 m east of the room; ``gap`` metres cut out of the east wall's middle."""
    size = (0.4, 0.6, 0.5)
    geometry = (Geometry(Box(size), Pose.planar(offset, 0.0, 0.0)),)
    limits = ((-1.5, 2.5), (-1.5, 1.5)) + (((-np.pi, np.pi),) if motion is Motion.SE2 else ())
    target = PuzzleObject("obj_00", motion, Pose.planar(-offset, 0.0, 0.25), geometry, geometry, limits=limits)
    walls = [_box("fixed_00_wall", 0.0, 1.0, (2.1, 0.1, 0.5), wall_z), _box("fixed_01_wall", 0.0, -1.0, (2.1, 0.1, 0.5),
                                                                             wall_z),
             _box("fixed_02_wall", -1.0, 0.0, (0.1, 2.1, 0.5), wall_z)]
    piece = (2.1 - gap) / 2
    walls += [_box("fixed_03_wall", 1.0, (gap + piece) / 2, (0.1, piece, 0.5), wall_z),
              _box("fixed_04_wall", 1.0, -(gap + piece) / 2, (0.1, piece, 0.5), wall_z)]
    objects = (target, *walls)
    return objects, Goal("obj_00", {"obj_00_x": 2.0 + offset, "obj_00_y": 0.0})


def test_a_closed_room_is_proven_and_an_opening_or_walls_above_the_target_are_not():
    for motion in (Motion.R2, Motion.SE2):
        objects, goal = _room(motion=motion)
        for shrink in (0.0, 0.01, 0.04):
            assert region_proof.proves(objects, goal, [], shrink)
        # Control: a doorway wider than the target's disk (0.4 m across) in the east wall.
        assert not region_proof.proves(*_room(gap=0.5, motion=motion), [], 0.0)
        # Walls from 0.5 m up: their z extents meet the target's (0 .. 0.5 m) by nothing; the judge walks out.
        lifted, goal = _room(wall_z=0.75, motion=motion)
        assert not region_proof.proves(lifted, goal, [], 0.0)
        assert not _judge_fails(lifted, goal, [], 0.0)
        # Walls that overlap the target's height by exactly the tolerance are dropped by the model too.
        assert not region_proof.proves(*_room(wall_z=0.75 - 0.02, motion=motion), [], 0.01)


def test_a_gap_the_disk_cannot_pass_but_the_judge_can_is_not_claimed():
    # A 0.35 m gap: too narrow for the box turned to pass it 0.4 m wide (and its disk) unshrunk, wide
    # enough once shrunk by 0.04 (0.32 m box, 0.43 m gap): the proof holds only where the judge fails.
    objects, goal = _room(gap=0.35, motion=Motion.SE2)
    assert region_proof.proves(objects, goal, [], 0.0)
    assert _judge_fails(objects, goal, [], 0.0)
    assert not region_proof.proves(objects, goal, [], 0.04)
    assert not _judge_fails(objects, goal, [], 0.04)


def test_a_target_turning_about_a_frame_off_its_centre_is_proven_only_in_a_closed_room():
    objects, goal = _room(offset=0.3, motion=Motion.SE2)
    assert region_proof.proves(objects, goal, [], 0.01)
    opened, goal = _room(gap=0.8, offset=0.3, motion=Motion.SE2)
    assert not region_proof.proves(opened, goal, [], 0.01)
    assert not _judge_fails(opened, goal, [], 0.01)  # control: the judge finds the way out


def test_the_flood_fill_reaches_exactly_the_8_connected_component_of_the_start():
    """The proof's scanline fill against a plain breadth-first search, on random grids (a control: a fill
    that forgot diagonal steps reaches less on the same grids)."""
    from collections import deque

    def component(closed, start, steps):
        seen, queue = {start}, deque([start])
        while queue:
            i, j = queue.popleft()
            for di, dj in steps:
                a, b = i + di, j + dj
                if 0 <= a < closed.shape[0] and 0 <= b < closed.shape[1] and not closed[a, b] and (a, b) not in seen:
                    seen.add((a, b))
                    queue.append((a, b))
        return seen

    eight = [(di, dj) for di in (-1, 0, 1) for dj in (-1, 0, 1) if di or dj]
    rng = np.random.default_rng(7466)
    fewer = 0
    for _ in range(40):
        nx, ny = (int(v) for v in rng.integers(3, 40, size=2))
        closed = (rng.random((ny, nx)) < rng.uniform(0.2, 0.6)).T  # laid out as the proof lays its grids
        start = (int(rng.integers(nx)), int(rng.integers(ny)))
        closed[start] = False
        reached, box = region_proof._reach(closed, *start)
        expected = component(closed, start, eight)
        assert {tuple(c) for c in np.argwhere(reached)} == expected
        rows, columns = zip(*expected, strict=True)
        assert list(box) == [min(rows), min(columns), max(rows), max(columns)]
        fewer += len(component(closed, start, [(1, 0), (-1, 0), (0, 1), (0, -1)])) < len(expected)
    assert fewer > 0


# -- the finest level kept by parent cell (solver.validation.region_blocks) ---------------------
def _random_level(rng, factor: int = 8):
    """Obstacles (turned boxes and circles), a parent level's reached cells and a grid of blocks."""
    nbx, nby = (int(v) for v in rng.integers(4, 14, size=2))
    width = 0.01
    size = np.array([nbx, nby]) * factor * width
    boxes = []
    for _ in range(int(rng.integers(1, 6))):
        centre, half, yaw = rng.uniform(0, 1, 2) * size, rng.uniform(0.01, 0.2, 2), rng.uniform(-np.pi, np.pi)
        c, s = np.cos(yaw), np.sin(yaw)
        corners = np.array([[-half[0], -half[1]], [half[0], -half[1]], [half[0], half[1]], [-half[0], half[1]]])
        boxes.append(corners @ np.array([[c, s], [-s, c]]) + centre)
    vertices = np.array(boxes).reshape(len(boxes), 4, 2)
    circles = np.array([[*(rng.uniform(0, 1, 2) * size), rng.uniform(0.005, 0.1)]
                        for _ in range(int(rng.integers(0, 4)))]).reshape(-1, 3)
    parent = rng.random((nbx + 2, nby + 2)) < 0.85
    return vertices, np.full(len(boxes), 4, dtype=np.int64), circles, width, parent, nbx, nby


def _dense_and_blocks(level, reach: float, start, spread_scale: float = 1.0, factor: int = 8):
    """The dense grid's fill (region_proof._closed, _reach) and the fill by blocks, as dense grids of
    reached cells (None when the start is closed)."""
    from solver.validation import region_blocks

    vertices, counts, circles, width, parent, nbx, nby = level
    closed = region_proof._closed(vertices, counts, circles, reach, 0.0, 0.0, width, nbx * factor, nby * factor,
                                  parent, factor, 1, 1)
    spread = spread_scale * (factor - 1) * width * np.sqrt(0.5) + region_proof.REGION_SLACK
    index, bits = region_blocks.blocks(vertices, counts, circles, reach, spread, 0.0, 0.0, width, factor, parent,
                                       1, 1, nbx, nby)
    opened = region_blocks.is_open(index, bits, factor, *start)
    assert opened == (not closed[start])
    if not opened:
        return None, None
    dense, _ = region_proof._reach(closed, *start)
    whole, reached = region_blocks.fill(index, bits, factor, *start)
    by_blocks = np.zeros_like(dense)
    for bi in range(nbx):
        for bj in range(nby):
            cells = (slice(bi * factor, (bi + 1) * factor), slice(bj * factor, (bj + 1) * factor))
            if index[bi, bj] == region_blocks.OPEN:
                by_blocks[cells] = whole[bi, bj]
            elif index[bi, bj] >= 0:
                by_blocks[cells] = reached[index[bi, bj]]
    return dense, by_blocks


def test_the_fill_by_blocks_reaches_exactly_the_dense_grids_cells_and_meets_the_same_goal_cells():
    """On random obstacles and parent levels: the same cells reached, and the same answer for random
    goal boxes. Control: blocks called open by their centre alone (no spread for their children) let
    the fill through blocked children on some of the same grids."""
    from solver.validation import region_blocks

    rng = np.random.default_rng(7467)
    compared = differs = 0
    for _ in range(60):
        level = _random_level(rng)
        nbx, nby = level[5], level[6]
        reach = float(rng.uniform(0.0, 0.08))
        start = (int(rng.integers(nbx * 8)), int(rng.integers(nby * 8)))
        dense, by_blocks = _dense_and_blocks(level, reach, start)
        if dense is None:
            continue
        compared += 1
        assert np.array_equal(dense, by_blocks)
        index, bits = region_blocks.blocks(level[0], level[1], level[2], reach, 7 * 0.01 * np.sqrt(0.5) + 1e-6, 0.0,
                                           0.0, 0.01, 8, level[4], 1, 1, nbx, nby)
        whole, reached = region_blocks.fill(index, bits, 8, *start)
        for _ in range(10):
            x0, y0 = (int(v) for v in rng.integers(0, [nbx * 8, nby * 8]))
            x1, y1 = x0 + int(rng.integers(0, 12)), y0 + int(rng.integers(0, 12))
            assert region_blocks.meets(index, whole, reached, 8, x0, y0, x1, y1) == dense[x0:x1, y0:y1].any()
        careless, careless_blocks = _dense_and_blocks(level, reach, start, spread_scale=0.0)
        differs += careless_blocks is not None and not np.array_equal(careless, careless_blocks)
    assert compared >= 30 and differs > 0


def _dense_finest(obstacles, reach, corner, width, factor, parent, parent_first, size, point, goal_low, goal_high):
    """The finest level as the proof ran it before blocks: a dense grid and its scanline fill."""
    closed = region_proof._closed(obstacles.vertices, obstacles.counts, obstacles.circles, reach, corner[0], corner[1],
                                  width, int(size[0]), int(size[1]), parent, factor, int(parent_first[0]),
                                  int(parent_first[1]))
    i, j = (int(v) for v in np.floor((point - corner) / width))
    if not (0 <= i < size[0] and 0 <= j < size[1]) or closed[i, j]:
        return False
    reached, box = region_proof._reach(closed, i, j)
    g0, g1 = region_proof._cells(corner, width, goal_low, goal_high)
    return box[0] >= 0 and not reached[g0[0]:g1[0], g0[1]:g1[1]].any()


@pytest.mark.parametrize("generator, seed, params", [FRESH[1], FRESH[3]])
def test_the_proof_by_blocks_gives_the_dense_grids_verdicts_on_fresh_puzzles(generator, seed, params, monkeypatch):
    puzzle, doors, margin = _puzzle(generator, seed, **params)
    questions = [([door], shrink) for door in doors for shrink in (TOP * margin, 2 * margin, 5 * margin, 6 * margin)]
    questions.append(([], TOP * margin))
    verdicts = [region_proof.proves(puzzle.objects, puzzle.goal, fixed, shrink) for fixed, shrink in questions]
    monkeypatch.setattr(region_proof, "_finest_proves", _dense_finest)
    assert verdicts == [region_proof.proves(puzzle.objects, puzzle.goal, fixed, shrink) for fixed, shrink in questions]
    assert any(verdicts) and not all(verdicts)  # both kinds of verdict compared (control: not one answer)

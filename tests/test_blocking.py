"""The geometric necessity proof (solver.validation.blocking) and the verdict kinds puzzles record.

Every proof here has its control: a blocker that only blocks the way and one that sits on the
goal are proven, the same blocker left free, or moved out of the way, is not; on fresh Grid World
seeds every question the prover answers is one that both judges, with far larger budgets, fail
too, and some questions it does not answer are solvable. Work is bounded by counts (queries,
checks), never seconds. Seeds 7401-7404 and 7411-7412 are used by no other test.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from phyrogen_core.chain import Geometry
from phyrogen_core.geometry import Box, Pose
from phyrogen_core.maker import BY_GEOMETRY, NECESSITY_KINDS
from phyrogen_core.objects import Motion, PuzzleObject, build_chain
from phyrogen_core.puzzle import Goal
from phyrogen_core.record import PuzzleRecord
from solver.pipelines.generation import generate_here
from solver.validation import validator as validator_module
from solver.validation.blocking import BlockingProver
from solver.validation.judge import JUDGE_BUDGET, SECOND_JUDGE_BUDGET, attempt_fixed, attempt_second

CUBE = (Geometry(Box((1.0, 1.0, 1.0))),)


def _corridor(blocker_x: float, blocker_y: float = 0.0):
    """The target cube slides along x from 0 to its goal at 3; a cube at (``blocker_x``, ``blocker_y``)
    slides aside along y (0 to 2). At (1.5, 0) it blocks the way; at (3, 0) it also sits on the goal."""
    target = PuzzleObject("obj_00", Motion.PRISMATIC, Pose.planar(0.0, 0.0, 0.5), CUBE, CUBE, limits=((0.0, 3.0),))
    blocker = PuzzleObject("obj_01", Motion.PRISMATIC, Pose.planar(blocker_x, blocker_y, 0.5), CUBE, CUBE,
                           limits=((0.0, 2.0),), axis=(0.0, 1.0, 0.0))
    objects = (target, blocker)
    return objects, Goal("obj_00", {build_chain(objects).joint_order[0]: 3.0})


@pytest.mark.parametrize("blocker_x", [1.5, 3.0])
def test_a_fixed_blocker_on_the_way_or_on_the_goal_is_proven_and_a_free_one_is_not(blocker_x):
    objects, goal = _corridor(blocker_x)
    prover = BlockingProver()
    for shrink in (0.0, 0.01, 0.04):
        assert prover.proves(objects, goal, ["obj_01"], shrink)
        assert not prover.proves(objects, goal, [], shrink)  # control: it can slide aside


def test_a_fixed_object_out_of_the_way_is_not_proven():
    objects, goal = _corridor(1.5, blocker_y=1.2)  # 0.2 m of a 1 m cube apart: never in the target's way
    assert not BlockingProver().proves(objects, goal, ["obj_01"], 0.0)


def test_a_blocker_that_blocks_by_less_than_the_shrink_is_not_proven():
    objects, goal = _corridor(1.5, blocker_y=0.94)  # overlaps the target's path by 6 cm
    prover = BlockingProver(erosion=0.01)  # fine cells: the default's proofs need more overlap than 6 cm
    assert prover.proves(objects, goal, ["obj_01"], 0.0)
    assert not prover.proves(objects, goal, ["obj_01"], 0.04)  # shrunk by 4 cm each: 2 cm apart, a free way


def test_a_fixed_target_away_from_its_goal_is_proven():
    objects, goal = _corridor(1.5, blocker_y=5.0)
    assert BlockingProver().proves(objects, goal, ["obj_00"], 0.04)


def test_a_question_proven_at_the_top_rung_runs_no_search_and_gets_the_judges_verdict():
    from solver.validation.judge import MARGIN_LEVELS, judge

    objects, goal = _corridor(1.5)
    chain, margin = build_chain(objects), 0.01
    prover = BlockingProver()
    proven = judge(chain, goal, ["obj_01"], margin, JUDGE_BUDGET, np.random.default_rng(0),
                   second_budget=SECOND_JUDGE_BUDGET, proof=lambda s: prover.proves(objects, goal, ["obj_01"], s))
    alone = judge(chain, goal, ["obj_01"], margin, JUDGE_BUDGET, np.random.default_rng(0),
                  second_budget=SECOND_JUDGE_BUDGET)
    assert proven.necessary and proven.how == BY_GEOMETRY and proven.queries == 0 and proven.second_checks == 0
    assert alone.necessary and proven.margin == alone.margin == MARGIN_LEVELS[0] * margin
    assert alone.queries > 0  # control: without the proof the first judge spent its search


def _turnstile(fixed_angle: float = 0.0):
    """A target bar slides along x (0 to 2.5) past an arm that hangs from (1.5, 0.7) and turns from
    ``fixed_angle`` (0: across the way) in -pi/2..pi/2 (up to along the way, 0.6 m clear of it): a revolute
    blocker, so the proof's bound for turning cells is asked."""
    bar = (Geometry(Box((0.4, 0.2, 1.0))),)
    arm = (Geometry(Box((0.2, 1.2, 1.0)), Pose.planar(0.0, -0.6, 0.0)),)
    target = PuzzleObject("obj_00", Motion.PRISMATIC, Pose.planar(0.0, 0.0, 0.5), bar, bar, limits=((0.0, 2.5),))
    blocker = PuzzleObject("obj_01", Motion.REVOLUTE, Pose.planar(1.5, 0.7, 0.5, fixed_angle), arm, arm,
                           limits=((-1.5707, 1.5707),))
    objects = (target, blocker)
    return objects, Goal("obj_00", {build_chain(objects).joint_order[0]: 2.5})


def test_a_turning_blocker_held_across_the_way_is_proven_and_one_held_along_it_or_free_is_not():
    objects, goal = _turnstile()
    prover = BlockingProver()
    assert prover.proves(objects, goal, ["obj_01"], 0.04)
    assert not prover.proves(objects, goal, [], 0.04)  # control: it turns aside
    along, goal = _turnstile(1.5707)
    assert not BlockingProver().proves(along, goal, ["obj_01"], 0.04)  # control: held along the way


def test_every_cell_pair_the_prover_finds_blocked_collides_at_states_drawn_in_both_cells():
    """The table's claim, checked by the collision model the judges use: states drawn in a blocked cell
    pair (its ends included) collide, for prismatic and revolute objects, fixed and free; control: the
    same check catches a prover that tests only the cells' centres (no bound for the motion within)."""
    from solver.collision.model import CollisionModel
    from solver.planning.problem import shrunk_tolerance

    def misses(prover, objects, goal, fixed, shrink, rng):
        prover.proves(objects, goal, fixed, shrink)
        chain = build_chain(objects)
        model = CollisionModel(chain, tolerance=shrunk_tolerance(shrink))
        order = list(chain.joint_order)
        by_id = {id(o): o for o in objects}
        checked = missed = 0
        for (id_a, where_a, id_b, where_b, _), table in prover._tables.items():
            pairs = np.argwhere(table)
            states = []
            for cell_a, cell_b in pairs[rng.choice(len(pairs), min(len(pairs), 60), replace=False)]:
                for fraction in (0.0, 1.0, *rng.uniform(0, 1, 3)):
                    state = np.zeros(len(order))
                    for obj, where, cell in ((by_id[id_a], where_a, cell_a), (by_id[id_b], where_b, cell_b)):
                        if where[0] == "level":  # a free object's cells at that level
                            cells = prover.free_cells(obj, where[1])
                            state[order.index(obj.joint_names[0])] = cells.lower + cells.width * (cell + fraction)
                        else:
                            state[[order.index(n) for n in obj.joint_names]] = where
                    states.append(state)
            if states:
                hits = model.colliding_objects_each(np.ascontiguousarray(states))
                pair = {by_id[id_a].name, by_id[id_b].name}
                checked += len(hits)
                missed += sum(1 for h in hits if not any(set(p) == pair for p in h))
        return checked, missed

    rng = np.random.default_rng(7431)
    corridor, goal = _corridor(1.5, blocker_y=0.7)
    turnstile, turn_goal = _turnstile(0.3)
    questions = [(corridor, goal, ["obj_01"], 0.02), (corridor, goal, [], 0.0),
                 (turnstile, turn_goal, ["obj_01"], 0.04), (turnstile, turn_goal, [], 0.01)]
    total = 0
    for objects, goal, fixed, shrink in questions:
        checked, missed = misses(BlockingProver(), objects, goal, fixed, shrink, rng)
        assert missed == 0
        total += checked
    assert total > 1000

    class CentresOnly(BlockingProver):  # unsound: a cell pair blocked at the centres counts as blocked throughout
        def free_cells(self, obj, level=None):
            cells = super().free_cells(obj, level)
            still = np.concatenate([0 * cells.motions[:, :2], cells.motions[:, 2:]], axis=1)
            return dataclasses.replace(cells, motions=still)

    caught = sum(misses(CentresOnly(), *question, rng)[1] for question in questions)
    assert caught > 0


def _levels_of(pose, prismatic, lower, upper, count, levels):
    """Frames (x, y, cos, sin) and motions of a one-joint object's cells at ``levels`` levels (count, 2 count,
    ...), as :meth:`BlockingProver.free_cells` makes them: prismatic along x, or revolute about ``pose``."""
    out = []
    for level in range(levels):
        n = count << level
        width = (upper - lower) / n
        values = lower + width * (np.arange(n) + 0.5)
        x = pose[0] + (values if prismatic else 0.0 * values)
        yaw = pose[2] + (0.0 * values if prismatic else values)
        frames = np.ascontiguousarray(np.stack([x, pose[1] + 0.0 * values, np.cos(yaw), np.sin(yaw)], axis=1))
        motions = np.zeros((n, 4))
        motions[:, 0 if prismatic else 1] = width / 2
        motions[:, 2], motions[:, 3] = x, pose[1]
        out.append((frames, motions))
    return out


def _reference_table(outline_a, levels_a, outline_b, levels_b, threshold, sides, budget):
    """The table written out pair by pair with :func:`cell_pairs.pair_verdicts` (every widest pair tested),
    breadth first as the prover did before its compiled refinement: None past the budget."""
    from solver.validation import cell_pairs

    depth = max(len(levels_a), len(levels_b))
    table = np.zeros((len(levels_a[-1][0]), len(levels_b[-1][0])), dtype=bool)
    i, j = (index.ravel() for index in np.meshgrid(np.arange(len(levels_a[0][0])), np.arange(len(levels_b[0][0])),
                                                   indexing="ij"))
    spent, marks = 0, []
    for step in range(depth):
        la, lb = min(step, len(levels_a) - 1), min(step, len(levels_b) - 1)
        spent += len(i) * sides
        if spent > budget:
            return None
        verdicts = cell_pairs.pair_verdicts(outline_a.vertices, outline_a.normals, *levels_a[la], outline_b.vertices,
                                           outline_b.normals, *levels_b[lb], i, j, threshold)
        scale_a, scale_b = 1 << (len(levels_a) - 1 - la), 1 << (len(levels_b) - 1 - lb)
        marks += [(a * scale_a, b * scale_b, scale_a, scale_b) for a, b in zip(*(x[verdicts == cell_pairs.BLOCKED]
                                                                                 for x in (i, j)), strict=True)]
        i, j = i[verdicts == cell_pairs.UNSURE], j[verdicts == cell_pairs.UNSURE]
        if la + 1 < len(levels_a):
            i, j = np.concatenate([2 * i, 2 * i + 1]), np.concatenate([j, j])
        if lb + 1 < len(levels_b):
            i, j = np.concatenate([i, i]), np.concatenate([2 * j, 2 * j + 1])
    for a, b, scale_a, scale_b in marks:
        table[a:a + scale_a, b:b + scale_b] = True
    return table


def test_the_compiled_refinement_marks_what_the_pair_by_pair_test_marks():
    """The tables the prover builds (cells prepared once, edge lines stopped early, the finest pairs asked
    only blocked or not, pairs another outline pair already blocked skipped) are the pair-by-pair test's,
    cell for cell, on random slotted-disc pieces, boxes and poses, turning and sliding, at several levels;
    the widest verdicts are its verdicts, apart, blocked and unsure all occurring. Controls: a budget too small
    gives no table in both, and tables at a tolerance 1 mm larger differ."""
    from phyrogen_core.geometry import slot_disc
    from solver.validation import blocking, cell_pairs

    rng = np.random.default_rng(7451)
    radius = 1.5
    disc = [blocking._outline(np.array(piece), 0.0, 1.0) for piece in slot_disc(radius, 1.0).pieces]
    box = blocking._outline(np.array([[-0.7, -0.1], [0.7, -0.1], [0.7, 0.1], [-0.7, 0.1]]), 0.0, 1.0)
    seen, differ, refused = set(), 0, 0
    for trial in range(12):
        turning = _levels_of((0.0, 0.0, rng.uniform(-3, 3)), False, -math.pi, math.pi, int(rng.integers(20, 60)),
                             int(rng.integers(1, 4)))
        sliding = _levels_of((rng.uniform(-radius - 0.7, 0.0), rng.uniform(-0.5, 0.5), 0.0), True, 0.0, 1.0,
                             int(rng.integers(4, 10)), int(rng.integers(1, 4)))
        threshold = float(rng.choice([0.002, 0.02, 0.08])) + 1e-6
        disc_first = trial % 2 == 0
        table = np.zeros((len(turning[-1][0]), len(sliding[-1][0])) if disc_first else
                         (len(sliding[-1][0]), len(turning[-1][0])), dtype=bool)
        expected = np.zeros_like(table)
        for piece in disc:
            (outline_a, levels_a), (outline_b, levels_b) = ((piece, turning), (box, sliding))[::1 if disc_first else -1]
            sides = (len(outline_a.vertices) + len(outline_b.vertices)) * max(len(outline_a.vertices),
                                                                             len(outline_b.vertices))
            shapes = []
            for outline, levels in ((outline_a, levels_a), (outline_b, levels_b)):
                frames, motions = (np.concatenate([level[k] for level in levels]) for k in (0, 1))
                n, k = len(frames), len(outline.vertices)
                shapes.append(((outline.vertices, outline.normals, frames, motions, np.empty((n, k, 2)),
                                np.empty((n, k, 2)), np.empty((n, k)), np.empty((n, k)), np.zeros(n, dtype=bool)),
                               np.cumsum([0, *(len(level[0]) for level in levels[:-1])]).astype(np.int64),
                               blocking._one_pivot(motions)))
            (shape_a, bases_a, one_a), (shape_b, bases_b, one_b) = shapes
            i, j = (index.ravel() for index in np.meshgrid(np.arange(len(levels_a[0][0])),
                                                           np.arange(len(levels_b[0][0])), indexing="ij"))
            widest = cell_pairs.widest_verdicts(shape_a, shape_b, one_a, one_b, i, j, threshold)
            reference = cell_pairs.pair_verdicts(outline_a.vertices, outline_a.normals, *levels_a[0],
                                                outline_b.vertices, outline_b.normals, *levels_b[0], i, j, threshold)
            assert np.array_equal(widest, reference)
            seen |= set(reference.tolist())
            moved = _reference_table(outline_a, levels_a, outline_b, levels_b, threshold + 1e-3, sides, 3_000_000)
            differ += not np.array_equal(moved, _reference_table(outline_a, levels_a, outline_b, levels_b,
                                                                 threshold, sides, 3_000_000))
            for budget in (3_000_000, len(i) * sides + 1):
                marked = cell_pairs.refine(shape_a, bases_a, shape_b, bases_b, one_a, one_b, i, j, widest, threshold,
                                          sides, len(i) * sides, budget, table)
                written = _reference_table(outline_a, levels_a, outline_b, levels_b, threshold, sides, budget)
                assert marked == (written is not None)
                refused += not marked
                if written is not None:
                    expected |= written
                    assert np.array_equal(table, expected)
        assert np.array_equal(table, expected)
    assert seen == {cell_pairs.APART, cell_pairs.BLOCKED, cell_pairs.UNSURE}
    assert differ >= 6  # control: tables 1 mm of tolerance apart are told apart
    assert refused >= 6  # the budget's refusal is met and agreed on


def _questions(seeds, generator="grid_world", params=None):
    """Every necessity question the Maker asked on ``seeds``: (objects, goal, fixed, margin, verdict)."""
    asked = []
    original = validator_module.OmplValidator.necessity

    def recording(self, objects, goal, fixed, margin, **kwargs):
        verdict = original(self, objects, goal, fixed, margin, **kwargs)
        asked.append((tuple(objects), goal, tuple(fixed), margin, verdict))
        return verdict

    validator_module.OmplValidator.necessity = recording
    try:
        for seed in seeds:
            generate_here(generator, seed, params)
    finally:
        validator_module.OmplValidator.necessity = original
    return asked


@pytest.mark.slow
@pytest.mark.parametrize("generator, seeds, size", [("grid_world", [7401, 7402], {}),
                                                    ("simple_slider", [7405], {"n_objects": "4"})])
def test_on_fresh_puzzles_every_proven_question_defeats_both_judges_with_ten_times_their_budgets(generator, seeds,
                                                                                              size):
    from phyrogen_core.registry import get_generator

    asked = _questions(seeds, generator, get_generator(generator).parse_params(size))
    prover = BlockingProver()
    proven = [q for q in asked if q[4] is not None and q[4].how == BY_GEOMETRY]
    assert len(proven) >= 4 * len(seeds)
    for index, (objects, goal, fixed, _, verdict) in enumerate(proven):
        assert prover.proves(objects, goal, fixed, verdict.margin)
        chain = build_chain(objects)
        first = attempt_fixed(chain, goal, fixed, verdict.margin, 10 * JUDGE_BUDGET, np.random.default_rng(index))
        second = attempt_second(chain, goal, fixed, verdict.margin, 10 * SECOND_JUDGE_BUDGET, 9000 + index)
        assert not first.solved and not second.solved, (fixed, verdict.margin)
    # Control: the same judges solve the questions with nothing held, which the prover never proves.
    objects, goal, fixed, margin, _ = proven[-1]
    assert not prover.proves(objects, goal, [], margin)
    assert attempt_fixed(build_chain(objects), goal, [], margin, 10 * JUDGE_BUDGET, np.random.default_rng(1)).solved


@pytest.mark.slow
@pytest.mark.parametrize("generator, seeds", [("lockbox_random", [7432]), ("continuous_space", [7441, 7442, 7443])])
def test_one_joint_blockers_are_proven_at_the_top_rung_and_defeat_both_judges_with_ten_times_their_budgets(generator,
                                                                                                       seeds):
    """Lockbox Random's and Continuous Space's blockers (one joint each) on fresh seeds: most necessary
    ones are proven at the top rung, and every proven question defeats both judges with ten times their
    budgets. Controls: with the blocker free, or the goal where the target starts, no proof holds; a
    prover that ignores the shrink proves a question the judge solves at that shrink (the check sees it)."""
    from solver.validation.judge import MARGIN_LEVELS

    asked = _questions(seeds, generator)
    blockers = [q for q in asked if q[2] != (q[1].target,)]
    necessary = [q for q in blockers if q[4] is not None and q[4].margin == MARGIN_LEVELS[0] * q[3]]
    prover = BlockingProver()
    proven = [q for q in necessary if prover.proves(q[0], q[1], q[2], q[4].margin)]
    assert len(proven) >= max(3, 0.75 * len(necessary)), (len(proven), len(necessary))
    for index, (objects, goal, fixed, _, verdict) in enumerate(proven):
        assert verdict.how == BY_GEOMETRY  # the Maker asked it before the first judge and recorded it
        chain = build_chain(objects)
        first = attempt_fixed(chain, goal, fixed, verdict.margin, 10 * JUDGE_BUDGET, np.random.default_rng(index))
        second = attempt_second(chain, goal, fixed, verdict.margin, 10 * SECOND_JUDGE_BUDGET, 9000 + index)
        assert not first.solved and not second.solved, (fixed, verdict.margin)
        assert not prover.proves(objects, goal, [], verdict.margin)  # control: the blocker free
        start = Goal(goal.target, {name: 0.0 for name in goal.values}, goal.tolerance)
        assert not prover.proves(objects, start, fixed, verdict.margin)  # control: the goal is the start
    objects, goal, _, _, verdict = proven[-1]
    assert attempt_fixed(build_chain(objects), goal, [], verdict.margin, 10 * JUDGE_BUDGET,
                         np.random.default_rng(1)).solved  # control: the judge solves it with the blocker free
    if generator == "continuous_space":  # control: an unsound prover (no shrink) is caught by the judge
        solved = [q for q in blockers if q[4] is None or q[4].margin < MARGIN_LEVELS[0] * q[3]]
        caught = 0
        for objects, goal, fixed, margin, _ in solved:
            shrink = MARGIN_LEVELS[0] * margin
            if BlockingProver().proves(objects, goal, fixed, 0.0) and not prover.proves(objects, goal, fixed, shrink):
                caught += attempt_fixed(build_chain(objects), goal, fixed, shrink, 10 * JUDGE_BUDGET,
                                        np.random.default_rng(2)).solved
        assert caught >= 1


def test_grid_world_records_how_each_blocker_was_shown_needed_and_the_record_reads_it_back(tmp_path):
    from phyrogen_core.export import read_puzzle_dir, write_puzzle

    for seed in (7403, 7404):
        puzzle = generate_here("grid_world", seed)
        blockers = set(puzzle.margins)
        assert blockers and set(puzzle.necessity) == blockers
        assert set(puzzle.necessity.values()) == {BY_GEOMETRY}  # every Grid World blocker proven so far
        folder = write_puzzle(puzzle, tmp_path)
        data = json.loads((folder / "puzzle.json").read_text())
        assert data["format_version"] == 4
        kinds = {o["name"]: o.get("necessity") for o in data["objects"] if "interlock_margin" in o}
        assert kinds == dict(puzzle.necessity)
        assert read_puzzle_dir(folder).record.necessity == dict(puzzle.necessity)


@pytest.mark.slow
@pytest.mark.parametrize("generator, seed", [("continuous_space", 7411), ("lockbox_random", 7412)])
def test_other_generators_record_a_kind_for_every_blocker(generator, seed):
    puzzle = generate_here(generator, seed)
    assert set(puzzle.necessity) == set(puzzle.margins)
    assert set(puzzle.necessity.values()) <= set(NECESSITY_KINDS)


def _record_data(tmp_path):
    from phyrogen_core.export import write_puzzle

    folder = write_puzzle(generate_here("grid_world", 7403), tmp_path)
    return json.loads((folder / "puzzle.json").read_text())


@pytest.mark.parametrize("change, message", [
    (lambda d: d.update(format_version=3), "format_version 4"),
    (lambda d: d["objects"][1].update(necessity="hunch"), "necessity 'hunch' is not valid"),
    (lambda d: d["objects"][1].pop("interlock_margin"), "necessity without"),
])
def test_the_strict_reader_refuses_a_bad_necessity(tmp_path, change, message):
    from phyrogen_core.errors import PuzzleFormatError

    data = _record_data(tmp_path)
    assert "necessity" in data["objects"][1]
    PuzzleRecord.from_dict(data)  # control: the file as written reads
    change(data)
    with pytest.raises(PuzzleFormatError, match=message):
        PuzzleRecord.from_dict(data)


def test_an_older_file_reads_with_the_kind_unknown_and_writes_back_as_it_was(tmp_path):
    data = _record_data(tmp_path)
    for entry in data["objects"]:
        entry.pop("necessity", None)
    data["format_version"] = 1
    record = PuzzleRecord.from_dict(data)
    assert record.necessity == {} and record.format_version == 1
    assert json.loads(record.to_json()) == data


def test_the_dataset_manifest_says_how_each_puzzles_blockers_were_shown_needed(tmp_path):
    pytest.importorskip("pyarrow")
    from phyrogen.cli import main
    from solver.pipelines.dataset import manifest_rows

    root = tmp_path / "dataset"
    # Seeds 7421-7422 with three boxes, 7423 with one (the target alone: no blocker, no verdict).
    assert main(["dataset", "--generator", "grid_world", "--seeds", "7421-7422", "--set", "n_objects=3",
                 "--quiet", "--out", str(root)]) == 0
    alone = tmp_path / "alone"
    assert main(["dataset", "--generator", "grid_world", "--seeds", "7423", "--set", "n_objects=1",
                 "--quiet", "--out", str(alone)]) == 0
    assert [r.necessity for r in manifest_rows(root)[0]] == [BY_GEOMETRY, BY_GEOMETRY]
    assert [r.necessity for r in manifest_rows(alone)[0]] == [None]


def test_a_puzzle_counts_as_its_weakest_verdict():
    from solver.pipelines.dataset.manifest import weakest_necessity

    assert weakest_necessity(["geometry", "geometry"]) == "geometry"
    assert weakest_necessity(["geometry", "goal sampler"]) == "goal sampler"
    assert weakest_necessity(["goal sampler", "search", "geometry"]) == "search"
    assert weakest_necessity([]) is None

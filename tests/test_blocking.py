"""The geometric necessity proof (solver.validation.blocking) and the verdict kinds puzzles record.

Every proof here has its control: a blocker that only blocks the way and one that sits on the
goal are proven, the same blocker left free, or moved out of the way, is not; on fresh Grid World
seeds every question the prover answers is one that both judges, with far larger budgets, fail
too, and some questions it does not answer are solvable. Work is bounded by counts (queries,
checks), never seconds. Seeds 7401-7404 and 7411-7412 are used by no other test.
"""

from __future__ import annotations

import json

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


def test_the_compiled_overlap_test_answers_as_the_numpy_one_ties_included():
    from solver.validation.blocking import _overlaps, _pair_overlaps

    rng = np.random.default_rng(7406)
    differ = shifted = 0
    for _ in range(200):
        n, m = (int(v) for v in rng.integers(1, 12, 2))
        # Half-unit coordinates, axis normals and thresholds: many overlaps equal their threshold exactly.
        va, vb = (np.round(rng.normal(size=(k, 4, 2)) * 2) / 2 for k in (n, m))
        na, nb = (rng.integers(-1, 2, size=(k, 4, 2)).astype(float) for k in (n, m))
        i, j = rng.integers(0, n, 30), rng.integers(0, m, 30)
        threshold = np.round(rng.uniform(-2, 2, 30) * 2) / 2
        compiled = _pair_overlaps(va, na, vb, nb, i, j, threshold)
        differ += int(np.sum(compiled != _overlaps(va[i], na[i], vb[j], nb[j], threshold)))
        shifted += int(np.sum(compiled != _overlaps(va[i], na[i], vb[j], nb[j], threshold - 1e-12)))
    assert differ == 0
    assert shifted > 0  # control: the comparison sees a threshold moved by 1e-12 (the ties are there)


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

"""The geometric proof's finer cells (a question asked again) and its reach of two objects together.

:class:`~solver.validation.blocking.BlockingProver` answers a question it failed once, asked again, with cells
narrower than the judges' motion steps (a *deep* proof), where a run of blocked cells is a wall only when it is
as wide as a step (:func:`~solver.validation.cell_reach.walls`); and it follows two objects in each other's way
through the cell pairs they can reach together (:func:`~solver.validation.cell_reach.pair_spans`). Each claim
has its check and its control: walls and the flood against walks written out, the deep cells' blocked pairs
against the judges' collision model (a prover that tests only the cells' centres is caught), and on fresh
Continuous Space puzzles every question only these proofs settle defeats both judges with ten times their
budgets while no question the Maker found superfluous is proven. Bounded by counts, never seconds. Seeds
5731001-5731006, 7501-7509, 8130002 and 8130007 are used by no other test.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from phyrogen_core.objects import build_chain
from phyrogen_core.registry import get_generator
from solver.validation import validator as validator_module
from solver.validation.blocking import BlockingProver
from solver.validation.cell_reach import emptied, flood, pair_spans, walls
from solver.validation.judge import JUDGE_BUDGET, SECOND_JUDGE_BUDGET, attempt_fixed, attempt_second


def test_a_wall_is_a_run_of_blocked_cells_as_wide_as_a_step():
    blocked = np.zeros(20, dtype=bool)
    blocked[[2, 3, 4]] = True  # a run of 3 on the left
    blocked[[8, 12, 13]] = True  # runs of 1 and 2 on the right
    blocked[16:20] = True  # a run of 4
    start = 6
    assert walls(blocked, start, 1) == (5, 7)  # cells as wide as a step: every blocked cell is a wall
    assert walls(blocked, start, 2) == (5, 11)  # the single cell at 8 can be jumped
    assert walls(blocked, start, 3) == (5, 15)
    assert walls(blocked, start, 4) == (0, 15)  # control: nothing on the left is that wide


def _walls_written_out(blocked: np.ndarray, start: int, width: int) -> tuple[int, int]:
    """:func:`walls` from the blocked runs, listed whole."""
    edges = np.flatnonzero(np.diff(np.r_[0, blocked.view(np.int8), 0]))
    firsts, ends = edges[::2], edges[1::2]
    wide = ends - firsts >= width
    before, after = ends[wide & (ends <= start)], firsts[wide & (firsts > start)]
    return (int(before[-1]) if len(before) else 0), (int(after[0]) - 1 if len(after) else len(blocked) - 1)


def test_walls_scanned_outwards_are_the_runs_listed_whole():
    rng = np.random.default_rng(5731009)
    differs = 0
    for _ in range(500):
        blocked = rng.random(int(rng.integers(1, 60))) < rng.uniform(0.1, 0.7)
        free = np.flatnonzero(~blocked)
        if not len(free):
            continue
        start, width = int(rng.choice(free)), int(rng.integers(1, 5))
        assert walls(blocked, start, width) == _walls_written_out(blocked, start, width)
        differs += walls(blocked, start, width) != _walls_written_out(blocked, start, width + 1)  # control
    assert differs > 100


def _walked(free: np.ndarray, start: tuple[int, int], reach: tuple[int, int]) -> np.ndarray:
    """The cells a walk of moves of at most ``reach`` cells reaches, written out breadth first."""
    seen = np.zeros_like(free)
    queue = [start] if free[start] else []
    for cell in queue:
        seen[cell] = True
    while queue:
        a, b = queue.pop(0)
        for x in range(a - reach[0], a + reach[0] + 1):
            for y in range(b - reach[1], b + reach[1] + 1):
                if 0 <= x < free.shape[0] and 0 <= y < free.shape[1] and free[x, y] and not seen[x, y]:
                    seen[x, y] = True
                    queue.append((x, y))
    return seen


def test_the_flood_reaches_what_a_walk_written_out_reaches():
    rng = np.random.default_rng(5731001)
    differs = 0
    for _ in range(40):
        free = rng.random((int(rng.integers(5, 30)), int(rng.integers(5, 30)))) < rng.uniform(0.4, 0.8)
        start = (int(rng.integers(free.shape[0])), int(rng.integers(free.shape[1])))
        reach = (int(rng.integers(1, 4)), int(rng.integers(1, 4)))
        seen = flood(np.ascontiguousarray(free), *start, *reach)
        assert np.array_equal(seen, _walked(free, start, reach))
        differs += not np.array_equal(seen, _walked(free, start, (1, 1)))  # control: the reach matters
    assert differs > 0


def _flooded_spans(table, blocked_i, blocked_k, span_i, span_k, start_i, start_k, steps_i, steps_k):
    """``pair_spans`` written out: the whole grid of free pairs built, flooded, and its rows and columns read."""
    (lo_i, hi_i), (lo_k, hi_k) = span_i, span_k
    free = ~table[lo_i:hi_i + 1, lo_k:hi_k + 1] & ~blocked_i[lo_i:hi_i + 1, None] & ~blocked_k[None, lo_k:hi_k + 1]
    seen = flood(np.ascontiguousarray(free), start_i - lo_i, start_k - lo_k, steps_i, steps_k)
    rows, columns = np.flatnonzero(seen.any(axis=1)), np.flatnonzero(seen.any(axis=0))
    if not len(rows):
        return span_i, span_k
    return (lo_i + int(rows[0]), lo_i + int(rows[-1])), (lo_k + int(columns[0]), lo_k + int(columns[-1]))


def test_the_runs_two_objects_reach_together_are_the_whole_floods_though_the_fill_stops_early():
    # pair_spans fills without building the grid and stops once every side is reached; either way round of
    # the table (a transposed view), random spans, starts and steps, it answers as the whole flood does.
    rng = np.random.default_rng(5731007)
    narrowed = differs = 0
    for trial in range(300):
        n, m = (int(v) for v in rng.integers(3, 40, size=2))
        table = rng.random((n, m)) < rng.uniform(0.05, 0.5)
        if trial % 2:
            table = np.ascontiguousarray(table.T).T  # the same values in the other memory order
        blocked_i, blocked_k = rng.random(n) < 0.1, rng.random(m) < 0.1
        span_i = tuple(sorted(int(v) for v in rng.integers(0, n, size=2)))
        span_k = tuple(sorted(int(v) for v in rng.integers(0, m, size=2)))
        start_i, start_k = int(rng.integers(span_i[0], span_i[1] + 1)), int(rng.integers(span_k[0], span_k[1] + 1))
        steps = (int(rng.integers(1, 3)), int(rng.integers(1, 3)))
        args = (table, blocked_i, blocked_k, span_i, span_k, start_i, start_k, *steps)
        expected = _flooded_spans(*args)
        assert pair_spans(*args) == expected
        narrowed += expected != (span_i, span_k)
        # Control: the answer hangs on the table (all pairs free: nothing narrows but a blocked start).
        differs += pair_spans(np.zeros_like(table), *args[1:]) != expected
    assert narrowed > 50 and differs > 50


def _arc_consistent(tables, domains):
    """The goal states' arc consistency written out with whole-array operations (a table per ordered pair)."""
    changed = True
    while changed:
        if any(not mask.any() for mask in domains):
            return True
        changed = False
        for i in range(len(domains)):
            for k in range(len(domains)):
                if k != i:
                    kept = domains[i] & ~tables[i, k][:, domains[k]].all(axis=1)
                    if not np.array_equal(kept, domains[i]):
                        domains[i], changed = kept, True
    return any(not mask.any() for mask in domains)


def test_the_compiled_arc_consistency_empties_a_domain_exactly_where_the_whole_array_one_does():
    rng = np.random.default_rng(5731008)
    emptied_count = 0
    for _ in range(300):
        sizes = [int(v) for v in rng.integers(2, 12, size=int(rng.integers(2, 5)))]
        density = rng.uniform(0.2, 0.9)
        tables = {}
        for i, n in enumerate(sizes):
            for k in range(i + 1, len(sizes)):
                table = rng.random((n, sizes[k])) < density
                if rng.random() < 0.2:
                    table[:] = False  # a pair that blocks nothing: left out of the compiled one's tables
                tables[i, k], tables[k, i] = table, table.T
        domains = [rng.random(n) < 0.6 for n in sizes]
        expected = _arc_consistent(tables, [d.copy() for d in domains])
        kept = {key: table for key, table in tables.items() if table.any()}
        assert emptied([d.copy() for d in domains], kept) == expected
        emptied_count += expected
        # Control: without the tables nothing is pruned, so only an empty start is emptied.
        if expected and all(d.any() for d in domains):
            assert not emptied([d.copy() for d in domains], {})
    assert 50 < emptied_count < 250


def test_two_objects_in_each_others_way_are_kept_to_what_they_reach_together():
    # i can pass cell 5 only where k stands at 6 or more; k can get there only where i stands at 3 or more.
    table = np.zeros((10, 10), dtype=bool)
    table[5, :6] = True
    table[:3, 6:] = True
    none = np.zeros(10, dtype=bool)
    assert pair_spans(table, none, none, (0, 9), (0, 9), 0, 0, 1, 1) == ((0, 9), (0, 9))  # a way round: 3, then 6
    table[:7, 6:] = True  # control: now k gets past 5 only where i stands at 7 or more, beyond cell 5
    assert pair_spans(table, none, none, (0, 9), (0, 9), 0, 0, 1, 1) == ((0, 4), (0, 5))
    assert pair_spans(table, none, none, (0, 9), (0, 9), 0, 0, 2, 1) == ((0, 9), (0, 9))  # i jumps cell 5
    blocked = np.zeros(10, dtype=bool)
    blocked[4] = True  # i kept out of cell 4 whatever k does: the pairs stop at 3
    assert pair_spans(table, blocked, none, (0, 9), (0, 9), 0, 0, 1, 1) == ((0, 3), (0, 5))


class _Keeping(BlockingProver):
    """Keeps a deep proof's tables, so that the test can draw states in them."""

    def _forget(self, tables, blocks):
        pass


def _deep_misses(prover: BlockingProver, objects, goal, fixed, shrink, rng) -> tuple[int, int]:
    """States drawn in the deep cells' blocked pairs (ends included) that the judges' model finds apart."""
    from solver.collision.model import CollisionModel
    from solver.planning.problem import shrunk_tolerance

    prover.proves(objects, goal, fixed, shrink)
    prover.proves(objects, goal, fixed, shrink)  # asked again: the deep cells
    chain = build_chain(objects)
    model = CollisionModel(chain, tolerance=shrunk_tolerance(shrink))
    order = list(chain.joint_order)
    by_id = {id(o): o for o in objects}
    checked = missed = 0
    for (id_a, where_a, id_b, where_b, _), table in prover._tables.items():
        deep = [where for where in (where_a, where_b) if where[0] == "level"]
        if not deep or max(where[1] for where in deep) <= max(
                prover.free_cells(by_id[i]).level for i, w in ((id_a, where_a), (id_b, where_b)) if w[0] == "level"):
            continue
        pairs = np.argwhere(table)
        states = []
        for cell_a, cell_b in pairs[rng.choice(len(pairs), min(len(pairs), 80), replace=False)]:
            for fraction in (0.0, 1.0, *rng.uniform(0, 1, 2)):
                state = np.zeros(len(order))
                for obj, where, cell in ((by_id[id_a], where_a, cell_a), (by_id[id_b], where_b, cell_b)):
                    if where[0] == "level":
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


def _continuous_space_questions(seeds) -> list[tuple]:
    """(objects, goal, fixed, margin, verdict) of every necessity question the Maker asks on ``seeds``."""
    from solver.pipelines.generation import generate_here

    asked = []
    original = validator_module.OmplValidator.necessity

    def necessity(self, objects, goal, fixed, margin, **kw):
        out = original(self, objects, goal, fixed, margin, **kw)
        asked.append((tuple(objects), goal, tuple(fixed), margin, self.verdicts[-1]))
        return out

    validator_module.OmplValidator.necessity = necessity
    try:
        params = get_generator("continuous_space").parse_params({})
        for seed in seeds:
            generate_here("continuous_space", seed, params)
    finally:
        validator_module.OmplValidator.necessity = original
    return asked


def test_every_cell_pair_a_deep_proof_finds_blocked_collides_at_states_drawn_in_both_cells():
    """Control: a prover that tests only the deep cells' centres (no bound for the motion within) is caught."""
    rng = np.random.default_rng(7501)
    asked = _continuous_space_questions([7501])
    questions = [(q[0], q[1], q[2], q[3] * level) for q in asked[-3:] for level in (1, 4)]
    total = 0
    for question in questions:
        checked, missed = _deep_misses(_Keeping(), *question, rng)
        assert missed == 0
        total += checked
    assert total > 1000

    class CentresOnly(_Keeping):
        def free_cells(self, obj, level=None):
            cells = super().free_cells(obj, level)
            still = np.concatenate([0 * cells.motions[:, :2], cells.motions[:, 2:]], axis=1)
            return dataclasses.replace(cells, motions=still)

    assert sum(_deep_misses(CentresOnly(), *question, rng)[1] for question in questions) > 0


@pytest.mark.slow
def test_on_fresh_puzzles_questions_only_the_finer_proofs_settle_defeat_both_judges_with_ten_times_their_budgets():
    """Fresh Continuous Space seeds: the questions a proof settles that the proof before this change (one object
    at a time, cells as wide as a step: ``steps`` of one and no pair reach) does not, at the rung the Maker
    settled them, defeat both judges with ten times their budgets. Controls: no question the Maker found
    superfluous (it holds a path at the margin) is proven, deep or not; with the blocker free nothing is."""
    asked = _continuous_space_questions(range(7502, 7510))

    class Before(BlockingProver):  # no pair reach, no deep cells
        def _proves(self, objects, goal, fixed, shrink, deep):
            return not deep and super()._proves(objects, goal, fixed, shrink, deep)

    import solver.validation.blocking as blocking

    new = []
    for objects, goal, fixed, margin, verdict in asked:
        prover = BlockingProver()
        if not verdict.necessary:
            for level in (1, 2, 4):
                assert not (prover.proves(objects, goal, fixed, level * margin) or
                            prover.proves(objects, goal, fixed, level * margin))
            continue
        if verdict.how != "geometry":
            continue
        spans = blocking.pair_spans
        blocking.pair_spans = lambda table, bi, bk, si, sk, *rest: (si, sk)
        try:
            old = Before().proves(objects, goal, fixed, verdict.margin)
        finally:
            blocking.pair_spans = spans
        if not old:
            new.append((objects, goal, fixed, verdict.margin))
    assert len(new) >= 2, "too few questions on these seeds needed the finer proofs"
    for index, (objects, goal, fixed, shrink) in enumerate(new):
        chain = build_chain(objects)
        first = attempt_fixed(chain, goal, fixed, shrink, 10 * JUDGE_BUDGET, np.random.default_rng(index))
        second = attempt_second(chain, goal, fixed, shrink, 10 * SECOND_JUDGE_BUDGET, 9100 + index)
        assert not first.solved and not second.solved, (fixed, shrink)
        prover = BlockingProver()
        assert not (prover.proves(objects, goal, [], shrink) or prover.proves(objects, goal, [], shrink))


def test_pairs_tried_after_every_level_alone_answer_as_each_level_settled_in_turn():
    """The prover tries objects one at a time at the widest and the finest cells before pairs at either, the
    pairs resumed from where one at a time stopped: its answers are those of a prover that settles each level
    in turn, pairs from scratch (1fcbf94's order), question by question on fresh Continuous Space puzzles.
    Control: a prover that never follows pairs answers differently on some question, so pairs are exercised."""
    from solver.validation.blocking import _domains

    class InTurn(BlockingProver):
        def _settled(self, levels, points, target, goal, shrink):
            for index, free in enumerate(levels):
                for pairs in (False, True):
                    runs = self._narrowed(free, points, shrink)
                    if runs is not None and (not pairs or self._paired(runs)) and \
                            self._emptied(free, points, _domains(free, runs, target, goal), shrink):
                        return index
            return None

    class Alone(BlockingProver):
        @staticmethod
        def _paired(runs):
            return False

    asked = _continuous_space_questions([8130002, 8130007])
    answers = {kind: [] for kind in (BlockingProver, InTurn, Alone)}
    for kind, found in answers.items():
        prover = None
        for index, (objects, goal, fixed, margin, _) in enumerate(asked):
            if index == 0 or objects[0] is not asked[index - 1][0][0]:
                prover = kind()  # one prover a puzzle, as the validator keeps
            for level in (4, 2, 1):
                found.append(prover.proves(objects, goal, fixed, level * margin))
    assert len(answers[BlockingProver]) >= 30 and any(answers[BlockingProver])
    assert answers[BlockingProver] == answers[InTurn]
    assert answers[Alone] != answers[BlockingProver]

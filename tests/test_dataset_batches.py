"""How a dataset's cheap entries are cut into worker processes' batches (solver.pipelines.dataset.build).

A fresh process costs about two Grid World puzzles, so long requests run 32 entries of seven objects a
process, up to 64 of smaller ones; a short one is cut into four batches a worker, so that no worker is left
idle while another makes them all, and larger puzzles run in shorter batches, so that none is left with a
long queue at the end.
Every entry is made exactly once, in its order, whatever the cut.
"""

from __future__ import annotations

from solver.pipelines.dataset.build import BATCH_SIZE, EntryTask, _batches


def _tasks(count: int, generator: str = "grid_world") -> list[EntryTask]:
    return [EntryTask(i, generator, 7410000 + i, None, "/nonexistent") for i in range(count)]


def test_a_long_request_runs_full_batches_and_every_entry_once():
    tasks = _tasks(5 * BATCH_SIZE + 3)
    batches = list(_batches(iter(tasks), BATCH_SIZE, 2))
    assert [len(b) for b in batches] == [BATCH_SIZE] * 5 + [3]
    assert [t for b in batches for t in b] == tasks


def test_a_short_request_gives_every_worker_a_share():
    tasks = _tasks(12)
    batches = list(_batches(iter(tasks), BATCH_SIZE, 2))
    assert [len(b) for b in batches] == [2] * 6  # four batches a worker, at most
    assert [t for b in batches for t in b] == tasks
    # One worker: four batches too, of three (the cut follows the workers, not a fixed size).
    assert [len(b) for b in _batches(iter(tasks), BATCH_SIZE, 1)] == [3] * 4


def _move_n_times(n: str, count: int, first: int = 7410000) -> list[EntryTask]:
    from phyrogen_core.registry import get_generator

    params = get_generator("move_n_times").parse_params({"n": n})
    return [EntryTask(i, "move_n_times", first + i, params, "/nonexistent") for i in range(count)]


def test_larger_puzzles_run_in_shorter_batches():
    def cut(n: str, count: int, workers: int = 1) -> list[int]:
        tasks = _move_n_times(n, count)
        batches = list(_batches(iter(tasks), BATCH_SIZE, workers))
        assert sorted(t.index for b in batches for t in b) == list(range(count))  # each once
        return [len(b) for b in batches]

    # At the largest default size, seven objects (n = 6), full batches; smaller puzzles in longer ones, up to
    # twice as long: n = 3 (4 objects) 64 a batch, n = 4 (5 objects) 62; never more than twice.
    assert cut("6", 2 * BATCH_SIZE) == [BATCH_SIZE] * 2
    assert cut("3", 4 * BATCH_SIZE) == [2 * BATCH_SIZE] * 2
    assert cut("4", 2 * BATCH_SIZE) == [62, 2]
    assert cut("1", 4 * BATCH_SIZE) == [2 * BATCH_SIZE] * 2
    # Larger ones in shorter batches: n = 8 (9 objects) 19 a batch, n = 20 (21 objects) three.
    assert cut("8", 2 * BATCH_SIZE) == [19] * 3 + [7]
    assert cut("20", BATCH_SIZE) == [3] * 10 + [2]
    # A short request of any size: four batches a worker, at most (never more entries than a long one).
    assert cut("3", 8) == [2] * 4
    assert cut("8", 20, workers=2) == [3] * 6 + [2]


def test_entries_of_other_costs_never_share_a_batch():
    from solver.pipelines.dataset.build import _batch_cost

    big, small = _move_n_times("8", BATCH_SIZE, 7420000), _tasks(BATCH_SIZE)
    mixed = [t for pair in zip(small, big, strict=True) for t in pair]  # interleaved, as sweeps are
    batches = list(_batches(iter(mixed), BATCH_SIZE, 1))
    assert all(len({t.generator for t in b}) == 1 for b in batches)
    assert sorted(len(b) for b in batches if b[0].generator == "move_n_times") == [13, 19]
    assert [len(b) for b in batches if b[0].generator == "grid_world"] == [BATCH_SIZE]
    # The costliest start first: a batch's priority is its entries' validation budget scale.
    assert {_batch_cost(b) for b in batches if b[0].generator == "move_n_times"} == {20480.0}
    assert {_batch_cost(b) for b in batches if b[0].generator == "grid_world"} == {1.0}

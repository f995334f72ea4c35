"""How a dataset's cheap entries are cut into worker processes' batches (solver.pipelines.dataset.build).

A fresh process costs about two Grid World puzzles, so long requests run 32 entries a process; a short
one is cut into four batches a worker, so that no worker is left idle while another makes them all.
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


def test_costly_entries_run_alone():
    from phyrogen_core.registry import get_generator

    spec = get_generator("move_n_times")

    def cut(n: str) -> list[int]:
        params = spec.parse_params({"n": n})
        tasks = [EntryTask(i, "move_n_times", 7410000 + i, params, "/nonexistent") for i in range(8)]
        return [len(b) for b in _batches(iter(tasks), BATCH_SIZE, 1)]

    assert cut("3") == [1] * 8  # a validation budget scaled up (5x at n = 3): one a process
    assert cut("1") == [2] * 4  # control: unscaled at n = 1, the same entries share processes

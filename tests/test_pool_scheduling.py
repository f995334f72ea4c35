"""Both pools schedule through one lookahead (solver.parallel.pool.Lookahead): among the items read
ahead, the highest priority starts first; results of ``imap`` still come in the items' order."""

from __future__ import annotations

import pytest

from solver.parallel.pool import Lookahead, fresh_process_pool

ITEMS = [1, 5, 3, 2, 4]


def _starts(items, limit, priority, held=0):
    """The order a one-worker run starts ``items`` in (each started item finishes before the next is read)."""
    waiting, order = Lookahead(items, limit, priority), []
    while True:
        waiting.fill(held)
        if not waiting:
            return order
        order.append(waiting.pop())


def test_the_highest_priority_read_ahead_starts_first_and_the_oldest_breaks_ties():
    assert _starts(ITEMS, 4, float) == [(1, 5), (4, 4), (2, 3), (3, 2), (0, 1)]
    assert _starts(ITEMS, 4, lambda item: 0.0) == [(0, 1), (1, 5), (2, 3), (3, 2), (4, 4)]  # ties: oldest first
    assert _starts(ITEMS, 4, None) == list(enumerate(ITEMS))  # the control: no priority, the items' order
    assert _starts(ITEMS, 1, float) == list(enumerate(ITEMS))  # and nothing read ahead, nothing reordered


def test_items_held_elsewhere_count_against_the_limit():
    waiting = Lookahead(iter(range(10)), 4, None)
    waiting.fill(3)
    assert len(waiting) == 1
    waiting.fill(0)
    assert len(waiting) == 4
    waiting.fill(0)
    assert len(waiting) == 4  # full: nothing more is read


@pytest.mark.parametrize("priority", [float, None])
def test_a_one_worker_pool_starts_in_priority_order_and_imap_keeps_the_items_order(priority):
    with fresh_process_pool(1, len(ITEMS), []) as pool:
        started = list(pool.imap_unordered(abs, ITEMS, lookahead=4, priority=priority))
    with fresh_process_pool(1, len(ITEMS), []) as pool:
        ordered = list(pool.imap(abs, ITEMS, lookahead=4, priority=priority))
    assert started == ([5, 4, 3, 2, 1] if priority else ITEMS)
    assert ordered == ITEMS

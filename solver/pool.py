"""Fresh worker processes and the seeds they run with.

OMPL's global RNG can be seeded only once per process
(:func:`solver.validation.seed_ompl`), so work whose random draws must not
depend on what ran before (generating a puzzle, one benchmark run) runs in a
process of its own: forked from a server process that has imported
``preload`` but never planned, one task per process. Seeds come from a
stable hash of names and numbers, so they are the same on any machine, in
any order and on any number of workers.

This module does not use OMPL.
"""

from __future__ import annotations

import hashlib
import multiprocessing
import multiprocessing.pool
from collections.abc import Sequence


def fresh_process_pool(workers: int, tasks: int, preload: Sequence[str]) -> multiprocessing.pool.Pool:
    """A pool of ``workers`` processes (at most one per task, at least one) in which every task
    gets a fresh process, forked from a server that imported the modules named in ``preload``.

    The server is started once per parent process; ``preload`` counts only for the first pool.
    """
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(list(preload))
    return context.Pool(processes=max(1, min(workers, tasks)), maxtasksperchild=1)


def stable_seed(*parts: object) -> int:
    """A seed in [1, 2**31 - 2] (OMPL's range) from a hash of ``parts`` joined by ':'."""
    digest = hashlib.sha256(":".join(str(p) for p in parts).encode()).digest()
    return int.from_bytes(digest[:4], "little") % 2_147_483_646 + 1

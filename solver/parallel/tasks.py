"""Where tasks run: on this machine or on a Ray cluster, chosen by one argument.

The two back ends live in :mod:`solver.parallel.pool` and :mod:`solver.parallel.ray_pool`;
this module is the only one that knows both, so neither imports the other.
"""

from __future__ import annotations

from collections.abc import Sequence

from solver.parallel.pool import fresh_process_pool
from solver.parallel.ray_pool import RayPool


def task_pool(workers: int, tasks: int, preload: Sequence[str], ray: str | None = None, *, fresh: bool = True):
    """Where tasks run: :func:`fresh_process_pool` on this machine, or with ``ray`` (an address, or
    :data:`solver.parallel.ray_pool.LOCAL`) a :class:`solver.parallel.ray_pool.RayPool`, which runs each task in a
    new worker process only when ``fresh``. Both are context managers with ``imap_unordered``."""
    if ray is None:
        return fresh_process_pool(workers, tasks, preload)
    return RayPool(ray, workers, preload, fresh=fresh)

"""Where tasks run: on this machine or on a Ray cluster, chosen by one argument.

The two back ends live in :mod:`solver.parallel.pool` and :mod:`solver.parallel.ray_pool`;
this module is the only one that knows both, so neither imports the other.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from solver.parallel.pool import fresh_process_pool
from solver.parallel.ray_pool import RayPool


def task_pool(workers: int, tasks: int, preload: Sequence[str], ray: str | None = None, *, fresh: bool = True,
              server_hint: Callable[[Any], str | None] | None = None):
    """Where tasks run: :func:`fresh_process_pool` on this machine, or with ``ray`` (an address, or
    :data:`solver.parallel.ray_pool.LOCAL`) a :class:`solver.parallel.ray_pool.RayPool`, which runs each task in a
    new worker process only when ``fresh``. Both are context managers with ``imap_unordered``.
    ``server_hint``: see :func:`fresh_process_pool` (Ray's workers have no server: unused there)."""
    if ray is None:
        return fresh_process_pool(workers, tasks, preload, server_hint=server_hint)
    return RayPool(ray, workers, preload, fresh=fresh)

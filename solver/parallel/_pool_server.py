"""Imported first by the fresh-process server of :mod:`solver.parallel.pool`, before it forks any worker.

Ctrl-C in a terminal reaches every process of the foreground group, but it is
the parent's to handle: it stops its workers itself. The server ignores
SIGINT, and so does every worker from its first instruction on (a worker
inherits this disposition; one interrupted while starting would print a
traceback). The server also ignores SIGTERM, so that a SIGTERM to the whole
group (``timeout``, ``kill -- -PGID``) leaves it able to tell the parent how
its workers ended; it exits once the parent and all workers are gone. Workers
get SIGTERM's default back when they are forked, and their own handler from
:mod:`solver.parallel.pool` right after.

A worker of the pool (named :data:`solver.parallel.pool.WORKER_NAME`) starts
without the caller's ``__main__``: multiprocessing would otherwise run the
caller's script file again in every worker, before its task, and a script
without an ``if __name__ == "__main__":`` guard would start its own work
there (and fail, as a process still starting may not start others).
"""

import atexit
import gc
import multiprocessing.spawn
import os
import signal

signal.signal(signal.SIGINT, signal.SIG_IGN)
signal.signal(signal.SIGTERM, signal.SIG_IGN)
# No garbage collection while the server imports its preload: the imports make few cycles (about a
# thousand objects' worth after a dataset server's whole preload, kernels' signatures and a hint's puzzle
# included), but the collections triggered as their objects pile up visit the whole growing heap again and
# again: about 0.08 of the server's 0.52 CPU s (2-core machine). Collection is on again before the
# server's first fork (a worker, or a process that the preload starts), in the server and so in every
# worker; a preload that ends with gc.freeze (solver.pipelines._server_warmup) has moved its objects out
# of the collector's reach by then.
gc.disable()
os.register_at_fork(before=gc.enable)

# Imported once the signals are set, so that the window in which Ctrl-C can still interrupt the server
# does not grow.
from solver.parallel.pool import WORKER_NAME  # noqa: E402

_MAIN_ENTRIES = ("init_main_from_path", "init_main_from_name")
_prepare = multiprocessing.spawn.prepare


def _prepare_without_main(data: dict) -> None:
    if data.get("name") == WORKER_NAME:
        data = {key: value for key, value in data.items() if key not in _MAIN_ENTRIES}
    _prepare(data)


# spawn._main looks prepare up when each forked child starts, so this reaches every worker; other
# processes started through this server (another library's, in the same parent) keep their main.
multiprocessing.spawn.prepare = _prepare_without_main
os.register_at_fork(after_in_child=lambda: signal.signal(signal.SIGTERM, signal.SIG_DFL))
# Once the parent and its workers are gone, the server has nothing to clean up: it skips the
# interpreter's teardown of everything it preloaded (most of a second), so that no process
# outlives the command by more than a moment.
atexit.register(os._exit, 0)

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
"""

import atexit
import os
import signal

signal.signal(signal.SIGINT, signal.SIG_IGN)
signal.signal(signal.SIGTERM, signal.SIG_IGN)
os.register_at_fork(after_in_child=lambda: signal.signal(signal.SIGTERM, signal.SIG_DFL))
# Once the parent and its workers are gone, the server has nothing to clean up: it skips the
# interpreter's teardown of everything it preloaded (most of a second), so that no process
# outlives the command by more than a moment.
atexit.register(os._exit, 0)

"""Fresh worker processes and the seeds they run with.

Work that must not depend on what ran before it runs in a process of its
own: forked from a server process that has imported ``preload`` but never
planned, one task per process. A benchmark run is such a task (its time
must not profit from another run's warm caches); so is a batch of puzzles,
each of which seeds every random source it uses, OMPL's seed generator
included (:func:`solver.planning.ompl_setup.seed_ompl`). Seeds come from a stable
hash of names and numbers, so they are the same on any machine, in any
order and on any number of workers.

Stopping is part of the contract. The parent owns Ctrl-C: workers ignore
SIGINT (a terminal sends it to the whole process group) and are stopped by
their parent. A worker ends at once on SIGTERM, and when its parent dies,
even of SIGKILL, except inside :func:`deferred_signals` (writing a puzzle
folder), which it finishes first. The pool shares no lock or semaphore
between processes, so a process killed at any moment cannot block the others
or leave a semaphore behind, and a worker that dies without a result is
reported instead of waited for.

A worker does not run the caller's main script. For every process it starts,
multiprocessing sends the path of ``__main__`` along, and the new process
runs that file (as ``__mp_main__``) before its task: a script that calls
``phyrogen.generate`` at its top level, without an ``if __name__ ==
"__main__":`` guard, would call it again in the worker and fail there. A
task is a function of an importable module (one defined in the main script
cannot be sent) and needs nothing from ``__main__``, so the server
(:mod:`solver.parallel._pool_server`) drops the main module from the
start-up data of the processes named :data:`WORKER_NAME` (every worker, unless
the pool is made with ``run_main``).

This module does not use OMPL.
"""

from __future__ import annotations

import heapq
import multiprocessing
import multiprocessing.connection
import os
import signal
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass
from multiprocessing.pool import ExceptionWithTraceback
from typing import Any

_SERVER_MODULE = "solver.parallel._pool_server"
WORKER_NAME = "phyrogen-worker"
"""The process name of the pool's workers: the server starts these without the caller's ``__main__``."""
STOP_GRACE_SECONDS = 5.0
"""How long stopped workers may take to finish a write before they are killed."""
SERVER_HINT = "PHYROGEN_SERVER_HINT"
"""The environment variable through which a pool's ``server_hint`` reaches the server's preload (it is
set only while the server starts, and the server's preload removes it)."""

COLD_SERVER = "cold"
"""The :data:`SERVER_HINT` of a server that prepares for nothing beyond its imports: the one started again
after a server died preparing for its hint (no hint is this text: hints are base64 of a pickle)."""

_server_ready = False  # a worker has started: the server has finished importing its preload


class Lookahead:
    """The items of a pool's run read ahead of the ones it holds (running or finished but not yet
    returned), at most ``limit`` in all; among those read, the highest ``priority`` starts first,
    then the oldest. Both pools schedule through it (:mod:`solver.parallel.ray_pool` too)."""

    def __init__(self, items: Iterable[Any], limit: int, priority: Callable[[Any], float] | None):
        self._source = iter(items)
        self._limit = limit
        self._priority = priority
        self._heap: list[tuple[float, int, Any]] = []
        self._read = 0
        self._exhausted = False

    def fill(self, held: int) -> None:
        """Read items until those waiting and the ``held`` ones reach the limit, or the items end."""
        while not self._exhausted and len(self._heap) + held < self._limit:
            try:
                item = next(self._source)
            except StopIteration:
                self._exhausted = True
                return
            heapq.heappush(self._heap, (-self._priority(item) if self._priority else 0.0, self._read, item))
            self._read += 1

    def pop(self) -> tuple[int, Any]:
        """The next item to start, with its position among the items."""
        _, index, item = heapq.heappop(self._heap)
        return index, item

    def __len__(self) -> int:
        return len(self._heap)


class WorkerLostError(RuntimeError):
    """A worker process ended without sending its task's result."""


def fresh_process_pool(workers: int, tasks: int, preload: Sequence[str], *, run_main: bool = False,
                       server_hint: Callable[[Any], str | None] | None = None) -> FreshProcessPool:
    """A pool running at most ``workers`` tasks at once (at most ``tasks``, at least one), each in
    a fresh process forked from a server that imported the modules named in ``preload``.

    The server is started once per parent process; ``preload`` counts only for the first pool.
    Leaving the ``with`` block (normally, or by an exception) stops the pool's workers.
    ``run_main``: each worker runs the caller's main script first, as multiprocessing does by
    default, for tasks that need something only that script sets up (a generator it registers);
    such a script needs its ``if __name__ == "__main__":`` guard.
    ``server_hint(item)``, called with the first item when this pool starts the server, gives a text
    that the preload reads from the environment variable :data:`SERVER_HINT` (what to prepare the
    workers for); None sets nothing.
    """
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([_SERVER_MODULE, *preload])
    return FreshProcessPool(context, max(1, min(workers, tasks)), run_main, server_hint)


@dataclass(eq=False)
class _Task:
    process: Any
    reader: multiprocessing.connection.Connection
    item: Any


class FreshProcessPool:
    """Runs each task in a new process; see :func:`fresh_process_pool`."""

    def __init__(self, context, workers: int, run_main: bool = False,
                 server_hint: Callable[[Any], str | None] | None = None):
        self._context = context
        self._server_hint = server_hint
        self.workers = workers
        self._name = None if run_main else WORKER_NAME  # None: multiprocessing's own name and rules
        self._running: set[_Task] = set()

    def __enter__(self) -> FreshProcessPool:
        return self

    def __exit__(self, *exc_info) -> None:
        self.terminate()

    def imap_unordered(self, func: Callable[[Any], Any], items: Iterable[Any], *, lookahead: int = 0,
                       priority: Callable[[Any], float] | None = None,
                       on_lost: Callable[[Any, str], Any] | None = None,
                       heartbeat: Callable[[list[Any]], None] | None = None) -> Iterator[Any]:
        """``func(item)`` for each item, in the order they finish; the arguments as in :meth:`imap`."""
        return self._results(func, items, ordered=False, lookahead=lookahead, priority=priority,
                             on_lost=on_lost, heartbeat=heartbeat)

    def imap(self, func: Callable[[Any], Any], items: Iterable[Any], *, lookahead: int = 0,
             priority: Callable[[Any], float] | None = None,
             on_lost: Callable[[Any, str], Any] | None = None,
             heartbeat: Callable[[list[Any]], None] | None = None) -> Iterator[Any]:
        """``func(item)`` for each item, in the order of ``items``.

        At most ``lookahead`` items (at least one per worker) are read ahead of the oldest one
        not yet returned; among those, the one with the highest ``priority`` starts first.
        A worker that dies without a result gives ``on_lost(item, how it ended)`` (else
        :class:`WorkerLostError` is raised). ``heartbeat`` gets the running items, at least once a
        second and whenever they change. An exception raised by ``func`` is raised here, in turn.
        """
        return self._results(func, items, ordered=True, lookahead=lookahead, priority=priority,
                             on_lost=on_lost, heartbeat=heartbeat)

    def terminate(self) -> None:
        """Stop every running worker (see the module docstring) and wait until they are gone."""
        self._stop(list(self._running))

    def _results(self, func, items, *, ordered: bool, lookahead: int = 0, priority=None, on_lost=None,
                 heartbeat=None) -> Iterator[Any]:
        waiting = Lookahead(items, max(lookahead, self.workers), priority)
        running: dict[_Task, int] = {}
        finished: dict[int, tuple[bool, Any]] = {}
        emitted = 0
        try:
            while True:
                waiting.fill(len(running) + len(finished))
                while waiting and len(running) < self.workers:
                    index, item = waiting.pop()
                    running[self._start(func, item)] = index
                if not running:
                    return
                if heartbeat is not None:
                    heartbeat([task.item for task in sorted(running, key=running.get)])
                for task in self._wait(running, 1.0 if heartbeat is not None else None):
                    outcome = self._collect(task, on_lost)
                    index = running.pop(task)
                    if not ordered:
                        yield _unwrap(outcome)
                    else:
                        finished[index] = outcome
                while emitted in finished:
                    yield _unwrap(finished.pop(emitted))
                    emitted += 1
        finally:
            self._stop(list(running))

    def _start(self, func, item) -> _Task:
        global _server_ready
        if _server_ready:
            return self._start_worker(func, item)
        hint = self._server_hint(item) if self._server_hint is not None else None
        _start_server(hint)
        try:
            return self._start_worker(func, item)
        except (EOFError, OSError):
            # The server died before it forked the first worker: while it prepared the workers (the hint's
            # puzzle, or every kernel called once: a crash in compiled code, a stale cache). A puzzle that
            # crashes is the run's own to fail, in its worker; the server starts again with its imports alone.
            if hint == COLD_SERVER or not _wait_for_dead_server():
                raise
            _start_server(COLD_SERVER)
            return self._start_worker(func, item)

    def _start_worker(self, func, item) -> _Task:
        global _server_ready
        reader, writer = self._context.Pipe(duplex=False)
        process = self._context.Process(target=_work, args=(writer, func, item), name=self._name, daemon=True)
        # Once the server is up, starting takes milliseconds: an interrupt waits for it, so that
        # no worker is forked without being known here. The first start waits for the server's
        # imports and stays interruptible; a worker forked after that finds its parent gone and ends.
        with deferred_signals() if _server_ready else nullcontext():
            try:
                process.start()
            except BaseException:
                reader.close()
                raise
            finally:
                writer.close()
            task = _Task(process, reader, item)
            self._running.add(task)
        _server_ready = True
        return task

    @staticmethod
    def _wait(tasks: Iterable[_Task], timeout: float | None) -> list[_Task]:
        owner: dict[Any, _Task] = {}
        for task in tasks:
            owner[task.reader] = task
            owner[task.process.sentinel] = task
        ready = multiprocessing.connection.wait(list(owner), timeout)
        return list(dict.fromkeys(owner[handle] for handle in ready))

    def _collect(self, task: _Task, on_lost) -> tuple[bool, Any]:
        # Interrupted in here, the task stays running, for _stop.
        try:
            outcome = task.reader.recv()
        except EOFError:
            outcome = None
        task.process.join()
        how = _exit_status(task.process.exitcode)
        self._release(task)
        if outcome is not None:
            return outcome
        if on_lost is not None:
            return True, on_lost(task.item, how)
        return False, WorkerLostError(f"a worker process ended ({how}) without a result")

    def _release(self, task: _Task) -> None:
        self._running.discard(task)
        task.reader.close()
        task.process.close()  # its pipes now, not when garbage-collected: a run may start millions

    def _stop(self, tasks: list[_Task]) -> None:
        tasks = [task for task in tasks if not task.reader.closed]  # not released meanwhile
        if not tasks:
            return
        with deferred_signals():  # a second Ctrl-C must not cut the clean-up short
            for task in tasks:
                if task.process.exitcode is None:
                    task.process.terminate()
            deadline = time.monotonic() + STOP_GRACE_SECONDS
            for task in tasks:
                task.process.join(max(0.0, deadline - time.monotonic()))
                if task.process.exitcode is None:
                    task.process.kill()
                    task.process.join()
                self._release(task)


def _unwrap(outcome: tuple[bool, Any]) -> Any:
    ok, value = outcome
    if not ok:
        raise value
    return value


def _exit_status(code: int | None) -> str:
    return f"killed by signal {-code}" if code is not None and code < 0 else f"exit code {code}"


def _start_server(hint: str | None = None) -> None:
    """Start multiprocessing's fork server (when it is not running yet) with SIGINT blocked, which
    it and its workers inherit: until the server's first instruction ignores it, Python's own
    handler would meet a Ctrl-C to the process group and print its KeyboardInterrupt traceback
    beside the command's one line. The parent's Ctrl-C waits in the mask meanwhile (a moment: the
    start does not wait for the server's imports) and is handled as the mask is restored.
    ``hint``: the value of :data:`SERVER_HINT` in the server's environment (none when None)."""
    from multiprocessing import forkserver, resource_tracker

    # The resource tracker first: it blocks SIGINT itself around its start, then unblocks it,
    # which would undo the block below; started, it is left alone by the server's start.
    resource_tracker.ensure_running()
    with _server_environment(hint):
        if threading.current_thread() is not threading.main_thread():
            forkserver.ensure_running()
            return
        previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            forkserver.ensure_running()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, previous)


_SERVER_EXIT_POLLS = 200
"""How often (every 5 ms) a start that failed looks for the server's exit before it gives up (the server
still runs: the failure was another)."""


def _wait_for_dead_server() -> bool:
    """Whether multiprocessing's fork server process has ended, waiting a moment for it: its socket ends
    as it exits, a moment before it can be waited for. It is not reaped here: the next ``ensure_running``
    does that and starts a new one. False when this Python's multiprocessing keeps the server's process id
    elsewhere."""
    from multiprocessing import forkserver

    pid = getattr(getattr(forkserver, "_forkserver", None), "_forkserver_pid", None)
    if not isinstance(pid, int):
        return False
    for _ in range(_SERVER_EXIT_POLLS):
        try:
            if os.waitid(os.P_PID, pid, os.WEXITED | os.WNOWAIT | os.WNOHANG) is not None:
                return True
        except ChildProcessError:  # not this process's child (reaped elsewhere)
            return False
        time.sleep(0.005)
    return False


@contextmanager
def _server_environment(hint: str | None) -> Iterator[None]:
    """:data:`SERVER_HINT` set to ``hint`` (removed when None) while the server starts (it inherits the
    environment when it is started), and as before afterwards."""
    previous = os.environ.pop(SERVER_HINT, None)
    if hint is not None:
        os.environ[SERVER_HINT] = hint
    try:
        yield
    finally:
        os.environ.pop(SERVER_HINT, None)
        if previous is not None:
            os.environ[SERVER_HINT] = previous


@contextmanager
def deferred_signals() -> Iterator[None]:
    """SIGINT and SIGTERM arriving inside the block take effect when it ends (in the main thread;
    elsewhere, and for a signal that is ignored, nothing changes).

    Workers write their results inside such a block: stopped or orphaned, they finish the
    write and then end, so that no half-written output is left behind.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = {}
    for signum in (signal.SIGINT, signal.SIGTERM):
        handler = signal.getsignal(signum)
        if handler is not None and handler != signal.SIG_IGN:  # None: installed outside Python
            previous[signum] = signal.signal(signum, lambda number, frame: caught.append(number))
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        for signum in dict.fromkeys(caught):
            signal.raise_signal(signum)


def _work(results, func, item) -> None:
    """A worker's whole life: one task, its outcome sent to the parent."""
    _become_worker()
    try:
        outcome = (True, func(item))
    except Exception as exc:
        outcome = (False, ExceptionWithTraceback(exc, exc.__traceback__))
    try:
        results.send(outcome)
    except BrokenPipeError:  # the parent is gone; the watch below ends this process
        pass
    except Exception as exc:  # a result (or exception) that cannot be pickled
        results.send((False, RuntimeError(f"the worker's outcome could not be sent back: {exc!r}")))
    results.close()


def _become_worker() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _end_now)
    parent = multiprocessing.parent_process()
    if parent is not None and parent.sentinel is not None:
        threading.Thread(target=_end_with_parent, args=(parent.sentinel,), name="parent-watch",
                         daemon=True).start()


def _end_now(signum, frame) -> None:
    os._exit(128 + signum)


def _end_with_parent(sentinel: int) -> None:
    # The worker's OS parent is the server, which lives as long as any worker does; the parent
    # that matters is the process that started the task, whose sentinel pipe ends when it dies.
    multiprocessing.connection.wait([sentinel])
    os.kill(os.getpid(), signal.SIGTERM)  # the main thread's handler: now, or after a write

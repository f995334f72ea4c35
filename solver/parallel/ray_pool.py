"""Tasks on a Ray cluster, with the contract of :mod:`solver.parallel.pool`'s fresh process pool.

``phyrogen dataset --ray`` and ``phyrogen benchmark --ray`` run the same
functions on the same items as the local pool; only where they run changes.
With ``--ray`` alone a local Ray instance is started with ``--workers`` CPUs
(and stopped at the end); with ``--ray ADDRESS`` (``auto``, ``HOST:PORT`` or
``ray://HOST:PORT``) the run joins a running cluster and keeps one task per
CPU of the cluster in flight. Tasks read and write puzzle folders by path, so
every node must see the output folder at the same path (a shared file
system) and have PhyRoGen installed, as the driver does.

``fresh=True`` runs every task in a new worker process (Ray's
``max_calls=1``), as the benchmark's runs need for comparable timings;
dataset entries seed every random source per puzzle and reuse workers.

Stopping: leaving the ``with`` block cancels every task still pending or
running (``force=True`` ends its worker process) and, when this process
started the Ray instance, shuts it down. Task functions write their outputs
atomically, so a cancelled task leaves at most a temporary file, which the
next run removes. Killed with SIGKILL, the driver cannot shut its local
instance down, and Ray then leaves two agent processes running for good
(Ray 2.60); a small reaper process, started with the instance, ends every
process of the instance when the driver's pipe to it closes. It knows them
by a token in their environment and by the files they hold open in the
instance's session folder (Ray's process titles can overwrite the
environment).
"""

from __future__ import annotations

import contextlib
import importlib
import logging
import os
import socket
import subprocess
import sys
import uuid
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any

from solver.parallel.pool import Lookahead, WorkerLostError

LOCAL = "local"
"""The ``ray`` value (``--ray`` with no address) that starts a Ray instance on this machine."""

_MARK = "PHYROGEN_RAY_INSTANCE"
"""An environment variable every process of a local instance inherits, with a value of its own."""

_REAPER = f"""
import os, signal, sys, time
signal.signal(signal.SIGINT, signal.SIG_IGN)  # a Ctrl-C for the group is the driver's to handle
spared = {{os.getpid(), os.getppid()}}  # the driver too: after a normal shutdown it may hold a log open
session = sys.stdin.buffer.read().decode().strip()  # sent once the instance runs; the read ends with the driver
mark = ("{_MARK}=" + sys.argv[1]).encode()

def ours(pid):
    # Its environment (unless Ray's process titles overwrote it), or a file open in the session's folder.
    with open(f"/proc/{{pid}}/environ", "rb") as environ:
        if mark in environ.read().split(b"\\0"):
            return True
    if session:
        for fd in os.listdir(f"/proc/{{pid}}/fd"):
            try:
                if os.readlink(f"/proc/{{pid}}/fd/{{fd}}").startswith(session + "/"):
                    return True
            except OSError:
                pass
    return False

quiet, deadline = 0, time.monotonic() + 30
while quiet < 4 and time.monotonic() < deadline:  # until a second passes with none left (one may be starting)
    found = False
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            if int(pid) not in spared and ours(pid):
                os.kill(int(pid), signal.SIGKILL)
                found = True
        except OSError:
            pass
    quiet = 0 if found else quiet + 1
    time.sleep(0.25)
"""


def _call(func: Callable[[Any], Any], item: Any, preload: tuple[str, ...]) -> Any:
    # What the local pool's server imports before it forks (compiled kernels warmed up among
    # them), so that no run's time includes it; a reused worker has it already.
    for module in preload:
        importlib.import_module(module)
    return func(item)


def _start_reaper() -> subprocess.Popen | None:
    """The reaper of the local instance about to start (None where there is no /proc)."""
    if not os.path.isdir("/proc/self"):
        return None
    token = uuid.uuid4().hex
    reaper = subprocess.Popen([sys.executable, "-c", _REAPER, token], stdin=subprocess.PIPE,
                              env={k: v for k, v in os.environ.items() if k != _MARK})
    os.environ[_MARK] = token  # inherited by the instance's processes, started from here
    return reaper


CONNECT_SECONDS = 10.0
"""How long a cluster's address may take to answer before it counts as unreachable."""


@contextlib.contextmanager
def ray_instance(address: str, workers: int) -> Iterator[int]:
    """Join the Ray cluster at ``address``, or with :data:`LOCAL` start one on this machine with
    ``workers`` CPUs, for the block; yields how many tasks to keep running (a cluster: its CPUs).
    Raises ValueError (one line) when Ray is missing or the cluster cannot be reached, before
    anything is started. What this started is stopped when the block ends. Inside a block,
    :class:`RayPool` uses the connection."""
    ray = _import_ray()
    # Ray's own INFO lines would interleave with the progress bar; errors still show.
    options: dict[str, Any] = {"include_dashboard": False, "logging_level": logging.ERROR}
    reaper = None
    if address == LOCAL:
        reaper = _start_reaper()
        try:
            ray.init(num_cpus=workers, **options)
        finally:
            os.environ.pop(_MARK, None)  # the instance has it; later children of this process need not
        if reaper is not None:
            reaper.stdin.write(_session_folder(ray).encode() + b"\n")
            reaper.stdin.flush()
    else:
        _check_reachable(address)
        try:
            ray.init(address=address, **options)
        except (ConnectionError, ValueError, RuntimeError) as exc:
            raise ValueError(f"--ray {address}: cannot join a Ray cluster there ({_first_line(exc)})") from None
    try:
        yield workers if address == LOCAL else max(1, int(ray.cluster_resources().get("CPU", 0)))
    finally:
        ray.shutdown()
        if reaper is not None:  # it ends what shutdown left
            reaper.stdin.close()
            reaper.wait()


def _session_folder(ray) -> str:
    """The local instance's session folder, where its processes keep their logs open ('' if unknown:
    the reaper then knows them by their environment only)."""
    try:
        return str(ray._private.worker.global_worker.node.get_session_dir_path())
    except Exception:
        return ""


def _import_ray():
    try:
        import ray
    except ImportError:
        raise ValueError("--ray needs Ray: pip install 'phyrogen[datasets]'") from None
    return ray


def check_ray_address(address: str) -> None:
    """What :func:`ray_instance` would refuse before starting anything (Ray missing, an address that
    does not answer), checked alone: a command calls it before its first line of progress."""
    _import_ray()
    if address != LOCAL:
        _check_reachable(address)


def _check_reachable(address: str) -> None:
    """Refuse a HOST:PORT (or ray://HOST:PORT) that does not answer: Ray itself retries for minutes."""
    if address == "auto":
        return
    host, _, port = address.removeprefix("ray://").rpartition(":")
    if not host or not port.isdigit():
        raise ValueError(f"--ray {address}: not a Ray address (auto, HOST:PORT or ray://HOST:PORT)")
    try:
        socket.create_connection((host, int(port)), timeout=CONNECT_SECONDS).close()
    except OSError as exc:
        raise ValueError(f"--ray {address}: no Ray cluster answers there ({exc.strerror or exc})") from None


def _first_line(exc: BaseException) -> str:
    return str(exc).splitlines()[0] if str(exc) else type(exc).__name__


class RayPool:
    """Runs tasks on Ray (see :func:`ray_instance` for ``address`` and ``workers``; inside a
    ``ray_instance`` block, its connection). A worker imports the modules named in ``preload``
    before its first task. Use as a context manager."""

    def __init__(self, address: str, workers: int, preload: Sequence[str] = (), *, fresh: bool):
        ray = self._ray = _import_ray()
        self._instance = contextlib.ExitStack()
        if ray.is_initialized():
            self.workers = workers if address == LOCAL else max(1, int(ray.cluster_resources().get("CPU", 0)))
        else:
            self.workers = self._instance.enter_context(ray_instance(address, workers))
        self._remote = ray.remote(num_cpus=1, max_retries=0, max_calls=1 if fresh else 0)(_call)
        self._preload = tuple(preload)
        self._pending: dict[Any, Any] = {}

    def __enter__(self) -> RayPool:
        return self

    def __exit__(self, *exc_info) -> None:
        self.terminate()
        self._instance.close()

    def terminate(self) -> None:
        """Cancel every task still pending or running."""
        for ref in list(self._pending):
            try:
                self._ray.cancel(ref, force=True)
            except Exception:  # finished meanwhile, or the cluster is gone: nothing left to stop
                pass
        self._pending.clear()

    def imap_unordered(self, func: Callable[[Any], Any], items: Iterable[Any], *, lookahead: int = 0,
                       priority: Callable[[Any], float] | None = None,
                       on_lost: Callable[[Any, str], Any] | None = None,
                       heartbeat: Callable[[list[Any]], None] | None = None) -> Iterator[Any]:
        """``func(item)`` for each item, in the order they finish; arguments as in
        :meth:`solver.parallel.pool.FreshProcessPool.imap` (a task whose worker or node died gives
        ``on_lost(item, how)``)."""
        from ray import exceptions

        lost = (exceptions.WorkerCrashedError, exceptions.NodeDiedError, exceptions.ObjectLostError,
                exceptions.TaskCancelledError, exceptions.RayActorError)
        waiting = Lookahead(items, max(lookahead, self.workers), priority)
        try:
            while True:
                waiting.fill(len(self._pending))
                while waiting and len(self._pending) < self.workers:
                    _, item = waiting.pop()
                    self._pending[self._remote.remote(func, item, self._preload)] = item
                if not self._pending:
                    return
                if heartbeat is not None:
                    heartbeat(list(self._pending.values()))
                ready, _ = self._ray.wait(list(self._pending), num_returns=1,
                                          timeout=1.0 if heartbeat is not None else None)
                for ref in ready:
                    item = self._pending.pop(ref)
                    try:
                        result = self._ray.get(ref)
                    except lost as exc:
                        how = _first_line(exc)
                        if on_lost is None:
                            raise WorkerLostError(f"a Ray task ended without a result: {how}") from None
                        result = on_lost(item, how)
                    except exceptions.RayTaskError as exc:
                        raise exc.as_instanceof_cause() from None
                    yield result
        finally:
            self.terminate()

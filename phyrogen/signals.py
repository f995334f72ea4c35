"""SIGINT and SIGTERM while a command runs: raised where the command is, held back where compiled code
calls Python and cannot take an exception (a compiled module's initialisation, Numba's unboxing of a
numpy Generator), sent again when dropped in a finalizer."""

from __future__ import annotations

import functools
import os
import signal
import sys
import threading


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM: raised where the command is, so that every ``with`` and ``finally`` on
    the way out cleans up (workers stopped, temporary folders removed)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


_interrupted: int | None = None  # the signal that stopped the command


COMPILED_INIT = frozenset({"ExtensionFileLoader.create_module", "ExtensionFileLoader.exec_module"})
"""importlib's calls that run a compiled module's initialisation (OMPL's, Numba's, PyBullet's)."""
RETRY_SECONDS = 0.01
"""How soon a signal held back where compiled code called Python is sent again."""


def _in_compiled_init(frame) -> bool:
    """Whether ``frame`` runs inside the initialisation of a compiled module: Python code that the
    module's C++ calls (OMPL's builds hundreds of enums), or that C++ itself."""
    while frame is not None:
        if frame.f_code.co_qualname in COMPILED_INIT:
            return True
        frame = frame.f_back
    return False


def _in_unchecked_call(frame) -> bool:
    """Whether ``frame`` runs inside ``ctypes.cast`` (or code it calls), which Numba calls each time a
    compiled function takes a numpy Generator, to unbox the Generator's bit generator: Numba (0.61)
    reads an attribute of the result without checking it for an error, so an exception raised there
    makes it read through a null pointer and the process dies by SIGSEGV."""
    ctypes = sys.modules.get("ctypes")
    cast = getattr(getattr(ctypes, "cast", None), "__code__", None)
    while cast is not None and frame is not None:
        if frame.f_code is cast:
            return True
        frame = frame.f_back
    return False


def _interrupt(signum, frame) -> None:
    global _interrupted
    if _in_compiled_init(frame) or _in_unchecked_call(frame):
        # Raised here, the exception would cross compiled code on its way out: OMPL's initialisation
        # aborts the process ("terminate called after throwing an instance of 'nanobind::python_error'")
        # or swallows it; Numba's unboxing crashes (above). The signal comes again a moment later, by
        # then in Python that can take it (between two compiled calls) or in compiled code that runs
        # the handler as it returns.
        threading.Timer(RETRY_SECONDS, os.kill, (os.getpid(), signum)).start()
        return
    # Only the first signal counts: a second one would cut the clean-up short.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    _interrupted = signum
    raise Interrupted(signum)


def _redeliver(fallback, unraisable) -> None:
    # Raised inside a finalizer (a __del__, a weakref callback), Interrupted cannot propagate:
    # Python would print "Exception ignored" and the command would go on. Send the signal again,
    # to arrive a moment later, outside the finalizer.
    if isinstance(unraisable.exc_value, Interrupted) and threading.current_thread() is threading.main_thread():
        signum = unraisable.exc_value.signum
        signal.signal(signum, _interrupt)
        threading.Timer(0.01, os.kill, (os.getpid(), signum)).start()
    else:
        fallback(unraisable)


def install():
    """In the main thread, the handlers of SIGINT and SIGTERM and the hook of :func:`_redeliver`; what they
    replace, for :func:`restore` (nothing in another thread, where Python allows no handler)."""
    global _interrupted
    _interrupted = None
    previous_hook = sys.unraisablehook
    previous = {}
    if threading.current_thread() is threading.main_thread():
        previous = {signum: signal.signal(signum, _interrupt) for signum in (signal.SIGINT, signal.SIGTERM)}
        sys.unraisablehook = functools.partial(_redeliver, previous_hook)
    return previous, previous_hook


def raise_if_dropped() -> None:
    """A signal dropped in a finalizer, when the command ended before it came again."""
    if _interrupted is not None:
        raise Interrupted(_interrupted)


def ignore(previous: dict) -> None:
    """Ignore the signals from now on (also one that :func:`_redeliver` sent again)."""
    for signum in previous:
        signal.signal(signum, signal.SIG_IGN)


def restore(previous: dict, previous_hook) -> None:
    """The handlers and hook :func:`install` replaced, back in place."""
    if previous:
        sys.unraisablehook = previous_hook
        for signum, handler in previous.items():
            if handler is not None:
                signal.signal(signum, handler)

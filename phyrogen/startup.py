"""The first tenth of a second of the ``phyrogen`` command, before :func:`phyrogen.cli.main`
installs its signal handlers.

The command's imports (NumPy and the core, for ``import phyrogen``) come before ``main`` can
run, and Python's own handler met a Ctrl-C there with a KeyboardInterrupt traceback. Imported
first by ``phyrogen/__init__.py``: in the process of the command (the console script, or
``python -m phyrogen``) it makes SIGINT and SIGTERM end the process at once with the command's
one line, ``phyrogen: interrupted``, and exit 130 / 143, until ``main`` puts its own handlers in
place. Nothing has been written or started by then, so nothing is left to clean up. A program that
imports the package (``import phyrogen``) keeps Python's handlers: this module changes nothing there.
Only the moments while Python itself starts, before any code of the package, remain Python's.
"""

from __future__ import annotations

import os
import signal
import sys

_OPTIONS_WITH_A_VALUE = ("-X", "-W")


def started_as_the_command(argv: list[str]) -> bool:
    """Whether ``argv`` (the interpreter's own command line, ``sys.orig_argv``) runs ``phyrogen``: the
    console script (a file named ``phyrogen``) or ``python -m phyrogen``."""
    index = 1
    while index < len(argv) and argv[index].startswith("-"):
        if argv[index] == "-m":
            return argv[index + 1:index + 2] == ["phyrogen"]
        if argv[index] == "-c":
            return False
        index += 2 if argv[index] in _OPTIONS_WITH_A_VALUE else 1
    return index < len(argv) and os.path.basename(argv[index]) == "phyrogen"


def _end_at_once(signum, frame) -> None:
    os.write(2, b"phyrogen: interrupted\n")
    os._exit(128 + signum)


if started_as_the_command(getattr(sys, "orig_argv", [])):
    for _signum in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(_signum) not in (signal.SIG_IGN, None):  # ignored by the caller: stays ignored
            signal.signal(_signum, _end_at_once)

"""Waiting in a test for something to happen: a file, a line, a process state.

A test waits for the event itself, however long a loaded machine takes to get there. The clock
only guards against a hang: the backstop is minutes, far beyond what normal operation ever needs
even with every core busy, and when it fires the test fails saying which event never came.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TypeVar

import pytest

BACKSTOP = 900.0
"""Seconds after which a wait counts as a hang. A subprocess that takes 30 s on a quiet machine
took over 300 s with two cores shared by twenty busy processes, so the backstop is 15 minutes;
CI's whole run has a 40-minute limit, and a hang must fail one test, not stop the suite."""

T = TypeVar("T")


def wait_until(condition: Callable[[], T], what: str | Callable[[], str], backstop: float = BACKSTOP,
               poll: float = 0.05) -> T:
    """The first true value of ``condition()``; a test failure naming ``what`` (or what it returns,
    asked when the backstop fires) if none comes."""
    deadline = time.monotonic() + backstop
    while not (value := condition()):
        if time.monotonic() > deadline:
            pytest.fail(f"hung: {what() if callable(what) else what} did not happen in {backstop:.0f} s")
        time.sleep(poll)
    return value

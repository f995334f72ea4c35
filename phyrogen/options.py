"""The types of the command line's options, refused while the command line is read (before any work),
their limits, and the options several commands share."""

from __future__ import annotations

import argparse

WORKERS_PER_CORE = 4
"""``--workers`` may ask for at most this many processes per usable core: more only contend for
cores and memory (each worker holds OMPL, numpy and the compiled collision kernels), and in a
benchmark they would distort the timed runs."""
MAX_BENCHMARK_SEED = 2**31 - 2
"""``benchmark --seed``: OMPL's seed range (see ``phyrogen_core.seeding.stable_seed``), from 0 (the default)."""


def max_workers() -> int:
    """The largest ``--workers``: :data:`WORKERS_PER_CORE` times the cores this process may use."""
    import os

    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    return WORKERS_PER_CORE * max(1, cores)


def whole_number(text: str, low: int, high: int, why: str = "") -> int:
    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or not low <= value <= high:
        raise argparse.ArgumentTypeError(f"must be a whole number in {low}..{high}{why}, got {text!r}")
    return value


def workers_option(text: str) -> int:
    return whole_number(text, 1, max_workers(), f" ({WORKERS_PER_CORE} per usable core)")




def benchmark_seed_option(text: str) -> int:
    return whole_number(text, 0, MAX_BENCHMARK_SEED, " (OMPL's seed range)")






def budget_checks_option(text: str) -> int:
    from solver.planning.anytime import MAX_BUDGET_CHECKS

    return whole_number(text, 1, MAX_BUDGET_CHECKS, " collision checks")


def path_option(text: str) -> str:
    """A path given on the command line, as given, unless it is empty: ``Path("")`` is ``"."``, so an
    empty ``--out`` would write into the working directory and an empty reader path read it."""
    if not text:
        raise argparse.ArgumentTypeError("must name a file or folder, got ''")
    return text


def add_workers_option(parser: argparse.ArgumentParser, default: int = 2, what: str = "worker processes") -> None:
    parser.add_argument("--workers", type=workers_option, default=default,
                        help=f"{what} (default {default}; at most {WORKERS_PER_CORE} per usable core)")


def add_quiet_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--quiet", action="store_true", help="no progress bar")

"""What the speed benchmarks print beside a rate: CPU time, and whether other work ran meanwhile.

A rate in wall-clock time measured while other processes share the cores is a
floor, not the code's speed; a rate in CPU time (this process's, all its
threads) is much less affected. :func:`measure` records both, the load
average before and after, and the CPU time the whole machine spent
(``/proc/stat``, Linux) beyond the measured work: when others took more than
:data:`BUSY_SHARE` of the cores, the measurement is flagged busy.

Imported by the scripts beside it (``python benchmarks/env_speed.py`` puts
this folder on ``sys.path``).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

BUSY_SHARE = 0.25
"""Busy: other processes used more than this share of the machine's cores during a measurement."""


def usable_cpus() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def machine_cpus() -> int:
    return os.cpu_count() or 1


def machine_busy_seconds() -> float | None:
    """CPU seconds the whole machine has spent not idle since boot (None where /proc/stat is missing)."""
    try:
        with open("/proc/stat", encoding="ascii") as stat:
            fields = [int(v) for v in stat.readline().split()[1:9]]
    except (OSError, ValueError):
        return None
    user, nice, system, idle, iowait, irq, softirq, steal = (fields + [0] * 8)[:8]
    return (user + nice + system + irq + softirq + steal) / os.sysconf("SC_CLK_TCK")


def load_average() -> tuple[float, float, float]:
    return os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3


@dataclass
class Measurement:
    """One timed piece of work: wall and CPU seconds, and what else the machine did meanwhile."""

    wall: float = 0.0
    cpu: float = 0.0
    """CPU seconds of the measured work (this process by default; see :func:`measure`)."""
    machine: float | None = None
    """CPU seconds the whole machine spent meanwhile (None: unknown here)."""
    load_before: tuple[float, float, float] = (0.0, 0.0, 0.0)
    load_after: tuple[float, float, float] = (0.0, 0.0, 0.0)
    cpus: int = field(default_factory=machine_cpus)

    @property
    def others(self) -> float | None:
        """CPU seconds other work took meanwhile (the machine's less the measured work's)."""
        return None if self.machine is None else max(0.0, self.machine - self.cpu)

    @property
    def others_share(self) -> float | None:
        """The others' CPU time as a share of all cores over the wall time (0 quiet, 1 every core busy)."""
        if self.others is None or self.wall <= 0:
            return None
        return self.others / (self.cpus * self.wall)

    @property
    def busy(self) -> bool:
        share = self.others_share
        if share is None:  # no /proc/stat: the load average before the work, less nothing of ours
            return self.load_before[0] > BUSY_SHARE * self.cpus
        return share > BUSY_SHARE

    def rates(self, count: float) -> tuple[float, float]:
        """(per CPU second, per wall second)."""
        return count / max(self.cpu, 1e-12), count / max(self.wall, 1e-12)

    def describe(self) -> str:
        """One line: load before/after, the others' share, busy or quiet."""
        share = self.others_share
        others = "others' CPU unknown" if share is None else f"other work used {share:.0%} of {self.cpus} cores"
        return (f"load average {_load(self.load_before)} before, {_load(self.load_after)} after; {others}; "
                + ("BUSY: wall-clock rates are floors, compare CPU-time rates" if self.busy else "quiet"))


def _load(values: tuple[float, float, float]) -> str:
    return "/".join(f"{v:.2f}" for v in values)


@contextmanager
def measure(cpu_clock: Callable[[], float] = time.process_time) -> Iterator[Measurement]:
    """Time the ``with`` block. ``cpu_clock`` counts the measured work's CPU seconds (default: this
    process, all threads); work in other processes sets ``Measurement.cpu`` itself afterwards."""
    result = Measurement(load_before=load_average())
    machine = machine_busy_seconds()
    cpu = cpu_clock()
    started = time.perf_counter()
    try:
        yield result
    finally:
        result.wall = time.perf_counter() - started
        result.cpu = cpu_clock() - cpu
        after = machine_busy_seconds()
        result.machine = None if machine is None or after is None else after - machine
        result.load_after = load_average()


def combined(parts: list[Measurement]) -> Measurement:
    """The sum of several measurements (load: the first's before, the last's after)."""
    total = Measurement(load_before=parts[0].load_before, load_after=parts[-1].load_after)
    total.wall = sum(p.wall for p in parts)
    total.cpu = sum(p.cpu for p in parts)
    machines = [p.machine for p in parts]
    total.machine = None if any(m is None for m in machines) else sum(machines)  # type: ignore[arg-type]
    return total


def print_load_summary(parts: list[Measurement]) -> None:
    """The measured time of all ``parts`` with the machine's load, and how many ran while it was busy."""
    whole = combined(parts)
    print(f"{whole.wall:.1f} s measured ({whole.cpu:.1f} CPU s); {whole.describe()}")
    busy = sum(p.busy for p in parts)
    if busy:
        print(f"{busy} of {len(parts)} measurements ran while other work used over a quarter of the cores")

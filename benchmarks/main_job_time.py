"""The main job (``bash scripts/paper.sh``) from a fresh clone, stage by stage.

    python benchmarks/main_job_time.py [--repo .] [--keep]

Clones the repository's HEAD (committed work only) into a temporary folder
and runs ``bash scripts/paper.sh`` there as a new user would: a new virtual
environment and its packages, the 24 paper puzzles (numba compiles its
kernels on this first run), their renders and solution animations, and the
gallery. It prints each stage's wall time and CPU time (every process of the
job, sampled from ``/proc`` every 50 ms: a floor, as processes shorter than
that are missed), the render command's split between stills and animations
(its own report: the animations' worker time over the 2 workers), the
gallery alone (``phyrogen render --gallery-only`` once more afterwards), the
load average before and after each stage and the share of the cores other
work used (BUSY above a quarter; ``benchmarks/machine_load.py``). The goals:
the whole job within 120 s on 2 cores, renders and animations within 45 s.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from machine_load import Measurement, load_average, machine_busy_seconds, machine_cpus

GOAL_SECONDS = 120.0
GOAL_RENDER_SECONDS = 45.0
STAGES = ("install", "generation", "render")
MARKER = re.compile(r"^paper\.sh: stage (\w+) done at ([0-9.]+)$")
RENDER_LINE = re.compile(r"^(\d+) puzzles, (\d+) images .* in ([0-9.]+) s: .* with (\d+) workers$")
PIP_NOISE = re.compile(r"^WARNING: Location '.*' is ignored")
ANIMATION_LINE = re.compile(r"^(\d+) solution animations, ([0-9.]+) s each")


class SessionCpu:
    """CPU seconds of every process in one session (a job started with ``start_new_session``),
    sampled from ``/proc``: for each process the last utime + stime seen, summed."""

    def __init__(self, session: int, interval: float = 0.05):
        self.session, self.interval = session, interval
        self.seen: dict[tuple[int, int], float] = {}
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._tick = os.sysconf("SC_CLK_TCK")

    def __enter__(self) -> SessionCpu:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()

    def total(self) -> float:
        self.sample()
        with self._lock:
            return sum(self.seen.values())

    def sample(self) -> None:
        for entry in os.scandir("/proc"):
            if not entry.name.isdigit():
                continue
            try:
                with open(f"/proc/{entry.name}/stat", encoding="ascii", errors="replace") as stat:
                    text = stat.read()
            except OSError:
                continue
            fields = text[text.rfind(")") + 2:].split()
            # Fields after the name: state ppid pgrp session ... utime(12) stime(13) ... starttime(20).
            if len(fields) < 21 or int(fields[3]) != self.session:
                continue
            key = (int(entry.name), int(fields[19]))
            with self._lock:
                self.seen[key] = (int(fields[11]) + int(fields[12])) / self._tick

    def _run(self) -> None:
        while not self._stop.wait(self.interval):
            self.sample()


@dataclass
class Stage:
    name: str
    taken: Measurement


def run_job(clone: Path, out: str) -> tuple[list[Stage], list[str], float, int]:
    """Run paper.sh in ``clone``; the stages, every output line, the reaped CPU seconds, the exit status."""
    environment = dict(os.environ, PHYROGEN_STAGE_TIMES="1")
    for name in ("VIRTUAL_ENV", "PHYROGEN_VENV", "PYTHONPATH", "PHYROGEN_EXTRAS"):
        environment.pop(name, None)  # the clone's own environment, as a new user's
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    stages: list[Stage] = []
    lines: list[str] = []
    current = Measurement(load_before=load_average())
    machine = machine_busy_seconds()
    started = time.perf_counter()
    process = subprocess.Popen(["bash", "scripts/paper.sh", out], cwd=clone, env=environment, text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)
    with SessionCpu(process.pid) as cpu:
        cpu_before = 0.0
        assert process.stdout is not None
        for raw in process.stdout:
            line = raw.rstrip("\n")
            lines.append(line)
            marker = MARKER.match(line)
            if marker is None:
                # Progress bars and pip's notes on index folders it skips stay quiet.
                if not line.startswith("\r") and "%|" not in line and not PIP_NOISE.match(line):
                    print(f"  | {line}", flush=True)
                continue
            now = time.perf_counter()
            total = cpu.total()
            busy = machine_busy_seconds()
            current.wall, current.cpu = now - started, total - cpu_before
            current.machine = None if busy is None or machine is None else busy - machine
            current.load_after = load_average()
            stages.append(Stage(marker.group(1), current))
            print(f"  {marker.group(1)} done after {current.wall:.1f} s", flush=True)
            current = Measurement(load_before=current.load_after)
            started, cpu_before, machine = now, total, busy
        process.wait()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    reaped = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return stages, lines, reaped, process.returncode


def gallery_time(clone: Path, out: str) -> Measurement:
    from machine_load import measure

    phyrogen = clone / ".venv" / "bin" / "phyrogen"
    with measure(cpu_clock=_children_cpu) as taken:
        subprocess.run([str(phyrogen), "render", "--out", out, "--gallery-only", "--quiet"], cwd=clone, check=True,
                       stdout=subprocess.DEVNULL)
    return taken


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repo", default=str(Path(__file__).resolve().parent.parent),
                        help="the repository to clone (its HEAD)")
    parser.add_argument("--keep", action="store_true", help="keep the clone and its output (printed)")
    parser.add_argument("--out", default="output", help="paper.sh's output folder in the clone")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="phyrogen-main-job-"))
    clone = folder / "phyrogen"
    try:
        commit = subprocess.run(["git", "-C", args.repo, "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, check=True).stdout.strip()
        subprocess.run(["git", "clone", "--quiet", "--no-hardlinks", args.repo, str(clone)], check=True)
        print(f"fresh clone of {args.repo} at {commit} in {clone}; {machine_cpus()} cores; "
              f"load average {'/'.join(f'{v:.2f}' for v in load_average())}")
        stages, lines, reaped, status = run_job(clone, args.out)
        if status != 0:
            print(f"paper.sh failed with exit status {status}", file=sys.stderr)
            return 1
        gallery = gallery_time(clone, args.out)
        report(stages, lines, reaped, gallery)
        return 0
    finally:
        if args.keep:
            print(f"kept: {clone}")
        else:
            shutil.rmtree(folder, ignore_errors=True)


def report(stages: list[Stage], lines: list[str], reaped: float, gallery: Measurement) -> None:
    by_name = {s.name: s.taken for s in stages}
    render = by_name.get("render")
    rows: list[tuple[str, float, float | None, Measurement | None]] = []
    for name in STAGES:
        taken = by_name.get(name)
        if taken is not None:
            rows.append((name, taken.wall, taken.cpu, taken))
    render_line = next((m for m in map(RENDER_LINE.match, lines) if m), None)
    animation_line = next((m for m in map(ANIMATION_LINE.match, lines) if m), None)
    if render is not None and render_line is not None:
        workers = int(render_line.group(4))
        rendering = float(render_line.group(3))
        animations = (int(animation_line.group(1)) * float(animation_line.group(2)) / workers
                      if animation_line else 0.0)
        rows.append(("  renders (stills)", rendering - animations, None, None))
        rows.append(("  animations", animations, None, None))
        rows.append(("  start-up, checks, gallery", render.wall - rendering, None, None))
    rows.append(("gallery alone, again", gallery.wall, gallery.cpu, gallery))
    print(f"\n{'stage':28s} {'wall s':>8s} {'CPU s':>8s}  load before -> after, others' share of the cores")
    for name, wall, cpu, taken in rows:
        cpu_text = "" if cpu is None else f"{cpu:8.1f}"
        extra = ""
        if taken is not None:
            share = taken.others_share
            extra = (f"  {taken.load_before[0]:.2f} -> {taken.load_after[0]:.2f}, "
                     + ("?" if share is None else f"{share:.0%}") + (" BUSY" if taken.busy else ""))
        print(f"{name:28s} {wall:8.1f} {cpu_text:>8s}{extra}")
    total = sum(s.taken.wall for s in stages)
    cpu = sum(s.taken.cpu for s in stages)
    print(f"{'paper.sh in all':28s} {total:8.1f} {cpu:8.1f}  (CPU sampled every 50 ms, a floor; "
          f"{reaped:.1f} CPU s counted by the kernel for the processes it reaped)")
    busy = [s.name for s in stages if s.taken.busy]
    print(("BUSY during " + ", ".join(busy) + ": wall times are floors, compare CPU times") if busy else
          "quiet: other work used at most a quarter of the cores in every stage")
    verdict = "meets" if total <= GOAL_SECONDS else "MISSES"
    print(f"main job {total:.1f} s: {verdict} the {GOAL_SECONDS:.0f} s goal")
    if render_line is not None:
        rendering = float(render_line.group(3))
        verdict = "meets" if rendering <= GOAL_RENDER_SECONDS else "MISSES"
        print(f"renders and animations {rendering:.1f} s: {verdict} the {GOAL_RENDER_SECONDS:.0f} s goal")


if __name__ == "__main__":
    sys.exit(main())

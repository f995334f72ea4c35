"""Dataset speed: certified puzzles per CPU second per generator, this tree against a baseline commit.

    python benchmarks/dataset_speed.py [--baseline HEAD~1] [--generators grid_world,rooms]
                                       [--scale 1] [--workers 1] [--repeat 1] [--start 5000001]

The baseline commit is checked out into a temporary git worktree under /tmp (removed afterwards);
both trees run ``phyrogen dataset`` as a user would (start-up, pool, generation, certification,
export, hashing, the manifest), with the same seeds, the same settings and the same venv, one
after the other per generator, so both rates come from the same minutes of the same machine. A
rate counts the CPU time of the whole command and everything it started (``RUSAGE_CHILDREN``);
each tree first makes one throw-away puzzle per generator, outside the timing, so numba's
compiled kernels are cached (a new worktree compiles them once: about 40 CPU s).

Prints per generator: puzzles, CPU seconds per puzzle, puzzles per CPU second and per hour on
two cores for each tree, the ratio (this tree / baseline), the median ``generation_seconds`` of
the manifest (a worker's wall time per puzzle), whether the manifests agree on the columns both
have, apart from those that may differ (timing, content hash: a ``puzzle.json`` format change
moves it), how many puzzle folders are byte-identical (the same content hash), and the machine's load.

A run's CPU time has a fixed part (the command's imports, the worker pool and its server, the manifest)
that a large dataset spreads over many puzzles and a run of tens of puzzles does not. So each tree also
makes a dataset of the first puzzle alone (``--startup-runs`` times, the least CPU kept), and a second
table splits the cost: that run's CPU (*start-up*, one puzzle included) and the CPU each further puzzle
adds, (whole run - start-up) / (puzzles - 1), the cost of a puzzle in a dataset large enough for the
start-up not to count. Both tables come from the same runs; neither replaces the other.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from dataset_sizes import plan
from machine_load import load_average, measure

ROOT = Path(__file__).resolve().parents[1]
PLAN = plan({"grid_world": 200, "simple_slider": 60, "lockbox_random": 12, "rooms": 30, "continuous_space": 20,
             "move_n_times": 6})
"""Each generator's (puzzles at --scale 1, its size settings)."""
COMPARED_AWAY = ("generation_seconds", "validation_checks", "content_hash")
"""Manifest columns left out when the two trees' datasets are compared: timings, and what a change to
``puzzle.json``'s format or the validator's own bookkeeping moves without changing the puzzle."""


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _adopt_orphans() -> None:
    """Make this process the reaper of its orphaned descendants (Linux): the dataset's workers come from
    a fork server that outlives the command for a moment, and the CPU time of a process counts in
    RUSAGE_CHILDREN only once something here has waited for it."""
    import ctypes

    pr_set_child_subreaper = 36
    if ctypes.CDLL(None, use_errno=True).prctl(pr_set_child_subreaper, 1, 0, 0, 0) != 0:
        raise SystemExit("cannot count the workers' CPU time: prctl(PR_SET_CHILD_SUBREAPER) failed")


def _reap_all() -> None:
    while True:
        try:
            os.waitpid(-1, 0)
        except ChildProcessError:
            return


def run_dataset(tree: Path, generator: str, first: int, count: int, settings: list[str], workers: int,
                out: Path) -> tuple[float, float]:
    """``phyrogen dataset`` of ``tree`` into ``out``: (CPU seconds of it and its children, wall seconds)."""
    command = [sys.executable, "-m", "phyrogen", "dataset", "--generator", generator, "--count", str(count),
               "--start", str(first), "--workers", str(workers), "--out", str(out), "--quiet"]
    for setting in settings:
        command += ["--set", setting]
    env = {**os.environ, "PYTHONPATH": str(tree)}
    cpu, wall = _children_cpu(), time.perf_counter()
    done = subprocess.run(command, cwd=tree, env=env, capture_output=True, text=True)
    _reap_all()  # the fork server and any worker it left: their CPU time counts from here
    cpu, wall = _children_cpu() - cpu, time.perf_counter() - wall
    if done.returncode != 0:
        raise SystemExit(f"{tree}: phyrogen dataset failed ({done.returncode}): {done.stderr.strip()[-2000:]}")
    return cpu, wall


def manifest(root: Path) -> tuple[list[dict], list[float], int, list]:
    """(rows without the compared-away columns, generation seconds of the made puzzles, failures,
    content hashes)."""
    import pyarrow.parquet as pq

    table = pq.read_table(root / "manifest.parquet")
    seconds = [s for s, ok in zip(table.column("generation_seconds").to_pylist(),
                                  table.column("status").to_pylist(), strict=True) if ok == "ok" and s is not None]
    failed = table.column("status").to_pylist().count("failed")
    hashes = table.column("content_hash").to_pylist()
    return table.drop_columns(list(COMPARED_AWAY)).to_pylist(), seconds, failed, hashes


def startup_cpu(tree: Path, generator: str, first: int, settings: list[str], workers: int, out: Path,
                runs: int) -> float | None:
    """The least CPU of ``runs`` datasets of the first puzzle alone (None when ``runs`` is 0)."""
    taken = []
    for _ in range(runs):
        taken.append(run_dataset(tree, generator, first, 1, settings, workers, out)[0])
        shutil.rmtree(out)
    return min(taken, default=None)


def startup_table(rows: list, trees: list[str]) -> str:
    """The second table (module docstring): each tree's start-up and the CPU a further puzzle adds."""
    lines = ["", "| generator | puzzles | start-up CPU s (baseline, this tree) | CPU s a further puzzle adds "
             "(baseline, this tree) | ratio of further puzzles | this tree per hour on 2 cores, start-up aside |",
             "|---|---:|---|---|---:|---:|"]
    for generator, count, taken, _, startup in rows:
        if count < 2:
            continue
        further = [max(taken[n][0] - startup[n], 0.0) / (count - 1) for n in trees]
        ratio = f"{further[0] / further[1]:.2f}x" if further[1] > 0 else "-"
        hourly = f"{2 * 3600 / further[1]:,.0f}" if further[1] > 0 else "-"
        lines.append(f"| {generator} | {count} | {startup[trees[0]]:.2f}, {startup[trees[1]]:.2f} "
                     f"| {further[0]:.4f}, {further[1]:.4f} | {ratio} | {hourly} |")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--baseline", default="HEAD~1", help="the commit to compare with (default HEAD~1)")
    parser.add_argument("--generators", default=",".join(PLAN))
    parser.add_argument("--scale", type=float, default=1.0, help="multiplies every generator's puzzle count")
    parser.add_argument("--workers", type=int, default=1, help="worker processes of each dataset run")
    parser.add_argument("--repeat", type=int, default=1, help="runs per tree and generator; the least CPU kept")
    parser.add_argument("--start", type=int, default=5_000_001, help="the first seed (choose fresh ones)")
    parser.add_argument("--startup-runs", type=int, default=3,
                        help="one-puzzle runs per tree and generator, the least CPU kept (0: no start-up table)")
    args = parser.parse_args()
    _adopt_orphans()
    generators = args.generators.split(",")
    unknown = [g for g in generators if g not in PLAN]
    if unknown:
        print(f"unknown generator {unknown[0]!r}; valid: {', '.join(PLAN)}", file=sys.stderr)
        return 2
    baseline = subprocess.run(["git", "rev-parse", "--short", args.baseline], cwd=ROOT, capture_output=True,
                              text=True)
    if baseline.returncode != 0:
        print(f"--baseline {args.baseline!r} is not a commit of {ROOT}", file=sys.stderr)
        return 2
    commit = baseline.stdout.strip()
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                          text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT, capture_output=True,
                           text=True).stdout.strip()
    scratch = Path(tempfile.mkdtemp(prefix="dataset-speed-"))
    worktree = scratch / "baseline"
    subprocess.run(["git", "worktree", "add", "--detach", str(worktree), commit], cwd=ROOT, check=True,
                   capture_output=True)
    trees = {"baseline": worktree, "this tree": ROOT}
    rows = []
    load = load_average()
    try:
        for generator in generators:
            for tree in trees.values():  # numba's cache and first imports, outside the timing
                run_dataset(tree, generator, 1, 1, PLAN[generator][1], 1, scratch / "warm")
                shutil.rmtree(scratch / "warm")
        with measure(_children_cpu) as whole:
            for generator in generators:
                count, settings = PLAN[generator]
                count = max(1, round(count * args.scale))
                taken: dict[str, tuple[float, float]] = {}
                made: dict[str, tuple[list[dict], list[float], int, list]] = {}
                for _ in range(args.repeat):
                    for name, tree in trees.items():
                        out = scratch / f"{generator}-{name.replace(' ', '-')}"
                        cpu, wall = run_dataset(tree, generator, args.start, count, settings, args.workers, out)
                        if name not in taken or cpu < taken[name][0]:
                            taken[name] = (cpu, wall)
                            made[name] = manifest(out)
                        shutil.rmtree(out)
                startup = {name: startup_cpu(tree, generator, args.start, settings, args.workers,
                                             scratch / "startup", args.startup_runs) for name, tree in trees.items()}
                rows.append((generator, count, taken, made, startup))
                base, this = (taken[n][0] / count for n in trees)
                print(f"{generator:17s} {count:4d} puzzles (seeds {args.start}-{args.start + count - 1}): "
                      f"baseline {base:.4f} CPU s each, this tree {this:.4f} ({base / this:.2f}x)", flush=True)
    finally:
        subprocess.run(["git", "worktree", "remove", "--force", str(worktree)], cwd=ROOT, capture_output=True)
        shutil.rmtree(scratch, ignore_errors=True)
    label = f"{head}{' + uncommitted changes' if dirty else ''}"
    print(f"\nbaseline {commit}, this tree {label}; {args.workers} worker(s) per run; "
          f"load average {'/'.join(f'{v:.2f}' for v in load)} at the start\n")
    print("| generator | puzzles | baseline CPU s / puzzle | this tree CPU s / puzzle | baseline puzzles / CPU s "
          "| this tree puzzles / CPU s | ratio | this tree per hour on 2 cores | median generation_seconds "
          "(baseline, this tree) | failed | same puzzles | byte-identical folders |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---|---|---|---|")
    for generator, count, taken, made, _ in rows:
        (base_cpu, _), (this_cpu, _) = (taken[n] for n in trees)
        medians = ", ".join(f"{statistics.median(made[n][1]):.3f} s" if made[n][1] else "-" for n in trees)
        common = set(made["baseline"][0][0]) & set(made["this tree"][0][0]) if count else set()
        same = [{k: r[k] for k in common} for r in made["baseline"][0]] == \
            [{k: r[k] for k in common} for r in made["this tree"][0]]
        identical = sum(a == b for a, b in zip(made["baseline"][3], made["this tree"][3], strict=True))
        print(f"| {generator} | {count} | {base_cpu / count:.4f} | {this_cpu / count:.4f} | {count / base_cpu:.2f} "
              f"| {count / this_cpu:.2f} | {base_cpu / this_cpu:.2f}x | {2 * 3600 * count / this_cpu:,.0f} "
              f"| {medians} | {made['baseline'][2]}, {made['this tree'][2]} | {'yes' if same else 'NO'} "
              f"| {identical}/{count} |")
    if args.startup_runs:
        print(startup_table(rows, list(trees)))
    print(f"\n{whole.describe()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

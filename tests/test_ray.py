"""``--ray``: a dataset and a benchmark on a local Ray instance with 2 CPUs give what the local pool
gives; a Ray run killed with SIGKILL leaves no process and resumes to the same dataset.

Seeds are drawn afresh for every run (they are in the failure messages): the backends must agree on
puzzles no one looked at before.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from waiting import BACKSTOP, wait_until

pytest.importorskip("ray")
pq = pytest.importorskip("pyarrow.parquet")

from phyrogen.cli import main  # noqa: E402
from solver.benchmark.journal import JOURNAL, read_journal  # noqa: E402
from solver.pipelines.dataset import TIMING_COLUMNS  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RAY_CHECKS = 100_000
"""Collision checks per run. On 12 random 3-object Simple Slider seeds (2 runs each, until first) LA-RRT's
first solutions took 1,270-5,237 checks, LA-RRT+push's 122-793 and RRT*'s 2,412-8,113: 100,000 is 19
times LA-RRT's most, and a run that spends it all takes a few seconds. The time limit is a backstop."""


def dataset_files(root: Path) -> dict[str, bytes]:
    """Every file of a dataset but its Parquet files (timing columns) and the run's plots."""
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and p.suffix != ".parquet"}


def manifest_rows(root: Path) -> list[dict]:
    from solver.pipelines.dataset import manifest_rows as read_rows

    rows, complete = read_rows(root)
    assert complete
    return [{k: v for k, v in row.to_dict().items() if k not in TIMING_COLUMNS} for row in rows]


def ray_processes(session_of: int) -> list[str]:
    """Command lines of the Ray processes a command of process group ``session_of`` started."""
    out = subprocess.run(["ps", "-eo", "pgid=,args="], capture_output=True, text=True).stdout
    return [line for line in out.splitlines() if line.split(None, 1)[0] == str(session_of) and "ray" in line]


@pytest.mark.slow
def test_a_dataset_on_ray_is_the_local_one_byte_for_byte_even_after_sigkill(tmp_path):
    first = random.SystemRandom().randrange(200_000, 900_000)
    options = ["dataset", "--generator", "grid_world,rooms", "--seeds", f"{first}-{first + 11}",
               "--shard-size", "8", "--quiet"]
    assert main([*options, "--out", str(tmp_path / "local")]) == 0

    root = tmp_path / "ray"
    command = [sys.executable, "-m", "phyrogen", *options, "--out", str(root), "--ray", "--workers", "2"]
    process = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)

    def three_puzzles() -> bool:
        assert process.poll() is None, process.communicate()
        return len(list(root.glob("shard-*/*/[!.]*/puzzle.json"))) >= 3

    wait_until(three_puzzles, f"seeds {first}+: three puzzles on Ray")
    os.kill(process.pid, signal.SIGKILL)  # the command alone: Ray's processes must end with it
    process.communicate(timeout=BACKSTOP)
    wait_until(lambda: not ray_processes(process.pid),
               lambda: f"the end of the Ray processes of the killed command: {ray_processes(process.pid)}", poll=0.1)

    resumed = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=BACKSTOP)
    assert resumed.returncode == 0, resumed.stderr
    assert "24/24 puzzles ok" in resumed.stdout, resumed.stdout
    assert dataset_files(root) == dataset_files(tmp_path / "local"), f"seeds {first}-{first + 11}"
    assert manifest_rows(root) == manifest_rows(tmp_path / "local"), f"seeds {first}-{first + 11}"


@pytest.mark.slow
def test_a_benchmark_on_ray_runs_every_job_with_the_local_seeds_and_results(tmp_path):
    seed = random.SystemRandom().randrange(200_000, 900_000)
    assert main(["generate", "--generator", "simple_slider", "--seeds", str(seed), "--set", "n_objects=3",
                 "--out", str(tmp_path / "puzzles"), "--quiet"]) == 0
    journals = {}
    for name, extra in (("local", []), ("ray", ["--ray"])):
        out = tmp_path / name
        assert main(["benchmark", "--puzzles", str(tmp_path / "puzzles"), "--planners", "la_rrt,la_rrt_push,rrt_star",
                     "--runs", "2", "--budget-checks", str(RAY_CHECKS), "--time-limit", "300", "--until", "first",
                     "--no-solutions", "--out", str(out), "--quiet", *extra]) in (0, 1)
        journals[name] = {key: record for key, record in read_journal(out / JOURNAL).items()}
        assert (out / "summary.md").is_file() and (out / "benchmark.db").is_file()
    assert journals["ray"].keys() == journals["local"].keys() and len(journals["ray"]) == 6, f"seed {seed}"
    for key, local in journals["local"].items():
        # Seeded, and ended by its first solution or its budget, not by the clock: the same run, checks
        # and path on both backends, however busy the machine.
        remote = journals["ray"][key]
        assert (remote.solved, remote.checks) == (local.solved, local.checks), f"seed {seed}: {key}"
        if local.planner.startswith("LA-RRT"):
            assert local.solved and remote.path == local.path, f"seed {seed}: {key}"


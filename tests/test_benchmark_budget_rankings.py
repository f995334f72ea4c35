"""scripts/budget_rankings.py: the ranking under a check budget beside the ranking under a CPU budget,
from two benchmarks' journals; a clock-ended run is counted apart, not as a failure."""

from __future__ import annotations

import functools
import importlib.util
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


@functools.cache
def _script():
    spec = importlib.util.spec_from_file_location("budget_rankings_script", ROOT / "scripts" / "budget_rankings.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def _journal(folder: Path, outcomes: dict[str, list[tuple[bool, str, int, float]]]) -> Path:
    """A journal of runs on grid_world_1: per planner name, (solved, end, checks, cpu seconds) per run."""
    from solver.benchmark.jobs import RunRecord
    from solver.benchmark.journal import JOURNAL, journal_line
    from solver.planning.registry import get_planner

    folder.mkdir(parents=True)
    lines = []
    for planner, runs in outcomes.items():
        title = get_planner(planner).title
        for run, (solved, end, checks, cpu) in enumerate(runs):
            status = "Exact solution" if solved else "Timeout"
            record = RunRecord(title, "grid_world_1", run, run, 600.0, solved, status, 1.0, 0.5 if solved else None,
                               3 if solved else None, 1.0 if solved else None, 10, 0, (), checks=checks, cpu_time=cpu,
                               end=end)
            key = json.dumps({"planner": planner, "puzzle": "grid_world_1", "run": run, "seed": run})
            lines.append(journal_line(key, record))
    (folder / JOURNAL).write_bytes(b"".join(lines))
    return folder


def test_the_rankings_side_by_side_count_a_clock_ended_run_apart(tmp_path):
    script = _script()
    solved, failed = (True, "solved", 1000, 0.1), (False, "budget", 1_120_000, 1.0)
    # Under checks BIT* solves more; under CPU seconds RRT* does (its checks are cheap in CPU).
    # LBT-RRT ran under the check budget only: not compared.
    checks = _journal(tmp_path / "checks", {"rrt_star": [solved, failed, failed], "bit_star": [solved, solved, failed],
                                            "lbt_rrt": [failed]})
    cpu = _journal(tmp_path / "cpu", {"rrt_star": [solved, solved, solved],
                                      "bit_star": [solved, failed, (False, "clock", 500, 0.2)]})
    text = script.report(script.records([checks]), script.records([cpu]))
    rows = {line.split(" | ")[0].strip("| "): line.split(" | ") for line in text.splitlines() if line.startswith("| ")}
    assert rows["RRT*"][1].startswith("1/3") and rows["RRT*"][2] == "2" and rows["RRT*"][4].startswith("3/3")
    assert rows["RRT*"][5] == "1"
    assert rows["BIT*"][1].startswith("2/3") and rows["BIT*"][2] == "1"
    # The clock-ended run is neither a success nor a failure of the CPU budget: 1 of 2, named apart.
    assert rows["BIT*"][4].startswith("1/2") and "(+1 clock)" in rows["BIT*"][4] and rows["BIT*"][5] == "2"
    assert "end reasons budget 1, clock 1, solved 4" in text and "LBT-RRT" not in text
    assert "| grid_world | 1/3 / 3/3 | 2/3 / 1/2 |" in text


def test_a_cpu_budget_matches_a_check_budget_at_the_median_rate(tmp_path):
    script = _script()
    from solver.benchmark.jobs import RunRecord

    spent = ((100, 1.0), (300, 1.0), (200, 1.0))
    runs = [RunRecord("BIT*", "rooms_1", k, k, 1.0, False, "Timeout", 1.0, None, None, None, 1, 0, (),
                      checks=checks, cpu_time=cpu) for k, (checks, cpu) in enumerate(spent)]
    assert script.cpu_budgets(runs, {"rooms": 2000, "grid_world": 5}) == {"rooms": 10.0}  # median 200 a CPU second

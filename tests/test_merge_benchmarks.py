"""scripts/merge_benchmarks.py: a rerun replaces the run it repeats, and only that run."""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import merge_benchmarks  # noqa: E402


def _line(run: int, solved: bool, seed: int | None = None, checks: int = 1000) -> bytes:
    from solver.benchmark.jobs import RunRecord
    from solver.benchmark.journal import journal_line

    seed = 100 + run if seed is None else seed
    key = {"planner": "la_rrt", "planner_version": "v", "puzzle": "toy_1", "puzzle_sha256": "d", "run": run,
           "seed": seed, "until": "first", "budget_checks": 5000, "time_limit": 10.0}
    record = RunRecord("LA-RRT", "toy_1", run, seed, 10.0, solved, "Exact solution" if solved else "Timeout",
                       0.5, 0.5 if solved else None, 2 if solved else None, 1.0 if solved else None, 10, 0, (),
                       checks=checks, cpu_time=0.5, first_solution_checks=checks if solved else None,
                       end="solved" if solved else "budget")
    return journal_line(json.dumps(key, sort_keys=True), record)


def _summary(out: Path) -> dict:
    (cell,) = json.loads((out / "summary.json").read_text())["cells"]
    return cell


def test_a_rerun_replaces_the_run_it_repeats(tmp_path):
    first, rerun = tmp_path / "first.jsonl", tmp_path / "rerun.jsonl"
    first.write_bytes(_line(0, True) + _line(1, False) + _line(2, False))
    rerun.write_bytes(_line(1, True, checks=4000))
    assert merge_benchmarks.main([str(tmp_path / "alone"), str(first)]) == 0
    assert merge_benchmarks.main([str(tmp_path / "merged"), str(first), str(rerun)]) == 0
    alone, merged = _summary(tmp_path / "alone"), _summary(tmp_path / "merged")
    assert (alone["successes"], alone["runs"]) == (1, 3)
    assert (merged["successes"], merged["runs"]) == (2, 3)  # run 1 replaced; runs 0 and 2 kept
    assert merged["checks_to_first"]["samples"] == 3
    assert "| toy_1 |" in (tmp_path / "merged" / "summary.md").read_text()


def test_a_run_with_another_seed_is_not_the_same_run(tmp_path, capsys):
    first, other = tmp_path / "first.jsonl", tmp_path / "other.jsonl"
    first.write_bytes(_line(0, False))
    other.write_bytes(_line(0, True, seed=7))
    assert merge_benchmarks.main([str(tmp_path / "merged"), str(first), str(other)]) == 2
    err = capsys.readouterr().err
    assert "another seed or puzzle" in err and err.count("\n") == 1
    assert merge_benchmarks.main([str(tmp_path / "merged"), str(tmp_path / "missing.jsonl")]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["first.jsonl", "other.jsonl"]  # nothing written


def test_protocol_tables_count_a_cells_runs_and_refuse_a_broken_journal(tmp_path, capsys):
    import protocol_tables

    first, rerun = tmp_path / "first.jsonl", tmp_path / "rerun.jsonl"
    first.write_bytes(_line(0, True) + _line(1, False) + _line(2, False))
    rerun.write_bytes(_line(1, True, checks=4000))
    assert protocol_tables.main([str(first), str(rerun)]) == 0
    table = capsys.readouterr().out
    assert "| LA-RRT | 3 | 0/1 | 1/1 | 2/3 " in table  # run 1 replaced by the rerun, still not solved in all
    assert "| toy_1 | 2/3 |" in table
    rerun.write_bytes(_line(1, True) + _line(2, True))
    assert protocol_tables.main([str(first), str(rerun)]) == 0
    assert "| LA-RRT | 3 | 1/1 | 1/1 | 3/3 " in capsys.readouterr().out  # the control: every run solved
    broken = tmp_path / "broken.jsonl"
    broken.write_text('{"record": {}}\n')
    assert protocol_tables.main([str(broken)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and str(broken) in captured.err and captured.err.count("\n") == 1

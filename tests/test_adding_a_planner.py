"""The worked example of docs/adding-a-planner.md, docs/examples/rrt_connect_planner.py, as a planner.

It is registered into a copy of the registry (the five built-in entries stay as they were) and must
then be what every planner is: listed by the command line, run by the benchmark in a fresh worker
process (which loads the example from its file), and scored with the same action count. Bad or
duplicate registrations and unknown names are refused.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import pytest

from solver.planning.registry import PLANNERS, Planner, get_planner, planner, planner_names, registry_copy

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "docs" / "examples" / "rrt_connect_planner.py"
NAME = "rrt_connect"
BUILT_IN = (("la_rrt", "LA-RRT"), ("la_rrt_push", "LA-RRT+push (ours)"), ("rrt_star", "RRT*"),
            ("lbt_rrt", "LBT-RRT"), ("bit_star", "BIT*"))
"""Benchmark journals and logs key on these names, titles and this order."""
ABLATIONS = (("la_rrt_segment_check", "LA-RRT, original segment check"),
             ("la_rrt_fixed_order", "LA-RRT, fixed factor order"))
"""Registered after the five, outside ``--planners all`` (group "ablations")."""


def load_example() -> None:
    """Run the example module, which registers its planner in the registry in use."""
    spec = importlib.util.spec_from_file_location("rrt_connect_planner_example", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    try:
        spec.loader.exec_module(module)
    finally:
        del sys.modules[spec.name]  # loaded again next time, into that test's registry copy


@pytest.fixture()
def with_example():
    with registry_copy():
        load_example()
        yield get_planner(NAME)


@pytest.fixture(scope="module")
def slider_folder(tmp_path_factory):
    from phyrogen_core.export import write_puzzle
    from phyrogen_core.folder import find_puzzle_folders
    from solver.pipelines.generation import generate_puzzle, versions

    root = tmp_path_factory.mktemp("puzzles")
    write_puzzle(generate_puzzle("simple_slider", 2), root, versions())
    return find_puzzle_folders(root)


def test_the_example_is_registered_after_the_five_built_in_entries_only_in_the_copy(with_example):
    assert planner_names()[-1] == NAME and with_example.title == "RRT-Connect"
    assert tuple((s.name, s.title) for s in PLANNERS.values())[:5] == BUILT_IN
    assert with_example.uses_ompl_rng and with_example.version.startswith("ompl-1/goals")
    assert with_example.source[1] == str(EXAMPLE)


def test_the_real_registry_does_not_have_the_example_and_keeps_its_versions():
    assert tuple((s.name, s.title) for s in PLANNERS.values()) == BUILT_IN + ABLATIONS
    versions = {s.name: s.version.rsplit("/", 1)[0] for s in PLANNERS.values()}
    # Only the goal sampler's tag (last part) may change without a hand-bumped code version.
    assert versions == {"la_rrt": "paper-4/006e4be6", "la_rrt_push": "push-5/a2c6ea6d", "rrt_star": "ompl-6",
                        "lbt_rrt": "py-4", "bit_star": "ompl-6", "la_rrt_segment_check": "paper-4/5b264df5",
                        "la_rrt_fixed_order": "paper-4/346014de"}


def test_the_command_line_offers_it_and_refuses_an_unregistered_name(with_example, slider_folder, tmp_path,
                                                                     capsys):
    from phyrogen.cli import build_parser, main

    # Blanks removed: argparse wraps the help text at blanks and hyphens.
    assert f"{NAME}(RRT-Connect)" in "".join(_benchmark_help(build_parser()).split())
    puzzles = str(slider_folder[0].path.parent.parent)
    ok = main(["benchmark", "--puzzles", puzzles, "--planners", NAME, "--out", str(tmp_path / "b"), "--dry-run",
               "--runs", "1", "--time-limit", "1", "--budget-checks", "1000"])
    assert ok == 0
    capsys.readouterr()
    refused = main(["benchmark", "--puzzles", puzzles, "--planners", "prm_star", "--out", str(tmp_path / "b"),
                    "--dry-run"])
    err = capsys.readouterr().err.strip().splitlines()
    assert refused == 2 and len(err) == 1 and "unknown planner 'prm_star'" in err[0] and NAME in err[0]


def _benchmark_help(parser) -> str:
    import argparse

    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices["benchmark"].format_help()


def _trial(plan, name: str, title: str, version: str = "1", **declared) -> type[Planner]:
    """A planner class declaring ``name``, ``title`` and ``version`` (not yet registered)."""
    return type("Trial", (Planner,), {"name": name, "title": title, "version": version, "uses_ompl_rng": True,
                                      "plan": staticmethod(plan), **declared})


def test_a_duplicate_or_malformed_registration_is_refused(with_example):
    plan = with_example.plan_function
    with pytest.raises(ValueError, match="registered already"):
        planner(_trial(plan, NAME, "Another title"))
    with pytest.raises(ValueError, match="must declare version"):
        planner(type("NoVersion", (Planner,), {"name": "fresh", "title": "Fresh", "plan": staticmethod(plan)}))
    with pytest.raises(ValueError, match="title 'RRT\\*' is taken by 'rrt_star'"):
        planner(_trial(plan, "rrt_star_2", "RRT*"))
    for bad in ("all", "RRT", "rrt connect", "", "9rrt"):
        with pytest.raises(ValueError, match="planner name"):
            planner(_trial(plan, bad, "Fresh title"))
    with pytest.raises(ValueError, match="version"):
        planner(_trial(plan, "fresh", "Fresh title", version=""))
    with pytest.raises(ValueError, match="planner group"):
        planner(_trial(plan, "fresh", "Fresh title", group="favourites"))
    with pytest.raises(ValueError, match="decorates a subclass"):
        planner(type("NotAPlanner", (), {"name": "fresh"}))
    assert planner_names()[-1] == NAME and len(PLANNERS) == len(BUILT_IN + ABLATIONS) + 1
    # The control: the same declaration with a fresh name and title is registered, at the end.
    assert planner(_trial(plan, "fresh", "Fresh title")).spec is get_planner("fresh") and planner_names()[-1] == "fresh"


def test_it_runs_in_a_benchmark_and_is_scored_like_the_others(with_example, slider_folder, tmp_path):
    import numpy as np

    from phyrogen_core.actions import count_actions
    from phyrogen_core.export import read_puzzle_dir
    from solver.benchmark.journal import JOURNAL, read_journal
    from solver.benchmark.plots import summary_rows
    from solver.benchmark.profiles import get_profile
    from solver.benchmark.runner import run_benchmark

    # A check budget, not seconds: what the runs find does not depend on the machine's load.
    out = run_benchmark(slider_folder, ["la_rrt_push", NAME], get_profile("quick", runs=2, time_limit=120.0),
                        tmp_path / "bench", workers=2, progress=False, save_solutions=False,
                        budget_checks=200_000)  # motions charged by their length
    mine = [r for r in out.records if r.planner == "RRT-Connect"]
    assert len(mine) == 2 and all(r.error is None for r in mine), [r.error for r in mine]
    assert all(r.solved and 200_000 <= r.checks < 210_000 and r.cpu_time > 0 and r.end == "budget"
               for r in mine), mine
    chain = read_puzzle_dir(slider_folder[0].path).chain
    for record in out.records:  # the journal's paths are in the chain's joint order
        assert record.action_cost == count_actions(np.asarray(record.path), chain.factors)
    rows = {r.planner: r for r in summary_rows(out.database)}
    assert set(rows) == {"LA-RRT+push (ours)", "RRT-Connect"} and rows["RRT-Connect"].success == 1.0
    log = (tmp_path / "bench" / "logs" / f"{slider_folder[0].name}.log").read_text()
    assert "RRT-Connect\n" in log and "budget_checks INTEGER = 200000" in log
    keys = [json.loads(k) for k in read_journal(tmp_path / "bench" / JOURNAL)]
    assert {k["planner"] for k in keys} == {"la_rrt_push", NAME} and {k["budget_checks"] for k in keys} == {200_000}


def test_the_guide_and_the_docs_name_every_registered_planner():
    guide = (ROOT / "docs" / "adding-a-planner.md").read_text(encoding="utf-8")
    example = EXAMPLE.read_text(encoding="utf-8")
    declaration = example[example.index("@planner\n"):].strip()
    assert declaration in guide, "the guide shows the example's planner class as it is"
    table = (ROOT / "docs" / "benchmark" / "README.md").read_text(encoding="utf-8")
    for spec in PLANNERS.values():
        assert f"| `{spec.name}` | {spec.title} |" in table, spec.name

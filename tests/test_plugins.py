"""Plug-ins installed from packages of their own: a planner and a generator, each a separate package
folder with a ``pyproject.toml`` declaring a ``phyrogen.planners`` / ``phyrogen.generators`` entry point,
installed with pip (no network: no dependencies, no build isolation) into a folder of their own and
used through the command line in a fresh process whose ``PYTHONPATH`` points there. The packages'
code is the guides' worked examples as they stand (docs/examples/), so the guides' route runs.

Negative controls: a package whose entry point names a missing module, and one whose entry names a
function that registers no generator, stop every command with one line naming the entry, exit 2,
no traceback; and without the plug-ins' folder on the path, neither plug-in exists.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "docs" / "examples"
PHYROGEN = [sys.executable, "-m", "phyrogen"]
PLANNER, GENERATOR = "rrt_connect", "two_sliders"


def _package(root: Path, dist: str, module: str, code: str, group: str, entries: dict[str, str]) -> Path:
    """A package folder: ``pyproject.toml`` declaring ``entries`` in ``group``, and ``module``/__init__.py."""
    folder = root / dist
    (folder / module).mkdir(parents=True)
    (folder / module / "__init__.py").write_text(code, encoding="utf-8")
    lines = "\n".join(f'{name} = "{value}"' for name, value in entries.items())
    (folder / "pyproject.toml").write_text(f"""[build-system]
requires = ["setuptools"]
build-backend = "setuptools.build_meta"

[project]
name = "{dist}"
version = "0.1.0"

[tool.setuptools]
packages = ["{module}"]

[project.entry-points."{group}"]
{lines}
""", encoding="utf-8")
    return folder


def _install(packages: list[Path], site: Path) -> None:
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation",
                    "--no-index", "--target", str(site), *map(str, packages)], check=True, capture_output=True)


def _phyrogen(site: Path | None, *args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    if site is not None:
        env["PYTHONPATH"] = str(site)
    return subprocess.run([*PHYROGEN, *args], capture_output=True, text=True, cwd=cwd, env=env, timeout=900)


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("plugins")
    planner = _package(root, "phyrogen-demo-planner", "demo_planner",
                       (EXAMPLES / "rrt_connect_planner.py").read_text(encoding="utf-8"),
                       "phyrogen.planners", {PLANNER: "demo_planner:RrtConnect"})
    generator = _package(root, "phyrogen-demo-generator", "demo_generator",
                         (EXAMPLES / "two_sliders.py").read_text(encoding="utf-8"),
                         "phyrogen.generators", {GENERATOR: "demo_generator:build"})
    _install([planner, generator], root / "site")
    return root / "site"


def _one_error_line(result: subprocess.CompletedProcess) -> str:
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1 and result.stdout == "", (result.returncode, result.stderr)
    assert "Traceback" not in result.stderr
    return lines[0]


def test_installed_plugins_are_listed_beside_the_built_ins(site, tmp_path):
    listed = _phyrogen(site, "list", cwd=tmp_path)
    assert listed.returncode == 0, listed.stderr
    assert f"{GENERATOR}: Two Sliders (not in the paper)" in listed.stdout and "rooms: Rooms" in listed.stdout
    assert f"\n  {PLANNER}: RRT-Connect (version " in listed.stdout and "\n  la_rrt: LA-RRT (version " in listed.stdout
    offered = "".join(_phyrogen(site, "benchmark", "--help", cwd=tmp_path).stdout.split())
    assert f"{PLANNER}(RRT-Connect)" in offered and "la_rrt_push(LA-RRT+push(ours))" in offered


def test_without_the_plugins_folder_neither_exists(tmp_path):
    listed = _phyrogen(None, "list", cwd=tmp_path)
    assert listed.returncode == 0 and GENERATOR not in listed.stdout and f"  {PLANNER}:" not in listed.stdout
    refused = _phyrogen(None, "generate", "--generator", GENERATOR, "--seeds", "1", "--out", str(tmp_path / "o"),
                        cwd=tmp_path)
    assert f"unknown generator {GENERATOR!r}" in _one_error_line(refused)


@pytest.mark.slow
def test_the_plugins_generate_and_benchmark_through_the_command_line(site, tmp_path):
    out = tmp_path / "puzzles"
    generated = _phyrogen(site, "generate", "--generator", GENERATOR, "--seeds", "1-2", "--out", str(out), "--quiet",
                          cwd=tmp_path)
    assert generated.returncode == 0, generated.stderr
    folders = sorted(p.parent.name for p in out.rglob("puzzle.json"))
    assert folders == [f"{GENERATOR}_1", f"{GENERATOR}_2"]
    # A check budget, not seconds: the runs end the same way on a busy machine. Each run plans in a
    # fresh worker process, which finds the plug-in through the same entry points.
    bench = tmp_path / "bench"
    ran = _phyrogen(site, "benchmark", "--puzzles", str(out), "--planners", f"{PLANNER},la_rrt", "--runs", "1",
                    "--budget-checks", "20000", "--time-limit", "600", "--no-solutions", "--quiet",
                    "--out", str(bench), "--json", cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr
    entries = [json.loads(line) for line in (bench / "runs.jsonl").read_text().splitlines() if line.strip()]
    assert sorted(e["key"]["planner"] for e in entries) == sorted([PLANNER, "la_rrt"] * 2)
    mine = [e["record"] for e in entries if e["key"]["planner"] == PLANNER]
    # It planned (in the workers), spent the budget in the same units as the built-ins, and solved.
    assert all(r["error"] is None and r["end"] == "budget" and r["checks"] >= 20_000 for r in mine), mine
    assert all(r["action_cost"] is not None and r["action_cost"] >= 1 for r in mine), mine


def test_a_broken_entry_point_is_one_line_naming_it(tmp_path):
    broken = tmp_path / "broken"
    missing = _package(broken, "phyrogen-broken-planner", "broken_planner", "", "phyrogen.planners",
                       {"ghost": "broken_planner.nowhere:Ghost"})
    _install([missing], broken / "site-missing")
    for args in (["list"], ["benchmark", "--help"]):
        line = _one_error_line(_phyrogen(broken / "site-missing", *args, cwd=tmp_path))
        assert "phyrogen.planners" in line and "'ghost'" in line and "phyrogen-broken-planner" in line, line
        assert "cannot be loaded" in line and "broken_planner.nowhere" in line, line
    # An entry that loads but names a function that registers nothing.
    unregistered = _package(broken, "phyrogen-unregistered-generator", "plain", "def build(seed, params):\n    pass\n",
                            "phyrogen.generators", {"plain": "plain:build"})
    _install([unregistered], broken / "site-plain")
    line = _one_error_line(_phyrogen(broken / "site-plain", "list", cwd=tmp_path))
    assert "phyrogen.generators" in line and "registers no generator named 'plain'" in line, line

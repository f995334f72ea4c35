"""Hostile input, small holes in the contract: an empty generator list, docs that promised a
refusal the command did not make, progress printed before a refusal, a scene scale that broke
the physics, and a certificate ``check`` refuses that the robot executed anyway.

Each refusal is one line on stderr, exit 2, before any work (work started fails the test); each
has beside it the nearest accepted input, so that the refusal is the input's, not the command's.
"""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest
from hostile_support import cli_check, edit_json, hostile_puzzle

from phyrogen.cli import MIN_SCENE_SCALE, build_parser, main
from phyrogen_core.export import write_puzzle
from phyrogen_core.registry import ParameterError, get_generator, paper_generators

ROOT = Path(__file__).resolve().parents[1]


def cli(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def refused(argv: list[str], *fragments: str) -> str:
    code, out, err = cli(argv)
    assert (code, out) == (2, ""), (code, out, err)
    assert err.count("\n") == 1 and err.startswith("phyrogen: error: "), err
    for fragment in fragments:
        assert fragment in err, (fragment, err)
    return err


@pytest.fixture
def no_work(monkeypatch):
    import manipulation.batch
    import solver.pipelines.dataset.build
    import solver.pipelines.generation

    def started(*args, **kwargs):
        raise AssertionError("work started before the input was checked")

    monkeypatch.setattr(solver.pipelines.generation, "run_jobs", started)
    monkeypatch.setattr(solver.pipelines.dataset.build, "build_dataset", started)
    monkeypatch.setattr(manipulation.batch, "execute_puzzle", started)


@pytest.fixture
def puzzles(tmp_path) -> Path:
    write_puzzle(hostile_puzzle(), tmp_path / "puzzles")
    return tmp_path / "puzzles"


# -- an empty generator list ------------------------------------------------------------------
@pytest.mark.parametrize("names", ["", ",", " , "])
@pytest.mark.parametrize("command", ["generate", "dataset", "benchmark"])
def test_an_empty_generator_list_is_refused(names, command, tmp_path, no_work, puzzles):
    extra = {"generate": ["--seeds", "1", "--out", str(tmp_path / "out")],
             "dataset": ["--count", "1", "--out", str(tmp_path / "out")],
             "benchmark": ["--puzzles", str(puzzles), "--out", str(tmp_path / "out")]}[command]
    refused([command, "--generator", names, *extra, "--quiet"], "no generator named")
    assert not (tmp_path / "out").exists()


def test_a_named_generator_is_still_taken(tmp_path, monkeypatch):
    # The control: one name runs (its jobs are made, here counted, not run).
    import solver.pipelines.generation

    seen = []
    monkeypatch.setattr(solver.pipelines.generation, "run_jobs", lambda jobs, *a, **k: seen.extend(jobs) or [])
    code, _, err = cli(["generate", "--generator", " simple_slider, ", "--seeds", "1-2", "--out",
                        str(tmp_path / "out"), "--quiet"])
    assert code == 0, err
    assert [(job.generator, job.seed) for job in seen] == [("simple_slider", 1), ("simple_slider", 2)]


# -- docs/generators.md and the seed-sized maxima agree ----------------------------------------
def test_the_documented_refusal_of_all_generators_is_what_the_command_does(tmp_path, no_work):
    text = (ROOT / "docs" / "generators.md").read_text(encoding="utf-8")
    promised = re.findall(r"`--generator all --seeds 1-(\d+)` is refused", text)
    assert len(promised) == 1, promised
    last = int(promised[0])
    refused(["generate", "--generator", "all", "--seeds", f"1-{last}", "--out", str(tmp_path / "out")],
            f"seed {last}")
    # One seed fewer is accepted: every paper generator takes every seed below the documented one.
    for name in paper_generators():
        spec = get_generator(name)
        for seed in range(1, last):
            spec.check(seed, spec.default_params())
    with pytest.raises(ParameterError):
        get_generator("move_n_times").check(last, get_generator("move_n_times").default_params())


# -- an unreachable Ray cluster: one line, no progress before it -------------------------------
def test_dataset_with_an_unreachable_ray_prints_one_line_and_no_progress(tmp_path, no_work):
    refused(["dataset", "--generator", "simple_slider", "--count", "2", "--out", str(tmp_path / "out"),
             "--ray", "127.0.0.1:1"], "--ray")
    assert not (tmp_path / "out").exists()


def test_benchmark_with_an_unreachable_ray_prints_one_line_and_no_progress(tmp_path, puzzles):
    refused(["benchmark", "--puzzles", str(puzzles), "--out", str(tmp_path / "bench"), "--planners", "la_rrt",
             "--runs", "1", "--time-limit", "10", "--budget-checks", "10", "--ray", "127.0.0.1:1"], "--ray")
    assert not (tmp_path / "bench").exists()


def test_benchmark_dry_run_without_ray_still_prints_its_estimate(tmp_path, puzzles):
    # The control: the estimate line the refusal must not print comes out when nothing is refused.
    code, out, err = cli(["benchmark", "--puzzles", str(puzzles), "--out", str(tmp_path / "bench"), "--planners",
                          "la_rrt", "--runs", "1", "--time-limit", "10", "--budget-checks", "10", "--dry-run"])
    assert code == 0 and "puzzles x 1 planners" in err, (code, out, err)


# -- manipulate --scale -----------------------------------------------------------------------------
@pytest.mark.parametrize("scale", ["1e-300", "5e-324", "0.001", repr(MIN_SCENE_SCALE * 0.999)])
def test_a_scene_scale_below_the_stated_lower_bound_is_refused(scale, tmp_path, puzzles, no_work):
    refused(["manipulate", str(puzzles), "--out", str(tmp_path / "runs"), "--scale", scale], "--scale", scale)
    assert not (tmp_path / "runs").exists()


def test_the_lower_bound_itself_is_accepted():
    args = build_parser().parse_args(["manipulate", "p", "--scale", repr(MIN_SCENE_SCALE)])
    assert args.scale == MIN_SCENE_SCALE


# -- manipulate executes only a certificate that check accepts -------------------------------------
def straight_line(data) -> None:
    """The certificate as its start and end only."""
    data["certificate"] = [data["certificate"][0], data["certificate"][-1]]


def late_start(data) -> None:
    """The certificate without its first state: it begins where the first move ended."""
    data["certificate"] = data["certificate"][1:]


@pytest.fixture(scope="module")
def slider(tmp_path_factory) -> Path:
    """Simple Slider with two sliders (about 0.1 s): the blocker must leave before the target moves,
    so the straight line from the start to the end state drives one through the other."""
    from solver.pipelines.generation import generate_puzzle

    spec = get_generator("simple_slider")
    puzzle = generate_puzzle("simple_slider", 1, spec.parse_params({"n_objects": 2}))
    return write_puzzle(puzzle, tmp_path_factory.mktemp("slider"))


@pytest.mark.parametrize("change", [straight_line, late_start], ids=["straight line", "late start"])
def test_manipulate_refuses_a_certificate_that_check_refuses(change, slider, tmp_path, no_work):
    import shutil

    folder = tmp_path / "puzzles" / "simple_slider" / slider.name
    shutil.copytree(slider, folder)
    edit_json(folder, change)
    code, out, _ = cli_check(folder)
    assert code == 1 and "INVALID" in out, out  # what check says of it: the premise
    refused(["manipulate", str(folder), "--out", str(tmp_path / "runs"), "--quiet"],
            str(folder / "puzzle.json"), "certificate is not valid")
    assert not (tmp_path / "runs").exists()


def test_manipulate_takes_the_certificate_check_accepts(slider, tmp_path, monkeypatch):
    # The control: the unchanged puzzle passes the same test and reaches the simulation.
    import manipulation.batch

    reached = []

    def simulated(folder, *args, **kwargs):
        reached.append(Path(folder))
        raise RuntimeError("stop here: the simulation was reached")

    monkeypatch.setattr(manipulation.batch, "execute_puzzle", simulated)
    assert cli_check(slider)[0] == 0
    code, _, err = cli(["manipulate", str(slider), "--out", str(tmp_path / "runs"), "--quiet"])
    assert code == 1 and "stop here" in err and reached == [slider], (code, err)

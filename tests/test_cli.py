"""The command line: bad input gets one clear line and exit code 2, and no partial output."""

from __future__ import annotations

import json

import pytest

from phyrogen.cli import main


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["generate", "--generator", "no_such", "--out", "{out}"], "unknown generator 'no_such'"),
        (["generate", "--generator", "grid_world", "--seeds", "0", "--out", "{out}"], "positive"),
        (["generate", "--generator", "grid_world", "--seeds", "4-1", "--out", "{out}"], "bad seed list"),
        (["generate", "--generator", "grid_world", "--set", "colour=red", "--out", "{out}"], "no parameter 'colour'"),
        (["generate", "--generator", "grid_world", "--set", "n_objects=many", "--out", "{out}"], "must be int"),
        (["generate", "--generator", "grid_world", "--set", "n_objects", "--out", "{out}"], "expected key=value"),
        (["check", "{out}/missing"], "missing"),
    ],
)
def test_bad_input_is_one_line_and_exit_code_2(argv, message, tmp_path, capsys):
    out = tmp_path / "out"
    code = main([a.replace("{out}", str(out)) for a in argv])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and message in err
    assert not out.exists() or not any(out.rglob("puzzle.json"))


def test_infeasible_parameters_are_refused_before_any_work(tmp_path, capsys):
    code = main(["generate", "--generator", "simple_slider", "--set", "n_objects=500", "--out", str(tmp_path)])
    assert code == 2
    assert "n_objects" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


def test_list_names_every_generator(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name in ("simple_slider", "continuous_space", "grid_world", "lockbox_random", "move_n_times", "rooms"):
        assert name in out


def test_list_names_every_planner_with_its_version_and_a_new_one_once_registered(capsys):
    from solver.planning.anytime import PlanResult
    from solver.planning.registry import PLANNERS, Planner, planner, registry_copy

    def listed() -> list[str]:
        assert main(["list"]) == 0
        out = capsys.readouterr().out
        return out[out.index("\nplanners ("):].splitlines()

    lines = listed()
    for spec in PLANNERS.values():
        assert any(line.startswith(f"  {spec.name}: {spec.title} (version {spec.version}") for line in lines), spec.name
    assert "  la_rrt_fixed_order: LA-RRT, fixed factor order (version " in "\n".join(lines)
    assert next(line for line in lines if line.startswith("  la_rrt_fixed_order:")).endswith(
        "; group ablations, not in 'all')")
    with registry_copy():
        @planner
        class Probe(Planner):
            name, title, version, summary = "probe", "Probe", "7", "a planner that gives up at once"

            def plan(self, problem, *args, **kwargs) -> PlanResult:
                return PlanResult("Probe", False, (), None, None, 0.0, 0, (), "Timeout")

        with_probe = listed()
    assert with_probe[-2:] == [f"  probe: Probe (version {Probe.spec.version})",
                               "      a planner that gives up at once"]
    assert not any("probe" in line for line in listed())  # the control: gone with its registration


@pytest.mark.slow
def test_generate_then_check_and_detect_tampering(tmp_path, capsys):
    assert main(["generate", "--generator", "grid_world", "--seeds", "1", "--out", str(tmp_path), "--quiet"]) == 0
    folder = tmp_path / "grid_world" / "grid_world_1"
    assert main(["check", str(folder)]) == 0
    metadata = json.loads((folder / "puzzle.json").read_text())
    # Drop the middle of the certificate: the straight shortcut must run through a blocker.
    path = metadata["certificate"]
    metadata["certificate"] = [path[0], path[-1]]
    (folder / "puzzle.json").write_text(json.dumps(metadata))
    capsys.readouterr()
    assert main(["check", str(folder)]) == 1
    assert "INVALID" in capsys.readouterr().out


def test_a_folder_of_puzzles_stands_for_every_puzzle_in_it(tmp_path):
    from phyrogen_core.folder import find_in_paths

    def puzzle_folders(paths):
        return [getattr(f, "path", f) for f in find_in_paths(paths)]

    for name in ("rooms/rooms_2", "rooms/rooms_1", "simple_slider/simple_slider_1"):
        (tmp_path / "out" / name).mkdir(parents=True)
        (tmp_path / "out" / name / "puzzle.json").write_text("{}")
    (tmp_path / "out" / "manipulation" / "rooms_1").mkdir(parents=True)  # an output folder, no puzzle
    one = tmp_path / "out" / "rooms" / "rooms_2"
    assert puzzle_folders([str(tmp_path / "out")]) == [
        tmp_path / "out" / n for n in ("simple_slider/simple_slider_1", "rooms/rooms_1", "rooms/rooms_2")]
    assert puzzle_folders([str(one)]) == [one]
    assert puzzle_folders([str(tmp_path / "missing")]) == [tmp_path / "missing"]  # reported later

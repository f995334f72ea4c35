"""``phyrogen benchmark`` on hostile input and interrupted: bad input is refused before any run
with one line and exit code 2, leaving nothing behind; an interrupted benchmark resumes from the
runs it finished (``<out>/runs.jsonl``)."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import pytest
from hostile_support import hostile_puzzle

from phyrogen.cli import main
from phyrogen_core.atomic_writes import OutputError
from phyrogen_core.errors import PuzzleFormatError
from phyrogen_core.export import write_puzzle
from phyrogen_core.folder import find_puzzle_folders
from solver.benchmark.jobs import make_jobs
from solver.benchmark.journal import JOURNAL, Journal, read_journal
from solver.benchmark.profiles import get_profile
from solver.benchmark.runner import estimate_seconds, plan_benchmark, run_benchmark

REPO = Path(__file__).resolve().parents[1]
QUICK = ["--budget-checks", "5000", "--time-limit", "300", "--runs", "1", "--planners", "la_rrt", "--workers", "1",
         "--quiet"]
"""A benchmark here ends on its check budget, the time limit only a backstop against a hang, so that
what it finds does not depend on the machine's load: LA-RRT (base seed 0) solves each hostile puzzle
with its first checks (89 at most until first, over 3 runs of each), well within 5,000."""


@pytest.fixture(scope="module")
def generated(tmp_path_factory) -> Path:
    """Two small puzzles with every shape (prism meshes included), ``hostile_1`` and ``hostile_2``,
    written once; tests work on copies. Their generator is not a registered one: every
    benchmark here gives one time limit for all."""
    root = tmp_path_factory.mktemp("generated")
    for seed in (1, 2):
        write_puzzle(replace(hostile_puzzle(), seed=seed), root)
    return root


@pytest.fixture()
def puzzles(generated, tmp_path) -> Path:
    return Path(shutil.copytree(generated, tmp_path / "puzzles"))


def puzzle_dir(puzzles: Path, seed: int) -> Path:
    return puzzles / "hostile" / f"hostile_{seed}"


def benchmark(capsys, puzzles: Path, out: Path, *extra: str) -> tuple[int, str, str]:
    """``phyrogen benchmark`` in this process: exit code, stdout, stderr."""
    capsys.readouterr()
    try:
        code = main(["benchmark", "--puzzles", str(puzzles), "--out", str(out), *QUICK, *extra])
    except SystemExit as exc:  # a refusal by argparse itself
        code = exc.code
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def tree(root: Path) -> dict[str, bytes | None]:
    return {str(p.relative_to(root)): p.read_bytes() if p.is_file() else None for p in sorted(root.rglob("*"))}


def assert_refused(code: int, out: str, err: str, *fragments: str) -> None:
    assert code == 2, (code, out, err)
    assert out == ""
    assert len(err.splitlines()) == 1 and err.startswith("phyrogen: error: "), err
    for fragment in fragments:
        assert fragment in err, (fragment, err)


@contextlib.contextmanager
def unwritable(folder: Path):
    """``folder`` made unwritable for this process: mode 0555, or, for root (whom permission bits do
    not stop), the immutable attribute."""
    if os.geteuid() != 0:
        mode = folder.stat().st_mode
        folder.chmod(0o555)
        undo = lambda: folder.chmod(mode)  # noqa: E731
    else:
        if shutil.which("chattr") is None or subprocess.run(["chattr", "+i", str(folder)],
                                                            capture_output=True).returncode != 0:
            pytest.skip("running as root, and this file system has no immutable attribute (chattr +i)")
        undo = lambda: subprocess.run(["chattr", "-i", str(folder)], check=True)  # noqa: E731
    try:
        try:
            (folder / "probe").touch()
        except OSError:
            pass
        else:
            (folder / "probe").unlink()
            pytest.skip(f"{folder} stays writable for this process")
        yield folder
    finally:
        undo()


# -- bad input: one line, exit 2, before any run, nothing written -----------------------------------
def _json_array(folder: Path) -> None:
    (folder / "puzzle.json").write_text("[1, 2]")


def _json_folder(folder: Path) -> None:
    (folder / "puzzle.json").unlink()
    (folder / "puzzle.json").mkdir()


def _start_outside_limits(folder: Path) -> None:
    data = json.loads((folder / "puzzle.json").read_text())
    data["start"] = [5.0] * len(data["start"])
    (folder / "puzzle.json").write_text(json.dumps(data))


def _no_urdf(folder: Path) -> None:
    (folder / "urdf" / f"{folder.name}.urdf").unlink()


def _bad_xml(folder: Path) -> None:
    (folder / "urdf" / f"{folder.name}.urdf").write_text("<robot name='x'><link")


def _name_with_space(folder: Path) -> None:
    # A name the strict reader accepts, but OMPL's benchmark log splits on white space.
    data = json.loads((folder / "puzzle.json").read_text())
    data["name"] = "hostile 2"
    (folder / "puzzle.json").write_text(json.dumps(data))
    (folder / "urdf" / f"{folder.name}.urdf").rename(folder / "urdf" / "hostile 2.urdf")


@pytest.mark.parametrize(
    ("corrupt", "fragments"),
    [
        (_json_array, ["puzzle.json", "JSON object"]),
        (_json_folder, ["puzzle.json", "is a folder"]),
        (_start_outside_limits, ["puzzle.json", "start[0]", "outside the joint's limits"]),
        (_no_urdf, ["hostile_2.urdf", "missing"]),
        (_bad_xml, ["hostile_2.urdf", "malformed XML"]),
        (_name_with_space, ["puzzle.json", "white space"]),
    ],
    ids=lambda v: v.__name__.strip("_") if callable(v) else "",
)
def test_one_broken_puzzle_among_good_ones_stops_everything_before_any_run(corrupt, fragments, puzzles,
                                                                           tmp_path, capsys):
    corrupt(puzzle_dir(puzzles, 2))
    before = tree(puzzles)
    out = tmp_path / "bench"
    code, stdout, err = benchmark(capsys, puzzles, out)
    assert_refused(code, stdout, err, "hostile_2", *fragments)
    assert not out.exists()
    assert tree(puzzles) == before  # the good puzzle got no solution: nothing ran


def test_two_puzzles_with_one_name_are_refused(puzzles, tmp_path, capsys):
    shutil.copytree(puzzle_dir(puzzles, 1), puzzles / "copies" / "hostile_1")
    out = tmp_path / "bench"
    code, stdout, err = benchmark(capsys, puzzles, out)
    assert_refused(code, stdout, err, "both puzzle 'hostile_1'", str(puzzles / "copies"))
    assert not out.exists()


@pytest.mark.parametrize("where", ["missing", "empty", "file", "puzzle.json folder"])
def test_puzzles_that_are_not_there(where, tmp_path, capsys):
    given = tmp_path / "given"
    if where == "empty":
        given.mkdir()
    elif where == "file":
        given.write_text("not a folder")
    elif where == "puzzle.json folder":
        (given / "puzzle.json").mkdir(parents=True)
    out = tmp_path / "bench"
    code, stdout, err = benchmark(capsys, given, out)
    assert_refused(code, stdout, err, str(given))
    assert not out.exists()


@pytest.mark.parametrize("where", ["file", "under a file"])
def test_output_path_that_cannot_be_a_folder(where, puzzles, tmp_path, capsys):
    blocker = tmp_path / "a_file"
    blocker.write_text("mine")
    out = blocker if where == "file" else blocker / "bench"
    code, stdout, err = benchmark(capsys, puzzles, out)
    assert_refused(code, stdout, err, str(out), "file" if where == "file" else "not a folder")
    assert blocker.read_text() == "mine"
    assert not any(puzzle_dir(puzzles, 1).glob("solutions"))


def test_unwritable_output_folder_is_refused_before_any_run(puzzles, tmp_path, capsys):
    parent = tmp_path / "locked"
    parent.mkdir()
    with unwritable(parent):
        code, stdout, err = benchmark(capsys, puzzles, parent / "bench")
    assert_refused(code, stdout, err, str(parent))
    assert list(parent.iterdir()) == []
    assert not any(puzzle_dir(puzzles, 1).glob("solutions"))


def test_unwritable_puzzle_folder_is_refused_when_solutions_are_saved(puzzles, tmp_path, capsys):
    out = tmp_path / "bench"
    with unwritable(puzzle_dir(puzzles, 2)):
        code, stdout, err = benchmark(capsys, puzzles, out)
        assert_refused(code, stdout, err, str(puzzle_dir(puzzles, 2) / "solutions"), "--no-solutions")
        assert not out.exists()
        # A read-only collection of puzzles can still be benchmarked, without saving solutions.
        code, stdout, err = benchmark(capsys, puzzles, out, "--no-solutions")
    assert code == 0, err
    assert (out / "benchmark.db").is_file() and not (puzzle_dir(puzzles, 2) / "solutions").exists()


@pytest.mark.parametrize(("option", "value"), [("--workers", "0"), ("--workers", "-1"), ("--time-limit", "0"),
                                               ("--time-limit", "-1"), ("--time-limit", "nan"),
                                               ("--time-limit", "inf"), ("--runs", "0")])
def test_bad_numbers_are_refused(option, value, puzzles, tmp_path, capsys):
    out = tmp_path / "bench"
    code, stdout, err = benchmark(capsys, puzzles, out, option, value)
    assert code == 2, (code, err)
    assert "Traceback" not in err and option.lstrip("-") in err.replace(" ", "-"), err
    assert not out.exists()


def test_the_library_refuses_bad_workers_and_time_limits(generated, tmp_path):
    found = find_puzzle_folders(generated)
    profile = get_profile("quick", runs=1, time_limit=0.2)
    for workers in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match="workers"):
            plan_benchmark(found, ["la_rrt"], profile, tmp_path / "bench", workers)
        with pytest.raises(ValueError, match="workers"):
            estimate_seconds(found, ["la_rrt"], profile, workers, 1.0)
    for limit in (0, -2.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="time limit"):
            get_profile("quick", time_limit=limit)
    with pytest.raises(ValueError, match="named twice"):
        plan_benchmark(found, ["la_rrt", "la_rrt"], profile, tmp_path / "bench")
    assert not (tmp_path / "bench").exists()


def test_one_time_limit_covers_a_generator_the_profile_does_not_know(generated, tmp_path):
    found = find_puzzle_folders(generated)
    plan = plan_benchmark(found, ["la_rrt"], get_profile("quick", runs=1, time_limit=0.3), tmp_path / "bench")
    assert [job.time_limit for job in plan.jobs] == [0.3, 0.3]
    with pytest.raises(PuzzleFormatError, match="no time limit for generator 'hostile'"):
        plan_benchmark(found, ["la_rrt"], get_profile("quick", runs=1), tmp_path / "bench")


def test_dry_run_checks_everything_and_writes_nothing(puzzles, tmp_path, capsys):
    out = tmp_path / "bench"
    code, stdout, err = benchmark(capsys, puzzles, out, "--dry-run")
    assert code == 0 and "2 puzzles x 1 planners x 1 runs" in err
    assert not out.exists()
    _start_outside_limits(puzzle_dir(puzzles, 1))
    assert_refused(*benchmark(capsys, puzzles, out, "--dry-run"), "hostile_1")


# -- the output folder: the benchmark's entries only ----------------------------------------------
def test_a_finished_benchmark_replaces_only_its_own_entries(puzzles, tmp_path, capsys):
    out = tmp_path / "bench"
    (out / "mine").mkdir(parents=True)
    (out / "mine" / "notes.txt").write_text("keep me")
    # An earlier benchmark's folder (its journal: it stopped before a run finished), its runs crashed.
    (out / JOURNAL).touch()
    (out / "errors.txt").write_text("from an earlier benchmark whose runs crashed")
    (out / "logs" / "notes").mkdir(parents=True)
    (out / "logs" / "notes" / "reading.md").write_text("a user's notes beside the logs")
    # An earlier benchmark's log of a puzzle not run now (how write_log opens one), and a user's own .log.
    (out / "logs" / "hostile_9.log").write_text("OMPL version 2.0.1\nExperiment hostile_9\nRunning on a\n")
    (out / "logs" / "my_analysis.log").write_text("a user's analysis, named like a log")
    code, stdout, err = benchmark(capsys, puzzles, out)
    assert code == 0, err
    assert "| hostile_1 |" in stdout
    assert sorted(p.name for p in out.iterdir()) == ["benchmark.db", "fig4.png", "logs", "mine", "results.html",
                                                      JOURNAL, "summary.json", "summary.md"]
    assert (out / "mine" / "notes.txt").read_text() == "keep me"
    assert sorted(p.name for p in (out / "logs").iterdir()) == ["hostile_1.log", "hostile_2.log", "my_analysis.log",
                                                                 "notes"]
    assert (out / "logs" / "notes" / "reading.md").read_text() == "a user's notes beside the logs"
    assert (out / "logs" / "my_analysis.log").read_text() == "a user's analysis, named like a log"
    assert len((out / JOURNAL).read_text().splitlines()) == 2
    assert all((puzzle_dir(puzzles, s) / "solutions" / "la_rrt_best.json").is_file() for s in (1, 2))
    # Run again into the same --out: the user's files stay, and the benchmark's own logs are replaced.
    code, stdout, err = benchmark(capsys, puzzles, out)
    assert code == 0, err
    assert (out / "logs" / "my_analysis.log").read_text() == "a user's analysis, named like a log"
    assert sorted(p.name for p in (out / "logs").iterdir()) == ["hostile_1.log", "hostile_2.log", "my_analysis.log",
                                                                 "notes"]


def test_a_users_file_where_a_puzzles_log_goes_is_refused(puzzles, tmp_path, capsys):
    out = tmp_path / "bench"
    (out / "logs").mkdir(parents=True)
    (out / JOURNAL).touch()
    (out / "logs" / "hostile_1.log").write_text("my own notes on hostile_1")
    before = tree(out)
    assert_refused(*benchmark(capsys, puzzles, out), str(out / "logs" / "hostile_1.log"), "not a benchmark log")
    assert tree(out) == before


def _users_summary(out: Path, outside: Path) -> tuple[Path, str]:
    (out / "summary.md").write_text("my own summary of something else")
    return out / "summary.md", "was not written by phyrogen benchmark"


def _users_results_page(out: Path, outside: Path) -> tuple[Path, str]:
    (out / "results.html").write_text("<p>my page</p>")
    return out / "results.html", "was not written by phyrogen benchmark"


def _linked_summary(out: Path, outside: Path) -> tuple[Path, str]:
    (out / JOURNAL).touch()  # a benchmark's folder: still, the link is not the benchmark's to replace
    (out / "summary.md").symlink_to(outside / "mine.md")
    return out / "summary.md", "symbolic link"


def _linked_journal(out: Path, outside: Path) -> tuple[Path, str]:
    (out / JOURNAL).symlink_to(outside / "mine.md")  # appending would write outside the folder
    return out / JOURNAL, "symbolic link"


def _linked_logs(out: Path, outside: Path) -> tuple[Path, str]:
    (out / JOURNAL).touch()
    (out / "logs").symlink_to(outside, target_is_directory=True)
    return out / "logs", "symbolic link"


def _users_jsonl(out: Path, outside: Path) -> tuple[Path, str]:
    (out / JOURNAL).write_text('{"my": "data"}\n["more"]\n')  # appending runs would change a user's file
    return out / JOURNAL, "not a benchmark journal"


@pytest.mark.parametrize("damage", [_users_summary, _users_results_page, _linked_summary, _linked_journal,
                                    _linked_logs, _users_jsonl], ids=lambda f: f.__name__.strip("_"))
def test_a_users_file_or_link_at_an_output_name_is_refused_before_any_run(damage, puzzles, tmp_path, capsys):
    out, outside = tmp_path / "bench", tmp_path / "outside"
    out.mkdir()
    outside.mkdir()
    (outside / "mine.md").write_text("a user's file elsewhere")
    path, fragment = damage(out, outside)
    before, elsewhere = tree(out), tree(outside)
    assert_refused(*benchmark(capsys, puzzles, out), str(path), fragment)
    assert (tree(out), tree(outside)) == (before, elsewhere)
    assert not any(puzzle_dir(puzzles, 1).glob("solutions"))


def test_a_linked_output_folder_is_refused_before_any_run(puzzles, tmp_path, capsys):
    """``--out`` itself a symbolic link (to a folder, or dangling) is refused up front, naming it;
    nothing is written on either side of the link."""
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "mine.md").write_text("a user's file elsewhere")
    linked, dangling = tmp_path / "bench", tmp_path / "dangling"
    linked.symlink_to(outside, target_is_directory=True)
    dangling.symlink_to(tmp_path / "nowhere", target_is_directory=True)
    for out in (linked, dangling):
        before = tree(outside)
        assert_refused(*benchmark(capsys, puzzles, out), str(out), "symbolic link")
        assert tree(outside) == before and not (tmp_path / "nowhere").exists()
    assert not any(puzzle_dir(puzzles, 1).glob("solutions"))
    # Negative control: the folder the link points to is accepted when named itself.
    code, _, err = benchmark(capsys, puzzles, outside)
    assert code == 0, err
    assert (outside / "summary.md").is_file() and (outside / "mine.md").read_text() == "a user's file elsewhere"


def test_a_benchmark_folder_without_its_journal_is_still_the_benchmarks(puzzles, tmp_path, capsys):
    """Negative control: deleting the journal (to run everything again) leaves a folder whose
    ``benchmark.db`` says whose the other entries are; they are replaced."""
    out = tmp_path / "bench"
    assert benchmark(capsys, puzzles, out)[0] == 0
    (out / JOURNAL).unlink()
    (out / "summary.md").write_text("the earlier benchmark's summary")
    code, stdout, err = benchmark(capsys, puzzles, out)
    assert code == 0, err
    assert (out / "summary.md").read_text() != "the earlier benchmark's summary"
    (out / JOURNAL).unlink()
    (out / "benchmark.db").write_bytes(b"SQLite format 3\x00 but no benchmark")
    assert_refused(*benchmark(capsys, puzzles, out), f"{out} holds no {JOURNAL} and no benchmark database")


def test_a_journal_that_is_not_a_file_is_refused_before_any_run(puzzles, tmp_path, capsys):
    out = tmp_path / "bench"
    (out / JOURNAL).mkdir(parents=True)
    assert_refused(*benchmark(capsys, puzzles, out), str(out / JOURNAL), "not a regular file")
    assert [p.name for p in out.iterdir()] == [JOURNAL] and not any(puzzle_dir(puzzles, 1).glob("solutions"))


def test_a_second_benchmark_into_a_folder_in_use_is_refused(generated, tmp_path):
    out = tmp_path / "bench"
    out.mkdir()
    found = find_puzzle_folders(generated)
    with Journal(out / JOURNAL), pytest.raises(OutputError, match="in use by another benchmark"):
        run_benchmark(found, ["la_rrt"], get_profile("quick", runs=1, time_limit=0.2), out, workers=1,
                      save_solutions=False, progress=False)
    assert sorted(p.name for p in out.iterdir()) == [JOURNAL]


# -- resuming -----------------------------------------------------------------------------------------
PLANNERS = ["la_rrt", "rrt_star"]


def _bench(found, out, on_done=None):
    return run_benchmark(found, PLANNERS, get_profile("quick", runs=2, time_limit=0.2), out, workers=2,
                         save_solutions=False, plots=False, progress=False, on_done=on_done)


def _identity(records) -> set[tuple[str, str, int, int]]:
    return {(r.planner, r.puzzle, r.run, r.seed) for r in records}


class _Interrupt:
    """An ``on_done`` that counts the runs executed and, after ``after`` of them, acts like Ctrl-C."""

    def __init__(self, after: int | None = None):
        self.after, self.count = after, 0

    def __call__(self, record) -> None:
        self.count += 1
        if self.count == self.after:
            raise KeyboardInterrupt


def test_an_interrupted_benchmark_resumes_from_the_runs_it_finished(generated, tmp_path):
    found = find_puzzle_folders(generated)
    out = tmp_path / "bench"
    interrupt = _Interrupt(after=3)
    with pytest.raises(KeyboardInterrupt):
        _bench(found, out, interrupt)
    assert sorted(p.name for p in out.iterdir()) == [JOURNAL]  # no outputs, no leftover staging folder
    kept = read_journal(out / JOURNAL)
    assert len(kept) == 3

    resumed = _Interrupt()
    result = _bench(found, out, resumed)
    total = 2 * 2 * 2  # puzzles x planners x runs
    assert (resumed.count, result.reused) == (total - 3, 3)
    assert set(kept.values()) <= set(result.records)  # reused as recorded, not run again
    complete = _bench(found, tmp_path / "uninterrupted")
    assert _identity(result.records) == _identity(complete.records)
    assert len(result.records) == total == len(_identity(result.records))
    jobs = make_jobs(found, PLANNERS, get_profile("quick", runs=2, time_limit=0.2))
    assert {(j.puzzle.name, j.run, j.seed) for j in jobs} == {(p, r, s) for _, p, r, s in _identity(result.records)}
    with sqlite_runs(result.database) as count:
        assert count == total


@contextlib.contextmanager
def sqlite_runs(database: Path):
    import sqlite3

    with contextlib.closing(sqlite3.connect(database)) as db:
        yield db.execute("SELECT COUNT(*) FROM runs").fetchone()[0]


def _edit_metadata(folder: Path) -> None:
    data = json.loads((folder / "puzzle.json").read_text())
    # Saved by hand in another layout: the strict reader has no room for a new key, but other bytes are
    # another file all the same.
    (folder / "puzzle.json").write_text(json.dumps(data, indent=4))


def _edit_urdf(folder: Path) -> None:
    urdf = folder / "urdf" / f"{folder.name}.urdf"
    urdf.write_text(urdf.read_text() + "<!-- regenerated -->\n")


@pytest.mark.parametrize("edit", [_edit_metadata, _edit_urdf], ids=["puzzle.json", "urdf"])
def test_a_changed_puzzle_runs_again_and_the_others_are_reused(edit, puzzles, tmp_path):
    out = tmp_path / "bench"
    _bench(find_puzzle_folders(puzzles), out)
    edit(puzzle_dir(puzzles, 2))
    counter = _Interrupt()
    result = _bench(find_puzzle_folders(puzzles), out, counter)
    assert (counter.count, result.reused) == (4, 4)  # the edited puzzle's 2 planners x 2 runs
    assert len(result.records) == 8


def test_a_torn_last_line_and_a_garbled_line_are_ignored(generated, tmp_path):
    found = find_puzzle_folders(generated)[:1]
    out = tmp_path / "bench"
    _bench(found, out)
    journal = out / JOURNAL
    lines = journal.read_bytes().splitlines(keepends=True)
    assert len(lines) == 4
    # The second line garbled by hand, the last one cut mid-write (killed with SIGKILL).
    journal.write_bytes(lines[0] + b'{"key": {"planner": 3}, "record": []}\n' + lines[2] + lines[3][:-40])
    counter = _Interrupt()
    result = _bench(found, out, counter)
    assert (counter.count, result.reused) == (2, 2)  # the garbled run and the torn one
    assert len(read_journal(journal)) == 4
    # The torn tail was cut before appending: every line of the journal parses.
    for line in journal.read_bytes().splitlines()[2:]:
        json.loads(line)


def test_a_crashed_run_is_run_again(generated, tmp_path):
    found = find_puzzle_folders(generated)[:1]
    out = tmp_path / "bench"
    _bench(found, out)
    journal = out / JOURNAL
    lines = journal.read_text().splitlines()
    crashed = json.loads(lines[0])
    crashed["record"].update(status="Crash", solved=False, error="MemoryError: out of memory")
    journal.write_text(json.dumps(crashed) + "\n" + "\n".join(lines[1:]) + "\n")
    counter = _Interrupt()
    result = _bench(found, out, counter)
    assert (counter.count, result.reused) == (1, 3)
    assert not any(r.error for r in result.records)


# -- a real Ctrl-C and SIGTERM -------------------------------------------------------------------
def _start(puzzles: Path, out: Path) -> subprocess.Popen:
    argv = [sys.executable, "-m", "phyrogen.cli", "benchmark", "--puzzles", str(puzzles), "--out", str(out),
            "--time-limit", "0.2", "--runs", "3", "--planners", "la_rrt,rrt_star", "--workers", "2"]
    # A session of its own: the signal goes to the whole process group, workers included, as Ctrl-C does.
    return subprocess.Popen(argv, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def _journal_lines(path: Path) -> int:
    return path.read_bytes().count(b"\n") if path.exists() else 0


@pytest.mark.slow
@pytest.mark.parametrize(("signal_number", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)],
                         ids=["SIGINT", "SIGTERM"])
def test_a_signalled_benchmark_exits_cleanly_and_resumes(signal_number, code, puzzles, tmp_path):
    out = tmp_path / "bench"
    process = _start(puzzles, out)
    deadline = time.monotonic() + 60
    while _journal_lines(out / JOURNAL) < 3:
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.02)
    os.killpg(process.pid, signal_number)
    stdout, stderr = process.communicate(timeout=60)
    assert process.returncode == code, stderr
    assert "Traceback" not in stderr
    assert stderr.rstrip("\n").splitlines()[-1] == "phyrogen: interrupted", stderr
    kept = len(read_journal(out / JOURNAL))
    assert kept >= 3 and sorted(p.name for p in out.iterdir()) == [JOURNAL]

    again = _start(puzzles, out)
    stdout, stderr = again.communicate(timeout=120)
    assert again.returncode == 0, stderr
    assert f"resuming: {kept} of 12 runs already done" in stderr  # 2 puzzles x 2 planners x 3 runs
    assert _journal_lines(out / JOURNAL) == 12  # only the remaining runs ran
    assert len(read_journal(out / JOURNAL)) == 12 and (out / "fig4.png").is_file()

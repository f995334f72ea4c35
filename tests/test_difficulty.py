"""Difficulty in machine-independent units (solver/benchmark/difficulty.py) and its place in puzzle.json.

BIT*'s runs within a budget of collision checks, seeded from the puzzle's name
and the run index: the same numbers on every call and in a fresh process; an
easy puzzle rates easier than a larger one (and the comparison is shown to
fail when the two are swapped); the record round-trips, and a record without
difficulty keeps its exact bytes. Every run is bounded by its check budget.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import pytest

from phyrogen_core.difficulty import Difficulty
from phyrogen_core.errors import PuzzleFormatError
from phyrogen_core.export import write_puzzle
from phyrogen_core.export.metadata import puzzle_record
from phyrogen_core.record import PuzzleRecord
from solver.benchmark.difficulty import DifficultySettings, measure_difficulty
from solver.benchmark.statistics import wilson_interval
from solver.pipelines.generation import generate_here

ROOT = Path(__file__).resolve().parent.parent
# Fresh seeds: no other test uses them.
EASY = ("simple_slider", 611_904_277, {"n_objects": 1})
LARGER = ("simple_slider", 611_904_278, {"n_objects": 5})
SETTINGS = DifficultySettings(runs=4, budget_checks=20_000)


def _puzzle(generator: str, seed: int, sizes: dict):
    from phyrogen_core.registry import get_generator

    return generate_here(generator, seed, get_generator(generator).parse_params(sizes))


@pytest.fixture(scope="module")
def easy():
    return _puzzle(*EASY)


@pytest.fixture(scope="module")
def larger():
    return _puzzle(*LARGER)


@pytest.fixture(scope="module")
def easy_difficulty(easy):
    return measure_difficulty(easy.chain, easy.goal, easy.name, SETTINGS)


# -- the Wilson interval ---------------------------------------------------------------
@pytest.mark.parametrize(("successes", "runs", "low", "high"), [
    (0, 10, 0.0, 0.27753), (10, 10, 0.72247, 1.0), (5, 10, 0.23659, 0.76341), (1, 3, 0.06149, 0.79234),
])
def test_wilson_interval_matches_published_values(successes, runs, low, high):
    interval = wilson_interval(successes, runs)
    got = (interval.low, interval.high)
    assert got == pytest.approx((low, high), abs=1e-5)
    # Negative control: the normal approximation, which the Wilson interval replaces, collapses at 0/n.
    rate = successes / runs
    if successes in (0, runs):
        assert (rate, rate) != pytest.approx((low, high), abs=1e-5)


# -- determinism -------------------------------------------------------------------------
def test_the_same_puzzle_runs_and_budget_give_the_same_difficulty(easy, easy_difficulty):
    again = measure_difficulty(easy.chain, easy.goal, easy.name, SETTINGS)
    assert again == easy_difficulty
    assert easy_difficulty.runs == SETTINGS.runs and easy_difficulty.budget_checks == SETTINGS.budget_checks


def test_a_fresh_process_measures_the_same_difficulty(easy_difficulty):
    generator, seed, sizes = EASY
    code = (
        "import json, dataclasses\n"
        "from phyrogen_core.registry import get_generator\n"
        "from solver.pipelines.generation import generate_here\n"
        "from solver.benchmark.difficulty import DifficultySettings, measure_difficulty\n"
        f"p = generate_here({generator!r}, {seed}, get_generator({generator!r}).parse_params({sizes!r}))\n"
        f"d = measure_difficulty(p.chain, p.goal, p.name, DifficultySettings({SETTINGS.runs}, "
        f"{SETTINGS.budget_checks}))\n"
        "print(json.dumps(dataclasses.asdict(d)))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=600,
                         check=True).stdout
    assert Difficulty(**json.loads(out.strip().splitlines()[-1])) == easy_difficulty


def test_another_budget_gives_another_measurement(easy, easy_difficulty):
    # Negative control for the determinism test: the numbers do depend on what was asked.
    other = measure_difficulty(easy.chain, easy.goal, easy.name, DifficultySettings(runs=3, budget_checks=20_000))
    assert other != easy_difficulty


# -- easy versus larger ------------------------------------------------------------------
def _easier(a: Difficulty, b: Difficulty) -> bool:
    """``a`` rates easier than ``b``: a higher success rate, or the same and fewer checks to a first solution."""
    if a.success_rate != b.success_rate:
        return a.success_rate > b.success_rate
    return a.median_checks_to_first is not None and b.median_checks_to_first is not None \
        and a.median_checks_to_first < b.median_checks_to_first


def test_the_smallest_simple_slider_rates_easier_than_a_larger_one(larger, easy_difficulty):
    hard = measure_difficulty(larger.chain, larger.goal, larger.name, SETTINGS)
    assert easy_difficulty.success_rate == 1.0
    assert _easier(easy_difficulty, hard), (easy_difficulty, hard)
    assert not _easier(hard, easy_difficulty)  # the comparison can fail: swapped, it does


# -- the record --------------------------------------------------------------------------
def test_the_difficulty_round_trips_through_puzzle_json(easy, easy_difficulty):
    record = puzzle_record(dataclasses.replace(easy, difficulty=easy_difficulty))
    text = record.to_json()
    assert json.loads(text)["format_version"] == 3
    back = PuzzleRecord.from_json(text)
    assert back == record and back.difficulty == easy_difficulty and back.to_json() == text


def test_a_record_without_difficulty_keeps_its_bytes(easy, easy_difficulty):
    plain = puzzle_record(easy).to_json()
    measured = puzzle_record(dataclasses.replace(easy, difficulty=easy_difficulty)).to_json()
    assert "difficulty" not in plain and json.loads(plain)["format_version"] == 1
    data = json.loads(measured)
    del data["difficulty"]
    data["format_version"] = 1
    assert json.dumps(data, sort_keys=True, indent=2) + "\n" == plain
    assert PuzzleRecord.from_json(measured).same_puzzle(PuzzleRecord.from_json(plain))


def test_regenerating_with_difficulty_keeps_renders(tmp_path, easy, easy_difficulty):
    folder = write_puzzle(easy, tmp_path)
    (folder / "images").mkdir()
    (folder / "images" / "still.png").write_bytes(b"a render")
    notices: list[str] = []
    write_puzzle(dataclasses.replace(easy, difficulty=easy_difficulty), tmp_path, notices=notices)
    assert (folder / "images" / "still.png").read_bytes() == b"a render" and notices == []


def _refusal(data: dict) -> str:
    with pytest.raises(PuzzleFormatError) as caught:
        PuzzleRecord.from_dict(data, "p/puzzle.json")
    return str(caught.value)


@pytest.mark.parametrize(("edit", "words"), [
    (lambda d: d["difficulty"].update(success_rate=0.5), "success_rate"),
    (lambda d: d["difficulty"].update(success_interval=[0.0]), "success_interval"),
    (lambda d: d["difficulty"].update(success_interval=[1.5, 2.0]), "interval"),
    (lambda d: d["difficulty"].update(runs=0), "runs"),
    (lambda d: d["difficulty"].pop("median_checks_to_first"), "median_checks_to_first"),
    (lambda d: d["difficulty"].update(median_checks_to_first=None), "median_checks_to_first"),
    (lambda d: d["difficulty"].update(seconds=3.0), "difficulty.seconds"),
    (lambda d: d.update(format_version=2), "format_version 3"),
])
def test_bad_difficulty_values_are_refused_naming_the_key(easy, easy_difficulty, edit, words):
    data = puzzle_record(dataclasses.replace(easy, difficulty=easy_difficulty)).to_dict()
    PuzzleRecord.from_dict(data)  # control: the unedited data is accepted
    edit(data)
    message = _refusal(data)
    assert message.startswith("p/puzzle.json: ") and words in message


# -- the command line --------------------------------------------------------------------
CLI_SEED = 611_904_279  # fresh


def _phyrogen(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "phyrogen", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=600)


def test_generate_writes_difficulty_only_when_asked(tmp_path):
    common = ["generate", "--generator", "simple_slider", "--set", "n_objects=1", "--seeds", str(CLI_SEED),
              "--workers", "1", "--quiet"]
    plain = _phyrogen(*common, "--out", str(tmp_path / "plain"))
    measured = _phyrogen(*common, "--difficulty", "--difficulty-runs", "2", "--difficulty-checks", "5000",
                         "--out", str(tmp_path / "measured"))
    assert plain.returncode == 0 == measured.returncode, plain.stderr + measured.stderr
    name = f"simple_slider_{CLI_SEED}"
    folders = {kind: tmp_path / kind / "simple_slider" / name for kind in ("plain", "measured")}
    plain_record = PuzzleRecord.from_json((folders["plain"] / "puzzle.json").read_bytes())
    measured_record = PuzzleRecord.from_json((folders["measured"] / "puzzle.json").read_bytes())
    assert plain_record.difficulty is None and plain_record.format_version == 1
    assert measured_record.difficulty is not None and measured_record.difficulty.runs == 2
    assert measured_record.difficulty.budget_checks == 5000
    assert plain_record.same_puzzle(measured_record)
    # Every other file of the folder is the same, byte for byte.
    files = {kind: {p.relative_to(f): p.read_bytes() for p in f.rglob("*") if p.is_file()}
             for kind, f in folders.items()}
    assert files["plain"].keys() == files["measured"].keys()
    assert [p for p in files["plain"] if files["plain"][p] != files["measured"][p]] == [Path("puzzle.json")]


@pytest.mark.parametrize(("args", "words"), [
    (["--difficulty-runs", "2"], "--difficulty"),
    (["--difficulty", "--difficulty-runs", "0"], "--difficulty-runs"),
    (["--difficulty", "--difficulty-checks", "nan"], "--difficulty-checks"),
    (["--suite", "hard", "--generator", "rooms"], "--suite"),
    (["--suite", "easy"], "unknown suite 'easy'"),
])
def test_bad_difficulty_and_suite_options_are_refused_before_any_work(tmp_path, args, words):
    done = _phyrogen("generate", "--seeds", "1", "--out", str(tmp_path / "out"), *args)
    assert done.returncode == 2 and words in done.stderr and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert not (tmp_path / "out").exists()


def test_dataset_difficulty_columns_are_null_unless_asked(tmp_path):
    pytest.importorskip("pyarrow")
    from solver.pipelines.dataset import manifest_rows

    common = ["dataset", "--generator", "simple_slider", "--set", "n_objects=1", "--seeds",
              f"{CLI_SEED}-{CLI_SEED + 1}", "--workers", "1", "--quiet"]
    plain = _phyrogen(*common, "--out", str(tmp_path / "plain"))
    measured = _phyrogen(*common, "--difficulty", "--difficulty-runs", "2", "--difficulty-checks", "5000",
                         "--out", str(tmp_path / "measured"))
    assert plain.returncode == 0 == measured.returncode, plain.stderr + measured.stderr
    columns = ["difficulty_runs", "difficulty_budget_checks", "difficulty_success_rate", "difficulty_success_low",
               "difficulty_success_high", "difficulty_median_checks"]
    rows = {kind: manifest_rows(tmp_path / kind)[0] for kind in ("plain", "measured")}
    assert all(getattr(row, column) is None for row in rows["plain"] for column in columns)
    assert all(row.difficulty_runs == 2 and row.difficulty_budget_checks == 5000
               and row.difficulty_success_low <= row.difficulty_success_rate <= row.difficulty_success_high
               for row in rows["measured"])
    assert "difficulty" not in json.loads((tmp_path / "plain" / "dataset.json").read_text())
    # Resuming a dataset with another difficulty request is refused: its rows would mix two measurements.
    again = _phyrogen(*common, "--out", str(tmp_path / "measured"))
    assert again.returncode == 2 and "difficulty" in again.stderr, again.stderr


def test_difficulty_runs_are_the_benchmarks_runs(tmp_path, larger):
    # The docstring's claim: run r of the measurement is run r of `phyrogen benchmark --planners bit_star
    # --until first --budget-checks N`, on the generated chain as on the one read back from the folder.
    from phyrogen_core.export import read_puzzle_dir
    from solver.benchmark.journal import read_journal

    # (Not the smallest slider: every seed solves it in 2 checks, which tests no seeding.)
    folder = write_puzzle(larger, tmp_path / "puzzles")
    loaded = read_puzzle_dir(folder)
    settings = DifficultySettings(runs=2, budget_checks=20_000)
    from solver.benchmark.difficulty import difficulty_run

    mine = [difficulty_run(larger.chain, larger.goal, larger.name, run, settings) for run in range(2)]
    read_back = [difficulty_run(loaded.chain, loaded.goal, larger.name, run, settings) for run in range(2)]
    assert [(r.solved, r.checks) for r in mine] == [(r.solved, r.checks) for r in read_back]
    assert mine[0].checks != mine[1].checks  # control: another run's seeds give another count
    done = _phyrogen("benchmark", "--puzzles", str(tmp_path / "puzzles"), "--planners", "bit_star", "--runs", "2",
                     "--budget-checks", "20000", "--until", "first", "--time-limit", "600", "--workers", "1",
                     "--quiet", "--no-solutions", "--out", str(tmp_path / "bench"))
    assert done.returncode == 0, done.stderr
    runs = sorted(read_journal(tmp_path / "bench" / "runs.jsonl").values(), key=lambda r: r.run)
    assert [(r.solved, r.checks) for r in runs] == [(r.solved, r.checks) for r in mine]

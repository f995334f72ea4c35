"""The workers' server prepared for a dataset's own generator (solver.pipelines._server_warmup): the run's
first puzzle, generated once in the server and thrown away, loads that generator's compiled kernels'
signatures instead of every signature numba's cache holds; it changes no byte of the dataset, and a server
that dies preparing is started again, cold, instead of failing the run.

Seeds 9987001-9987010 are this file's; no other test uses them.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from phyrogen_core.maker import GenerationError
from phyrogen_core.registry import get_generator
from solver.parallel import pool
from solver.pipelines import generation
from solver.pipelines.dataset.build import RECORD_ONLY_ENTRIES, REFERENCE_OBJECTS, EntryTask, _server_hint

ROOT = Path(__file__).resolve().parents[1]
SLIDER = get_generator("simple_slider").parse_params({"n_objects": "4"})


def _task(generator: str, overrides: dict[str, str], seed: int = 9987001) -> EntryTask:
    return EntryTask(0, generator, seed, get_generator(generator).parse_params(overrides), "unused")


def test_the_hint_is_in_the_environment_only_while_the_server_starts(monkeypatch):
    monkeypatch.setenv(pool.SERVER_HINT, "the caller's own")
    with pool._server_environment("hint"):
        assert os.environ[pool.SERVER_HINT] == "hint"
    assert os.environ[pool.SERVER_HINT] == "the caller's own"  # restored
    with pool._server_environment(None):
        assert pool.SERVER_HINT not in os.environ  # no hint: none, not the caller's
    monkeypatch.delenv(pool.SERVER_HINT)
    with pool._server_environment("hint"):
        pass
    assert pool.SERVER_HINT not in os.environ


def test_only_a_puzzle_cheaper_than_the_whole_warm_up_is_generated_for_a_hint():
    hint = generation.read_hint(_server_hint([_task("simple_slider", {"n_objects": "4"})]))
    assert hint.generator == "simple_slider" and hint.generate
    # The control: Move N Times with n = 8 (nine objects, several CPU s a puzzle) is not generated: the server
    # loads its record, or else warms every kernel up.
    task = _task("move_n_times", {"n": "8"})
    assert get_generator("move_n_times").build(task.seed, task.params).n_objects > REFERENCE_OBJECTS
    hint = generation.read_hint(_server_hint([task]))
    assert hint.generator == "move_n_times" and not hint.generate


def test_only_a_large_requests_server_generates_its_puzzle_beside_a_record():
    small = EntryTask(0, "simple_slider", 9987001, SLIDER, "unused", entries=RECORD_ONLY_ENTRIES)
    assert not generation.read_hint(_server_hint([small])).always
    large = replace(small, entries=RECORD_ONLY_ENTRIES + 1)  # the control
    assert generation.read_hint(_server_hint([large])).always


def test_a_hint_names_the_requests_other_generators():
    task = EntryTask(0, "simple_slider", 9987001, SLIDER, "unused", generators=("simple_slider", "rooms"))
    assert generation.read_hint(_server_hint([task])).also == ("simple_slider", "rooms")


def test_a_hint_names_the_puzzle_it_generates_and_a_failed_seed_is_no_error(monkeypatch):
    made = []

    def fake(generator, seed, params):
        made.append((generator, seed, params))
        if seed == 2:
            raise GenerationError("no puzzle for this seed")
        if seed == 3:
            raise RuntimeError("a bug")

    monkeypatch.setattr(generation, "generate_here", fake)
    generation.generate_for_hint(generation.warm_hint("simple_slider", 1, SLIDER))
    assert made == [("simple_slider", 1, SLIDER)]
    generation.generate_for_hint(generation.warm_hint("simple_slider", 2, SLIDER))  # generation's own verdict
    with pytest.raises(RuntimeError):  # the control: anything else is raised (the server then warms everything)
        generation.generate_for_hint(generation.warm_hint("simple_slider", 3, SLIDER))


PROBE = '''
import sys
sys.path.insert(0, sys.argv[1])
from solver.parallel import pool
from solver.parallel.pool import fresh_process_pool
from solver.pipelines.dataset.build import PRELOAD
from solver.pipelines.generation import warm_hint
from phyrogen_core.registry import get_generator
import probe_helper  # (also the servers' first preload: it keeps their record in the test's folder)

hint = {"generator": lambda item: warm_hint("simple_slider", 9987001, get_generator("simple_slider").parse_params(
            {"n_objects": "4"})),
        "move_n_times": lambda item: warm_hint("move_n_times", 9987002, get_generator("move_n_times").parse_params(
            {"n": "3"})),
        "two": lambda item: warm_hint("simple_slider", 9987001, get_generator("simple_slider").parse_params(
            {"n_objects": "4"}), also=("simple_slider", "move_n_times")),
        "none": None, "garbage": lambda item: "not a hint", "crash": probe_helper.crashing_hint,
        "crash-no-retry": probe_helper.crashing_hint}[sys.argv[2]]
if sys.argv[2] == "crash-no-retry":
    pool._SERVER_EXIT_POLLS = 0  # the server's death is never seen: the start fails as it did before the retry
with fresh_process_pool(1, 1, ["probe_helper", *PRELOAD], server_hint=hint) as workers:
    print(*next(workers.imap(probe_helper.probe, [0])))
'''
HELPER = '''
import gc
import os
import sys
from pathlib import Path

COLLECTING_DURING_PRELOAD = gc.isenabled()  # (imported by the server, first of its preload)

from solver.pipelines import _warm_record

_warm_record.RECORD_FILE = Path(os.environ["PROBE_RECORD"])
_warm_record.record_key = lambda: "this test's code"  # (the checkout's files may change between its servers)
if os.environ.get("PROBE_NO_PUZZLE"):  # a puzzle generated in the server fails its warm-up
    from solver.pipelines import generation

    def _no_puzzle(*args, **kwargs):
        raise RuntimeError("this server was to generate no puzzle")

    generation.generate_here = _no_puzzle


def probe(_):
    warm = sys.modules["solver.pipelines._server_warmup"]
    return (warm.HINTED, sum(len(kernel.overloads) for kernel in warm._kernels_called_from_python()), warm.RECORDED,
            COLLECTING_DURING_PRELOAD, gc.isenabled())


class _Segfault:
    def __reduce__(self):
        import ctypes

        return ctypes.string_at, (8, 1)  # reads address 8 as the hint is read: the server dies of SIGSEGV


def crashing_hint(item):
    import base64
    import pickle

    return base64.b64encode(pickle.dumps(_Segfault())).decode("ascii")
'''


def _run_probe(tmp_path: Path, hint: str, *, no_puzzle: bool = False) -> subprocess.CompletedProcess:
    (tmp_path / "probe_helper.py").write_text(HELPER)
    # (The test's folder on PYTHONPATH: a fork server of Python 3.11 imports its preload on the default path.)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join((str(ROOT), str(tmp_path))),
           "PROBE_RECORD": str(tmp_path / "record.json")}
    if no_puzzle:
        env["PROBE_NO_PUZZLE"] = "1"
    return subprocess.run([sys.executable, "-c", PROBE, str(tmp_path), hint], cwd=ROOT, capture_output=True,
                          text=True, env=env)


def _probe(tmp_path: Path, hint: str, *, no_puzzle: bool = False, recorded: bool = False) -> tuple[bool, int]:
    """(whether the server prepared for its hint, the signatures it loaded); ``recorded``: whether it did so
    from a record, without a puzzle (asserted)."""
    done = _run_probe(tmp_path, hint, no_puzzle=no_puzzle)
    assert done.returncode == 0, done.stderr[-2000:]
    hinted, loaded, from_record, _, _ = done.stdout.split()
    assert (from_record == "True") == recorded
    return hinted == "True", int(loaded)


def test_a_hinted_server_loads_its_generators_signatures_and_no_others(tmp_path):
    hinted, loaded = _probe(tmp_path, "generator")
    unhinted, everything = _probe(tmp_path, "none")
    assert hinted and not unhinted
    assert 0 < loaded < everything  # (Simple Slider of four objects: 10 of 31 at the time of writing)
    garbled, fallback = _probe(tmp_path, "garbage")  # the control: a hint that fails warms everything up
    assert not garbled and fallback > loaded


def test_a_later_server_loads_the_record_of_the_first_instead_of_generating_a_puzzle(tmp_path):
    hinted, loaded = _probe(tmp_path, "generator")  # generates the puzzle, records what it loaded
    assert hinted and loaded > 0 and (tmp_path / "record.json").is_file()
    # A server that would fail any puzzle it generated prepares the same from the record.
    assert _probe(tmp_path, "generator", no_puzzle=True, recorded=True) == (True, loaded)
    # The controls: a record made for other code is not used; that server generates the puzzle (which fails
    # here: it warms every kernel instead). Nor is one naming a signature that numba's cache does not hold
    # (every worker would compile it).
    record = json.loads((tmp_path / "record.json").read_text())
    (tmp_path / "record.json").write_text(json.dumps({**record, "key": "other code"}))
    unhinted, everything = _probe(tmp_path, "generator", no_puzzle=True)
    assert not unhinted and everything > loaded
    kernel = record["generators"]["simple_slider"]["signatures"][0]
    record["generators"]["simple_slider"]["signatures"].append([kernel[0], kernel[1], "(uncached, signature)"])
    (tmp_path / "record.json").write_text(json.dumps(record))
    unhinted, everything = _probe(tmp_path, "generator", no_puzzle=True)
    assert not unhinted and everything > loaded


def test_a_record_is_for_the_code_it_was_made_with(tmp_path, monkeypatch):
    from solver.pipelines import _warm_record

    package = tmp_path / "package"
    (package / "sub").mkdir(parents=True)
    (package / "sub" / "module.py").write_text("x = 1\n")
    monkeypatch.setattr(_warm_record, "_SOURCE_PACKAGES", (package,))
    key = _warm_record.record_key()
    assert _warm_record.record_key() == key  # the control: the same code, the same key
    os.utime(package / "sub" / "module.py", ns=(0, 0))
    assert _warm_record.record_key() != key
    monkeypatch.setattr(_warm_record, "RECORD_FILE", tmp_path / "record.json")
    _warm_record.record("grid_world", key, [("m", "f", "(int64,)")], ["solver.x"])
    assert _warm_record.recorded("grid_world", key) == {"signatures": [("m", "f", "(int64,)")], "modules": ["solver.x"]}
    assert _warm_record.recorded("grid_world", "another key") is None
    assert _warm_record.recorded("rooms", key) is None


def test_a_server_loads_the_records_of_the_requests_other_generators_too(tmp_path):
    _, slider = _probe(tmp_path, "generator")  # (records Simple Slider's signatures)
    _, moves = _probe(tmp_path, "move_n_times")  # (and Move N Times')
    hinted, both = _probe(tmp_path, "two", no_puzzle=True, recorded=True)
    assert hinted and both > max(slider, moves)  # (Move N Times calls kernels Simple Slider does not)
    # The control: the first generator's record alone.
    assert _probe(tmp_path, "generator", no_puzzle=True, recorded=True) == (True, slider)


def test_the_server_imports_its_preload_without_collecting_garbage_and_its_workers_collect(tmp_path):
    done = _run_probe(tmp_path, "generator")
    assert done.returncode == 0, done.stderr[-2000:]
    during_preload, in_the_worker = done.stdout.split()[3:]
    assert during_preload == "False"
    assert in_the_worker == "True"  # the control: the same probe sees collection on, where it must be


def test_a_server_that_dies_preparing_for_its_hint_is_started_again_cold(tmp_path):
    hinted, loaded = _probe(tmp_path, "crash")
    assert not hinted and loaded == 0  # the task ran, in a worker of a server that prepared nothing
    # The control: the same hint kills the server, and without the second start the pool's start fails.
    done = _run_probe(tmp_path, "crash-no-retry")
    assert done.returncode != 0 and "EOFError" in done.stderr, done.stderr[-2000:]


@pytest.mark.slow
def test_a_hinted_server_makes_the_same_dataset_as_one_that_warms_everything(tmp_path):
    command = ["dataset", "--generator", "simple_slider", "--seeds", "9987002-9987010", "--set", "n_objects=4",
               "--workers", "2", "--quiet"]
    script = ("import sys; import solver.pipelines.dataset.build as build\n"
              "if sys.argv[1] == 'none': build._server_hint = lambda batch: None\n"
              "from phyrogen.cli import main; sys.exit(main(sys.argv[2:]))")
    roots = {}
    for hint in ("generator", "none"):
        roots[hint] = tmp_path / hint
        subprocess.run([sys.executable, "-c", script, hint, *command, "--out", str(roots[hint])], cwd=ROOT,
                       check=True, capture_output=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    files = {hint: {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
                    if p.is_file() and p.relative_to(root).parts[0] not in ("parts", "manifest.parquet")}
             for hint, root in roots.items()}
    assert len(files["generator"]) > 9 * 2
    assert files["generator"] == files["none"]

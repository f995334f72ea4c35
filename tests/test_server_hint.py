"""The workers' server prepared for a dataset's own generator (solver.pipelines._server_warmup): the run's
first puzzle, generated once in the server and thrown away, loads that generator's compiled kernels'
signatures instead of every signature numba's cache holds; it changes no byte of the dataset, and a server
that dies preparing is started again, cold, instead of failing the run.

Seeds 9987001-9987010 are this file's; no other test uses them.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from phyrogen_core.maker import GenerationError
from phyrogen_core.registry import get_generator
from solver.parallel import pool
from solver.pipelines import generation
from solver.pipelines.dataset.build import REFERENCE_OBJECTS, EntryTask, _server_hint

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


def test_only_a_puzzle_cheaper_than_the_whole_warm_up_is_hinted():
    hint = _server_hint([_task("simple_slider", {"n_objects": "4"})])
    assert isinstance(hint, str)
    # The control: Move N Times with n = 8 (nine objects, several CPU s a puzzle) is left to the warm-up.
    task = _task("move_n_times", {"n": "8"})
    assert get_generator("move_n_times").build(task.seed, task.params).n_objects > REFERENCE_OBJECTS
    assert _server_hint([task]) is None


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
import probe_helper

hint = {"generator": lambda item: warm_hint("simple_slider", 9987001, get_generator("simple_slider").parse_params(
            {"n_objects": "4"})),
        "none": None, "garbage": lambda item: "not a hint", "crash": probe_helper.crashing_hint,
        "crash-no-retry": probe_helper.crashing_hint}[sys.argv[2]]
if sys.argv[2] == "crash-no-retry":
    pool._SERVER_EXIT_POLLS = 0  # the server's death is never seen: the start fails as it did before the retry
with fresh_process_pool(1, 1, PRELOAD, server_hint=hint) as workers:
    print(*next(workers.imap(probe_helper.probe, [0])))
'''
HELPER = '''
import sys

def probe(_):
    warm = sys.modules["solver.pipelines._server_warmup"]
    return warm.HINTED, sum(len(kernel.overloads) for kernel in warm._kernels_called_from_python())


class _Segfault:
    def __reduce__(self):
        import ctypes

        return ctypes.string_at, (8, 1)  # reads address 8 as the hint is read: the server dies of SIGSEGV


def crashing_hint(item):
    import base64
    import pickle

    return base64.b64encode(pickle.dumps(_Segfault())).decode("ascii")
'''


def _run_probe(tmp_path: Path, hint: str) -> subprocess.CompletedProcess:
    (tmp_path / "probe_helper.py").write_text(HELPER)
    return subprocess.run([sys.executable, "-c", PROBE, str(tmp_path), hint], cwd=ROOT, capture_output=True,
                          text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})


def _probe(tmp_path: Path, hint: str) -> tuple[bool, int]:
    done = _run_probe(tmp_path, hint)
    assert done.returncode == 0, done.stderr[-2000:]
    hinted, loaded = done.stdout.split()
    return hinted == "True", int(loaded)


def test_a_hinted_server_loads_its_generators_signatures_and_no_others(tmp_path):
    hinted, loaded = _probe(tmp_path, "generator")
    unhinted, everything = _probe(tmp_path, "none")
    assert hinted and not unhinted
    assert 0 < loaded < everything  # (Simple Slider of four objects: 10 of 31 at the time of writing)
    garbled, fallback = _probe(tmp_path, "garbage")  # the control: a hint that fails warms everything up
    assert not garbled and fallback > loaded


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

"""The public API from a plain script: ``python script.py`` with generation at its top level and no
``if __name__ == "__main__":`` guard.

Each puzzle is generated in a fresh worker process. Multiprocessing used to run the caller's
script again in every worker, where a top-level ``phyrogen.generate`` failed ("the worker process
ended (exit code 1)"); the pool's server now starts its workers without the caller's main module
(:mod:`solver.parallel._pool_server`). Every case runs a real interpreter on a real file, in a
session of its own, so that a process left behind can be found by its session id.
"""

from __future__ import annotations

import ast
import os
import re
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from waiting import BACKSTOP, wait_until

import phyrogen

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "docs" / "examples" / "generate_from_script.py"
TWO_SLIDERS = ROOT / "docs" / "examples" / "two_sliders.py"  # registers a generator
OLD_FAILURE = "worker process ended"
MARKER = "top-level code ran"

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")

# Every public function that starts worker processes, called at the top level. The marker shows
# how often the top-level code ran: once, in the script's own process.
EVERY_GENERATING_CALL = f"""
import sys

import gymnasium as gym

import phyrogen
import phyrogen.env

print("{MARKER}", flush=True)
out = sys.argv[1]
puzzle = phyrogen.generate("simple_slider", seed=3, n_objects=2)
print("generate", puzzle.name, len(puzzle.certificate))
print("generate_into", phyrogen.generate_into(out, "simple_slider", seed=4, n_objects=2))
env = gym.make("phyrogen.env:PhyRoGen/Puzzle-v0", generator="simple_slider", puzzle_seed=[5, 6],
               params={{"n_objects": 2}})
obs, info = env.reset(seed=0)
print("env", info["puzzle"], env.observation_space.shape)
"""

# The same script with the pool's workers under another name, which the server does not start
# without the caller's main module: the behaviour before the fix.
WITHOUT_THE_FIX = "import solver.parallel.pool\nsolver.parallel.pool.WORKER_NAME = 'another-process'\n"


def session_processes(session: int) -> dict[int, str]:
    """Live (not zombie) processes of ``session``: pid -> command line."""
    found = {}
    for entry in filter(str.isdigit, os.listdir("/proc")):
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
            command = Path(f"/proc/{entry}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:  # ended meanwhile
            continue
        state, _, _, sid = stat[stat.rindex(")") + 2:].split()[:4]
        if int(sid) == session and state != "Z":
            found[int(entry)] = command
    return found


def finish(process: subprocess.Popen) -> tuple[str, str]:
    """stdout and stderr once the script and every process of its session are gone (orphans are
    reaped by PID 1, which may take a moment; a live one would stay and fail the test)."""
    try:
        out, err = process.communicate(timeout=BACKSTOP)
    except subprocess.TimeoutExpired:
        for pid in session_processes(process.pid):
            os.kill(pid, signal.SIGKILL)
        process.communicate()
        pytest.fail(f"hung: the script did not end in {BACKSTOP:.0f} s")
    wait_until(lambda: not session_processes(process.pid),
               lambda: f"no process of the script left: {session_processes(process.pid)}")
    return out, err


def run_script(path: Path, *args: str, cwd: Path) -> tuple[int, str, str]:
    """Run ``python path args`` in a new session; its exit code, stdout and stderr (see :func:`finish`)."""
    process = subprocess.Popen([sys.executable, str(path), *args], cwd=cwd, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, start_new_session=True)
    out, err = finish(process)
    return process.returncode, out, err


def phyrogen_check(folder: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "phyrogen", "check", str(folder)], cwd=ROOT, capture_output=True,
                          text=True, timeout=BACKSTOP)


def test_the_example_runs_as_a_plain_script_and_its_puzzles_check(tmp_path):
    # The example is what it shows: generation at the top level, under no `if` (no main guard).
    assert not any(isinstance(node, ast.If) for node in ast.parse(EXAMPLE.read_text()).body)
    code, out, err = run_script(EXAMPLE, str(tmp_path / "out"), cwd=tmp_path)
    assert OLD_FAILURE not in err
    assert (code, err) == (0, "")
    lines = out.splitlines()
    assert len(lines) == 2, out
    for line in lines:
        match = re.fullmatch(r"(.+): (\d+) certificate actions, valid", line)
        assert match, line
        folder = Path(match[1])
        assert folder.parent.parent == tmp_path / "out" and (folder / "puzzle.json").is_file()
        assert int(match[2]) >= 1
        checked = phyrogen_check(folder)
        assert checked.returncode == 0, checked.stdout + checked.stderr
    assert [Path(line.split(":")[0]).name for line in lines] == ["simple_slider_1", "grid_world_2"]


def test_every_generating_call_works_at_a_scripts_top_level_which_runs_once(tmp_path):
    script = tmp_path / "my_script.py"
    script.write_text(EVERY_GENERATING_CALL)
    code, out, err = run_script(script, str(tmp_path / "out"), cwd=tmp_path)
    assert OLD_FAILURE not in err
    assert code == 0, err
    assert out.count(MARKER) == 1, out
    rows = dict(line.split(" ", 1) for line in out.splitlines()[1:])
    assert rows["generate"].startswith("simple_slider_3 ")
    folder = Path(rows["generate_into"])
    assert folder == tmp_path / "out" / "simple_slider" / "simple_slider_4"
    assert phyrogen_check(folder).returncode == 0
    assert rows["env"].startswith("simple_slider_")


def test_negative_control_the_same_script_fails_as_it_did_without_the_fix(tmp_path):
    """Shows that the checks above tell the fix from the old behaviour: with the workers out of
    the server's reach, the script runs again in the worker and the call fails there."""
    script = tmp_path / "my_script.py"
    script.write_text(WITHOUT_THE_FIX + EVERY_GENERATING_CALL)
    code, out, err = run_script(script, str(tmp_path / "out"), cwd=tmp_path)
    assert code == 1
    assert OLD_FAILURE in err and "(exit code 1)" in err
    assert "An attempt has been made to start a new process" in err  # multiprocessing's own complaint
    assert out.count(MARKER) >= 2  # the parent, and the worker that ran the script again


@pytest.mark.parametrize(("call", "named"), [
    ('phyrogen.generate("grid_world", seed=1, n_objects=-3)', "got -3"),
    ('phyrogen.generate("no_such_generator", seed=1)', "'no_such_generator'"),
    ('phyrogen.generate_into(sys.argv[1], "grid_world", seed=0)', "got 0"),
    ('phyrogen.generate_into(sys.argv[1], "grid_world", seed=1, colour="red")', "'colour'"),
])
def test_bad_arguments_in_a_plain_script_raise_value_error_naming_the_value(tmp_path, call, named):
    script = tmp_path / "bad.py"
    script.write_text(textwrap.dedent(f"""
        import sys

        import phyrogen

        try:
            {call}
        except ValueError as exc:
            print("ValueError:", exc)
            raise SystemExit(3)
    """))
    code, out, err = run_script(script, str(tmp_path / "out"), cwd=tmp_path)
    assert (code, err) == (3, "")
    assert out.startswith("ValueError:") and named in out, out
    assert not (tmp_path / "out").exists()  # refused before any work: nothing written


def test_bad_arguments_are_refused_before_any_worker_starts(tmp_path, monkeypatch):
    from solver.parallel.pool import FreshProcessPool

    def no_worker(*args, **kwargs):
        raise AssertionError("a worker was started for a bad argument")

    monkeypatch.setattr(FreshProcessPool, "_start", no_worker)
    with pytest.raises(ValueError, match="n_objects must lie in 1..25, got 99"):
        phyrogen.generate("grid_world", seed=1, n_objects=99)
    with pytest.raises(ValueError, match="is a file"):
        (tmp_path / "file").write_text("")
        phyrogen.generate_into(tmp_path / "file", "grid_world", seed=1)


def test_ctrl_c_in_a_plain_script_stops_its_worker_and_leaves_nothing(tmp_path):
    """The pool's guarantees hold from a script too: Ctrl-C (SIGINT to the whole group) ends the
    script with its KeyboardInterrupt, no worker or fork server stays, no folder is half-written."""
    script = tmp_path / "loop.py"
    script.write_text(textwrap.dedent("""
        import sys

        import phyrogen

        for seed in range(1, 10_000):
            print(phyrogen.generate_into(sys.argv[1], "simple_slider", seed, n_objects=2), flush=True)
    """))
    out = tmp_path / "out"
    process = subprocess.Popen([sys.executable, str(script), str(out)], cwd=tmp_path, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, start_new_session=True)
    first = Path(process.stdout.readline().strip())  # one puzzle finished: the pool has run
    os.killpg(process.pid, signal.SIGINT)
    rest, err = finish(process)
    assert process.returncode == -signal.SIGINT, err
    assert "KeyboardInterrupt" in err and OLD_FAILURE not in err
    assert list(out.rglob(".*")) == []  # no temporary entry: no folder was left half-written
    finished = [first, *map(Path, rest.split())]
    assert all(phyrogen.check(folder) == [] for folder in finished)


def test_a_generator_the_script_registers_still_reaches_the_workers_under_the_guard(tmp_path):
    """A generator the caller registers is not the project's: for it the workers run the script
    again, as multiprocessing does by default (the guard keeps them from generating too)."""
    script = tmp_path / "own_generator.py"
    script.write_text(textwrap.dedent(f"""
        import importlib.util
        import sys

        import phyrogen

        spec = importlib.util.spec_from_file_location("two_sliders_example", {str(TWO_SLIDERS)!r})
        module = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = module
        spec.loader.exec_module(module)  # registers two_sliders

        if __name__ == "__main__":
            print(phyrogen.generate_into(sys.argv[1], "two_sliders", seed=1))
    """))
    code, out, err = run_script(script, str(tmp_path / "out"), cwd=tmp_path)
    assert (code, err) == (0, "")
    folder = Path(out.strip())
    assert folder == tmp_path / "out" / "two_sliders" / "two_sliders_1"
    assert phyrogen.check(folder) == []

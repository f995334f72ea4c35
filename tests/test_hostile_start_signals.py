"""Ctrl-C and SIGTERM while a command starts: one line, ``phyrogen: interrupted``, exit 130 / 143,
nothing written and no process left, at moments a random Ctrl-C rarely hits but sometimes does.

- **Inside OMPL's import.** OMPL's compiled module runs Python code while it initialises (it
  builds hundreds of enums); a KeyboardInterrupt raised there crossed its C++ and aborted the
  process (``terminate called after throwing an instance of 'nanobind::python_error'``, exit
  -6), or was swallowed, and the command went on. Seen in 1 of 25 random Ctrl-Cs 1.3-1.7 s into
  ``generate``, whose own process no longer imports OMPL (its workers' server does, ignoring
  SIGINT); ``replan`` plans in its own process. Here the signal is sent from inside that
  initialisation, at the k-th Python call it makes (a trace function, set only for the import of
  ``ompl._ompl``, sees the calls), so the moment is the same on any machine.
- **Before ``main`` installs its handlers.** The command's imports take a tenth of a second;
  a Ctrl-C then printed Python's KeyboardInterrupt traceback. Here the signal is sent as the
  command's process first looks for ``phyrogen_core`` (by a ``sitecustomize`` of the test's).
- **While the pool's fork server starts.** Until its first instruction ignores SIGINT, a Ctrl-C
  to the process group printed the server's KeyboardInterrupt traceback beside the command's
  line. Here the server, started with a ``sitecustomize`` that waits at its very start, is held
  there while the test sends SIGINT to the whole group, as a terminal does.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from test_hostile_signals import assert_nothing_left, finish
from waiting import BACKSTOP, wait_until

ROOT = Path(__file__).resolve().parents[1]
INTERRUPTED = "phyrogen: interrupted\n"
GENERATE = ["generate", "--generator", "simple_slider", "--set", "n_objects=2", "--seeds", "31", "--workers", "1",
            "--quiet"]

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")

INSIDE_OMPL_INIT = """
import os
import signal
import sys
from pathlib import Path

marker, signum, at = Path(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
calls = 0


def inside_ompl_init(frame) -> bool:
    depth = 0
    while frame is not None:
        if frame.f_code.co_qualname == "ExtensionFileLoader.exec_module":
            # exec_module -> _call_with_frames_removed -> OMPL's C++ -> this frame: called by the C++
            return getattr(frame.f_locals.get("module"), "__name__", None) == "ompl._ompl" and depth >= 2
        frame, depth = frame.f_back, depth + 1
    return False


def tracer(frame, event, arg):
    global calls
    if event == "call" and inside_ompl_init(frame):
        calls += 1
        if calls == at:
            sys.settrace(None)
            marker.write_text(frame.f_code.co_qualname)
            os.kill(os.getpid(), signum)
    return None


class WatchOmplInit:
    def find_spec(self, name, path=None, target=None):
        if name == "ompl._ompl" and not marker.exists():
            sys.settrace(tracer)
        return None


sys.meta_path.insert(0, WatchOmplInit())
from phyrogen.cli import main  # noqa: E402

sys.exit(main(sys.argv[4:]))
"""


@pytest.fixture(scope="module")
def puzzle_folder(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("puzzle")
    subprocess.run([sys.executable, "-m", "phyrogen", *GENERATE, "--out", str(out)], cwd=ROOT, check=True,
                   capture_output=True)
    return out / "simple_slider" / "simple_slider_31"


def _files(folder: Path) -> dict[str, bytes]:
    return {str(path.relative_to(folder)): path.read_bytes() for path in sorted(folder.rglob("*")) if path.is_file()}


@pytest.mark.parametrize("signum, at", [(signal.SIGINT, 20), (signal.SIGINT, 300), (signal.SIGTERM, 100)],
                         ids=["ctrl-c early", "ctrl-c late", "sigterm"])
def test_a_signal_inside_ompls_import_ends_the_command_cleanly(signum, at, puzzle_folder, tmp_path):
    marker = tmp_path / "signalled"
    before = _files(puzzle_folder)
    process = subprocess.Popen([sys.executable, "-c", INSIDE_OMPL_INIT, str(marker), str(int(signum)), str(at),
                                "replan", str(puzzle_folder)], cwd=ROOT, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, start_new_session=True)
    stdout, stderr = finish(process)
    assert marker.is_file(), "the signal was not sent inside OMPL's initialisation"
    assert (process.returncode, stdout, stderr) == (128 + signum, "", INTERRUPTED), (process.returncode, stdout,
                                                                                     stderr, marker.read_text())
    assert _files(puzzle_folder) == before  # stopped before it planned, nothing written
    assert_nothing_left(process)


IMPORTED = """
import sys

from phyrogen.cli import main

code = main(sys.argv[2:])
print(sorted(name for name in ("ompl", "numba") if name in sys.modules),
      file=open(sys.argv[1], "w"))
sys.exit(code)
"""


@pytest.mark.parametrize("command", ["generate", "dataset", "replan (control)"])
def test_the_generating_commands_leave_ompl_and_numba_to_the_workers_server(command, puzzle_folder, tmp_path):
    """``generate`` and ``dataset`` only schedule and write in their own process: OMPL, numba's kernels and the
    solver are imported (about 0.3 CPU s) by the server their workers fork from. Control: ``replan``, which
    plans in its own process, is seen importing them."""
    argv = {"generate": [*GENERATE, "--out", str(tmp_path / "out")],
            "dataset": ["dataset", "--generator", "simple_slider", "--set", "n_objects=2", "--seeds", "31",
                        "--workers", "1", "--quiet", "--out", str(tmp_path / "out")],
            "replan (control)": ["replan", str(puzzle_folder)]}[command]
    seen = tmp_path / "imported"
    done = subprocess.run([sys.executable, "-c", IMPORTED, str(seen), *argv], cwd=ROOT, capture_output=True,
                          text=True)
    assert done.returncode == 0, done.stderr
    imported = seen.read_text().strip()
    if command == "replan (control)":
        assert imported == "['numba', 'ompl']"
    else:
        assert imported == "[]"
        assert (tmp_path / "out").is_dir()  # the workers made the puzzle


HELD_SERVER = """
import os
import sys
import time
from pathlib import Path

if any("multiprocessing.forkserver import main" in arg for arg in sys.orig_argv):
    # The fork server, before any of its own code: say so, and wait for the test's signal to be sent.
    (Path(os.environ["HELD_DIR"]) / "starting").touch()
    sent = Path(os.environ["HELD_DIR"]) / "sent"
    deadline = time.monotonic() + float(os.environ["HELD_BACKSTOP"])
    while not sent.exists() and time.monotonic() < deadline:
        time.sleep(0.01)
"""


def test_ctrl_c_while_the_fork_server_starts_prints_one_line(tmp_path):
    site = tmp_path / "site"
    site.mkdir()
    (site / "sitecustomize.py").write_text(HELD_SERVER)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")]),
           "HELD_DIR": str(tmp_path), "HELD_BACKSTOP": str(BACKSTOP)}
    process = subprocess.Popen([sys.executable, "-m", "phyrogen", *GENERATE, "--out", str(tmp_path / "out")],
                               cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True, env=env)
    try:
        wait_until(lambda: process.poll() is not None or (tmp_path / "starting").exists(), "the fork server's start")
        assert process.poll() is None, process.communicate()
        os.killpg(process.pid, signal.SIGINT)  # Ctrl-C: the terminal signals the whole process group
    finally:
        (tmp_path / "sent").touch()
    stdout, stderr = finish(process)
    assert (process.returncode, stderr) == (130, INTERRUPTED), (process.returncode, stdout, stderr)
    assert len(stdout.splitlines()) <= 1 and "Traceback" not in stdout, stdout  # the table's header at most
    assert not (tmp_path / "out" / "simple_slider" / "simple_slider_31").exists()
    assert_nothing_left(process)


SIGNAL_ON_IMPORT = """
import os
import sys

# The command's process (not the fork server's); nothing of phyrogen is imported here, before its time.
if "phyrogen" in [os.path.basename(arg) for arg in sys.orig_argv[1:3]]:

    class SignalOnImport:
        def find_spec(self, name, path=None, target=None):
            if name == os.environ["SIGNAL_ON_IMPORT"]:
                sys.meta_path.remove(self)
                os.kill(os.getpid(), int(os.environ["SIGNAL_NUMBER"]))
            return None

    sys.meta_path.insert(0, SignalOnImport())
"""


@pytest.mark.parametrize("entry", ["python -m phyrogen", "console script"])
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["ctrl-c", "sigterm"])
def test_a_signal_before_main_installs_its_handlers_gives_the_commands_line(entry, signum, tmp_path):
    script = Path(sys.executable).with_name("phyrogen")
    if entry == "console script" and not script.is_file():
        pytest.skip("the package is not installed with its console script")
    command = [sys.executable, "-m", "phyrogen"] if entry == "python -m phyrogen" else [str(script)]
    site = tmp_path / "site"
    site.mkdir()
    (site / "sitecustomize.py").write_text(SIGNAL_ON_IMPORT)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")]),
           "SIGNAL_ON_IMPORT": "phyrogen_core", "SIGNAL_NUMBER": str(int(signum))}
    process = subprocess.Popen([*command, *GENERATE, "--out", str(tmp_path / "out")], cwd=ROOT,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                               env=env)
    stdout, stderr = finish(process)
    assert (process.returncode, stdout, stderr) == (128 + signum, "", INTERRUPTED), (process.returncode, stdout,
                                                                                     stderr)
    assert not (tmp_path / "out").exists()
    assert_nothing_left(process)


@pytest.mark.parametrize("argv, command", [
    (["/venv/bin/python", "/venv/bin/phyrogen", "generate"], True),
    (["/venv/bin/python", "-X", "importtime", "-m", "phyrogen", "check", "x"], True),
    (["python3", "-m", "phyrogen"], True),
    (["python3", "-m", "pytest", "tests"], False),
    (["python3", "-c", "import phyrogen"], False),
    (["python3", "my_phyrogen_script.py"], False),
    (["python3"], False),
])
def test_only_the_commands_own_process_gets_the_early_handlers(argv, command):
    """Negative control: a program that imports the package keeps Python's own handlers."""
    from phyrogen.startup import started_as_the_command

    assert started_as_the_command(argv) is command

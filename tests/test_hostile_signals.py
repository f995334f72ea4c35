"""Interrupted commands stop cleanly: SIGINT (Ctrl-C reaches the whole process group) and SIGTERM
(to the command, or to its group as ``timeout`` sends it) give exit 130 / 143 and one line,
``phyrogen: interrupted``, on stderr; no process is left behind (worker, fork server, resource
tracker, render worker), no temporary folder stays, and the puzzles finished before stay valid.
A parent killed outright takes its workers with it. Huge seed ranges stream; a long puzzle shows
progress; only ``--debug`` shows a traceback.

Every case runs the real command in a session of its own, so that every process it starts,
even one orphaned, can be found by its session id in /proc.

No outcome depends on how fast the machine is: each case waits for the event it needs (a
puzzle folder, a worker, a progress line), with a backstop of minutes only against a hang. That
a long puzzle is stopped at once, not finished first, is measured in the CPU time its worker
spends after the signal, not in seconds on the clock.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from waiting import BACKSTOP, wait_until

import phyrogen
from phyrogen.cli import main

ROOT = Path(__file__).resolve().parents[1]
QUICK = ["--generator", "simple_slider", "--set", "n_objects=2"]  # about 0.1 s a puzzle
SLOW = ["--generator", "move_n_times", "--set", "n=20"]  # about 20 s of CPU a puzzle
STOPPED_AT_ONCE_CPU = 5.0
"""CPU seconds a worker of a SLOW puzzle may still spend once stopped: a quarter of its puzzle."""
INTERRUPTED = "phyrogen: interrupted\n"

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")


def run_phyrogen(*args: str, stderr=subprocess.PIPE) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "phyrogen", *args], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=stderr, text=True, start_new_session=True)


def session_processes(session: int) -> dict[int, tuple[int, str]]:
    """Live (not zombie) processes of ``session``: pid -> (parent pid, command line)."""
    found = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
            command = Path(f"/proc/{entry}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:  # ended meanwhile
            continue
        state, parent, _, sid = stat[stat.rindex(")") + 2:].split()[:4]
        if int(sid) == session and state != "Z":
            found[int(entry)] = (int(parent), command)
    return found


def workers(process: subprocess.Popen) -> list[int]:
    """The pool's workers: processes forked by the fork server, a child of the command."""
    live = session_processes(process.pid)
    return [pid for pid, (parent, _) in live.items() if live.get(parent, (0,))[0] == process.pid]


def finish(process: subprocess.Popen) -> tuple[str, str]:
    """stdout and stderr until every process holding them (workers, servers) is gone."""
    try:
        out, err = process.communicate(timeout=BACKSTOP)
    except subprocess.TimeoutExpired:
        left = session_processes(process.pid)
        for pid in left:
            os.kill(pid, signal.SIGKILL)
        process.communicate()
        pytest.fail(f"hung: processes still running {BACKSTOP:.0f} s after the command was stopped: {left}")
    return out, err


def assert_nothing_left(process: subprocess.Popen) -> None:
    # Orphans are reaped by PID 1, which may take a moment; a live process would stay.
    wait_until(lambda: not session_processes(process.pid),
               lambda: f"the end of every process of the command: {session_processes(process.pid)}")


def cpu_and_state(pid: int, session: int) -> tuple[float, str] | None:
    """CPU seconds (user and system) ``pid`` has used, and its state; None once it is reaped."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = stat[stat.rindex(")") + 2:].split()
    if int(fields[3]) != session:  # the number was reused by another process
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK"), fields[0]


def stopped_workers_cpu(process: subprocess.Popen, stop: Callable[[], object]) -> dict[int, float]:
    """Call ``stop`` with the command's workers running; the CPU seconds each spends until it ends.
    A worker that finished its puzzle first would spend the rest of the puzzle's CPU."""
    pids = workers(process)
    start = {pid: cpu_and_state(pid, process.pid) for pid in pids}
    spent = dict.fromkeys(pids, 0.0)
    stop()

    def ended() -> bool:
        running = False
        for pid in pids:
            now = cpu_and_state(pid, process.pid)
            if now is not None and start[pid] is not None:
                spent[pid] = now[0] - start[pid][0]
                running |= now[1] != "Z"
        return not running

    wait_until(ended, f"the end of the workers {pids}")
    return spent


def puzzle_folders(out: Path) -> list[Path]:
    return sorted(p.parent for p in out.rglob("puzzle.json"))


def temporary_entries(out: Path) -> list[Path]:
    return list(out.rglob(".*"))


@pytest.mark.parametrize(("signum", "group"), [(signal.SIGINT, True), (signal.SIGTERM, False), (signal.SIGTERM, True)],
                         ids=["ctrl-c", "kill", "timeout"])
def test_interrupted_generate_keeps_finished_puzzles_and_leaves_nothing(signum, group, tmp_path):
    out = tmp_path / "out"
    process = run_phyrogen("generate", *QUICK, "--seeds", "1-500", "--out", str(out), "--quiet")
    wait_until(lambda: len(puzzle_folders(out)) >= 3, "three finished puzzles")
    if group:
        os.killpg(process.pid, signum)
    else:
        process.send_signal(signum)
    stdout, stderr = finish(process)
    assert (process.returncode, stderr) == (128 + signum, INTERRUPTED)
    assert_nothing_left(process)
    assert temporary_entries(out) == []
    folders = puzzle_folders(out)
    assert 3 <= len(folders) < 500
    assert {f.name: phyrogen.check(f) for f in folders} == {f.name: [] for f in folders}
    reported = [line.split()[-1] for line in stdout.splitlines()[1:]]
    assert set(reported) <= {str(f) for f in folders}  # a row is printed only for a finished puzzle


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["ctrl-c", "timeout"])
def test_a_long_puzzle_is_stopped_at_once(signum, tmp_path):
    out = tmp_path / "out"
    process = run_phyrogen("generate", *SLOW, "--seeds", "1-4", "--workers", "2", "--out", str(out), "--quiet")
    wait_until(lambda: len(workers(process)) == 2, "two workers")
    spent = stopped_workers_cpu(process, lambda: os.killpg(process.pid, signum))
    assert max(spent.values()) < STOPPED_AT_ONCE_CPU, f"CPU seconds spent after the signal: {spent}"
    _, stderr = finish(process)
    assert (process.returncode, stderr) == (128 + signum, INTERRUPTED)
    assert_nothing_left(process)
    assert puzzle_folders(out) == [] and temporary_entries(out) == []


def test_ctrl_c_twice_still_cleans_up(tmp_path):
    out = tmp_path / "out"
    process = run_phyrogen("generate", *SLOW, "--seeds", "1-4", "--workers", "2", "--out", str(out), "--quiet")
    wait_until(lambda: len(workers(process)) == 2, "two workers")

    def twice() -> None:
        os.killpg(process.pid, signal.SIGINT)
        time.sleep(0.02)  # the second arrives while the first is handled, or after: either must clean up
        os.killpg(process.pid, signal.SIGINT)

    spent = stopped_workers_cpu(process, twice)
    assert max(spent.values()) < STOPPED_AT_ONCE_CPU, f"CPU seconds spent after the signals: {spent}"
    _, stderr = finish(process)
    assert (process.returncode, stderr) == (130, INTERRUPTED)
    assert_nothing_left(process)


def test_sigterm_while_the_fork_server_starts(tmp_path):
    out = tmp_path / "out"
    process = run_phyrogen("generate", *QUICK, "--seeds", "1-50", "--out", str(out), "--quiet")
    server = lambda: [pid for pid, (_, cmd) in session_processes(process.pid).items() if "forkserver" in cmd]  # noqa: E731
    starting = wait_until(server, "the fork server")
    # Held where it is, the server cannot finish starting before the signal, however fast it is.
    for pid in starting:
        os.kill(pid, signal.SIGSTOP)
    assert workers(process) == []  # still importing its preload: the case under test
    os.killpg(process.pid, signal.SIGTERM)
    for pid in starting:
        os.kill(pid, signal.SIGCONT)
    _, stderr = finish(process)
    assert (process.returncode, stderr) == (143, INTERRUPTED)
    assert_nothing_left(process)
    assert temporary_entries(out) == []


def test_workers_end_with_a_killed_parent(tmp_path):
    process = run_phyrogen("generate", *SLOW, "--seeds", "1-4", "--workers", "2", "--out", str(tmp_path), "--quiet")
    wait_until(lambda: len(workers(process)) == 2, "two workers")
    spent = stopped_workers_cpu(process, process.kill)  # SIGKILL: no handler, no clean-up in the parent
    assert max(spent.values()) < STOPPED_AT_ONCE_CPU, f"CPU seconds spent after the parent died: {spent}"
    finish(process)
    assert_nothing_left(process)


def peak_rss_until(process: subprocess.Popen, condition: Callable[[], object]) -> int:
    """The command's largest resident memory (kB) until ``condition`` holds."""
    peak = 0

    def sampled() -> object:
        nonlocal peak
        assert process.poll() is None, "the command ended before it finished two puzzles"
        status = Path(f"/proc/{process.pid}/status").read_text()
        peak = max(peak, int(status.split("VmRSS:")[1].split()[0]))
        return condition()

    wait_until(sampled, "two finished puzzles")
    return peak


def test_a_hundred_million_seeds_stream_in_little_memory(tmp_path):
    out = tmp_path / "out"
    process = run_phyrogen("generate", *QUICK, "--seeds", "1-100000000", "--out", str(out), "--quiet")
    peak = peak_rss_until(process, lambda: len(puzzle_folders(out)) >= 2)
    os.killpg(process.pid, signal.SIGINT)
    stdout, stderr = finish(process)
    assert (process.returncode, stderr) == (130, INTERRUPTED)
    assert peak < 400 * 1024, f"{peak / 1024:.0f} MiB"  # a list of the seeds alone would be gigabytes
    # Work starts at the first seeds, and each row is printed once it and all rows before it are done.
    assert {f.name for f in puzzle_folders(out)} <= {f"simple_slider_{seed}" for seed in range(1, 20)}
    seeds = [int(line.split()[1]) for line in stdout.splitlines()[1:]]
    assert seeds == list(range(1, len(seeds) + 1))
    assert_nothing_left(process)


def test_a_hundred_million_seeds_with_a_bad_size_are_refused_before_any_work(tmp_path):
    # Without n_objects, simple_slider builds seed + 1 sliders: seed 100000000 is far too many.
    process = run_phyrogen("generate", "--generator", "simple_slider", "--seeds", "1-100000000",
                           "--out", str(tmp_path / "out"))
    _, stderr = finish(process)
    assert process.returncode == 2
    assert len(stderr.splitlines()) == 1 and "n_objects" in stderr
    assert not (tmp_path / "out").exists()


RUNNING_BAR = re.compile(r"0/1 \[(\d\d:\d\d)<[^\]\n\r]*, running move_n_times_1\]")
"""tqdm's bar with nothing finished yet and the long puzzle running; the group is the elapsed time."""


def test_a_single_long_puzzle_shows_running_progress(tmp_path):
    log = tmp_path / "stderr"
    with log.open("w") as sink:
        process = run_phyrogen("generate", *SLOW, "--seeds", "1", "--out", str(tmp_path / "out"), stderr=sink)
        try:
            # Redrawn every second although nothing finishes: the elapsed time moves on. Three
            # redraws at different times, the puzzle unfinished, show it whatever the machine's speed.
            wait_until(lambda: len(set(RUNNING_BAR.findall(log.read_text()))) >= 3,
                       "the running puzzle's progress bar at three different elapsed times")
        finally:
            os.killpg(process.pid, signal.SIGINT)
            finish(process)
    text = log.read_text()
    assert text.endswith(INTERRUPTED) and "Traceback" not in text


def test_ctrl_c_of_benchmark_prints_no_worker_traceback(tmp_path):
    puzzles = tmp_path / "puzzles"
    generated = run_phyrogen("generate", *QUICK, "--seeds", "1", "--out", str(puzzles), "--quiet")
    finish(generated)
    assert generated.returncode == 0
    # Short runs: workers end and start all the time, so Ctrl-C also finds some starting.
    process = run_phyrogen("benchmark", "--puzzles", str(puzzles), "--planners", "la_rrt", "--runs", "5000",
                           "--time-limit", "0.2", "--workers", "2", "--out", str(tmp_path / "bench"), "--quiet")
    first = set(wait_until(lambda: w if len(w := workers(process)) == 2 else None, "two benchmark workers"))
    wait_until(lambda: set(workers(process)) - first, "a benchmark worker started after the first two")
    os.killpg(process.pid, signal.SIGINT)
    _, stderr = finish(process)
    assert process.returncode == 130
    assert stderr.endswith(INTERRUPTED) and "Traceback" not in stderr and "KeyboardInterrupt" not in stderr
    assert_nothing_left(process)


def test_sigterm_of_render_stops_its_blender_workers(tmp_path):
    pytest.importorskip("bpy")
    out = tmp_path / "out"
    generated = run_phyrogen("generate", *QUICK, "--seeds", "1-8", "--out", str(out), "--quiet")
    finish(generated)
    process = run_phyrogen("render", "--out", str(out), "--workers", "2", "--quiet")
    render_workers = lambda: [pid for pid, (_, cmd) in session_processes(process.pid).items()  # noqa: E731
                              if "render_worker" in cmd]
    wait_until(lambda: len(render_workers()) == 2, "two render workers")
    process.terminate()  # the command only: its workers get no signal but from it
    _, stderr = finish(process)
    assert (process.returncode, stderr) == (143, INTERRUPTED)
    assert_nothing_left(process)
    assert temporary_entries(out) == []


def fail_with(exc: Exception):
    def command(args) -> int:
        raise exc

    return command


@pytest.mark.parametrize("argv", [["list"], ["--debug", "list"], ["list", "--debug"]])
def test_a_traceback_only_with_debug(argv, monkeypatch, capsys):
    monkeypatch.setattr("phyrogen.commands.list.run", fail_with(RuntimeError("boom\nsecond line")))
    assert main(argv) == 1
    err = capsys.readouterr().err
    if "--debug" in argv:
        assert "Traceback" in err and "RuntimeError: boom" in err
    else:
        assert err == "phyrogen: error: RuntimeError: boom (run with --debug for the traceback)\n"


def test_an_unusable_output_path_is_bad_input(monkeypatch, capsys):
    from phyrogen_core.atomic_writes import OutputError

    monkeypatch.setattr("phyrogen.commands.list.run", fail_with(OutputError("output folder out is a file")))
    assert main(["list"]) == 2
    assert capsys.readouterr().err == "phyrogen: error: output folder out is a file\n"


def test_a_worker_killed_from_outside_is_reported_not_waited_for(tmp_path):
    # What the kernel's out-of-memory killer does to a big puzzle.
    process = run_phyrogen("generate", *SLOW, "--seeds", "1", "--out", str(tmp_path), "--quiet")
    wait_until(lambda: workers(process), "the worker")
    os.kill(workers(process)[0], signal.SIGKILL)
    stdout, stderr = finish(process)
    assert process.returncode == 1 and stderr == ""
    assert "move_n_times" in stdout and "FAILED: the worker process ended (killed by signal 9)" in stdout
    assert_nothing_left(process)


FINALIZER_COMMAND = """
import os, signal, sys, time
import phyrogen.cli as cli
import phyrogen.commands.list as list_command

class Finalized:
    def __del__(self):
        os.kill(os.getpid(), signal.SIGTERM)  # handled in here, where Python drops what a handler raises
        time.sleep(1)

def command(args):
    Finalized()
    time.sleep(240)  # the rest of the work, which only the signal sent again may cut short
    print("finished")
    return 0

list_command.run = command
sys.exit(cli.main())
"""


def test_a_signal_arriving_in_a_finalizer_still_stops_the_command():
    process = subprocess.run([sys.executable, "-c", FINALIZER_COMMAND, "list"], cwd=ROOT, capture_output=True,
                             text=True, timeout=BACKSTOP)
    assert (process.returncode, process.stderr, process.stdout) == (143, INTERRUPTED, "")


def test_overlapping_seed_ranges_give_each_seed_once_in_order(tmp_path, capsys):
    assert main(["generate", *QUICK, "--seeds", "5,1-2,2,3-4,1", "--out", str(tmp_path), "--quiet"]) == 0
    rows = capsys.readouterr().out.splitlines()[1:-1]
    assert [int(row.split()[1]) for row in rows] == [1, 2, 3, 4, 5]


def test_a_worker_that_dies_without_a_result_is_reported_not_awaited():
    """A run killed from outside (the out-of-memory killer, a planner's segfault) is one lost item,
    in either order of results; the benchmark records it as a crashed run."""
    from solver.parallel.pool import fresh_process_pool

    lost = lambda item, how: (item, how)  # noqa: E731
    with fresh_process_pool(2, 3, []) as pool:
        unordered = sorted(pool.imap_unordered(os._exit, [3, 4, 5], on_lost=lost))
    with fresh_process_pool(2, 2, []) as pool:
        ordered = list(pool.imap(os._exit, [7, 6], on_lost=lost))
    assert unordered == [(3, "exit code 3"), (4, "exit code 4"), (5, "exit code 5")]
    assert ordered == [(7, "exit code 7"), (6, "exit code 6")]


def test_a_reader_that_stops_reading_ends_generate_quietly(tmp_path):
    """``phyrogen generate | head -2``: the command ends as SIGPIPE would, without a traceback,
    and stops its workers; the puzzles it finished stay whole."""
    out = tmp_path / "out"
    process = run_phyrogen("generate", *QUICK, "--seeds", "1-300", "--out", str(out), "--quiet")
    assert process.stdout.readline().startswith("generator")
    assert process.stdout.readline().startswith("simple_slider")
    process.stdout.close()  # the reader goes away; the next row the command prints breaks the pipe
    _, stderr = process.communicate(timeout=BACKSTOP)
    assert (process.returncode, stderr) == (128 + signal.SIGPIPE, "")
    assert_nothing_left(process)
    assert temporary_entries(out) == []
    assert 1 <= len(puzzle_folders(out)) < 300

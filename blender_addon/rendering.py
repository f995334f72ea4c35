"""Render many puzzle folders in worker subprocesses, Workbench first and Cycles as the fallback.

No bpy here: the work happens in ``python -m blender_addon.render_worker``
processes (the bpy wheel of the project's environment). Workbench needs an
OpenGL context (Mesa through EGL on a machine without a GPU) and aborts the
process without one, so the engine ``auto`` starts with Workbench and renders
whatever is left with Cycles on the CPU when a worker dies.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from solver.parallel.pool import deferred_signals

from .environment import render_worker_command
from .views import DEFAULT_VIEWS, STILL_SIZE

ENGINES = ("auto", "workbench", "cycles")


class RenderError(RuntimeError):
    """A worker failed and no fallback engine was left."""


@dataclass(frozen=True)
class RenderedPuzzle:
    folder: Path
    engine: str
    seconds: float
    images: int
    animation_seconds: float | None = None
    """The share of ``seconds`` spent on the solution animation; None when none was made."""


@dataclass(frozen=True)
class RenderReport:
    rendered: tuple[RenderedPuzzle, ...]
    seconds: float
    failures: tuple[str, ...] = field(default=())

    @property
    def images(self) -> int:
        return sum(r.images for r in self.rendered)

    @property
    def seconds_per_image(self) -> float:
        return self.seconds / self.images if self.images else 0.0

    @property
    def animations(self) -> int:
        return sum(r.animation_seconds is not None for r in self.rendered)

    @property
    def animation_seconds(self) -> float:
        """Worker time spent on solution animations, summed over puzzles."""
        return sum(r.animation_seconds or 0.0 for r in self.rendered)


def render_puzzles(puzzle_dirs: Sequence[str | Path], engine: str = "auto", size: tuple[int, int] = STILL_SIZE,
                   views: Sequence[str] = DEFAULT_VIEWS, workers: int = 1,
                   on_done: Callable[[RenderedPuzzle], None] | None = None, animation: bool = True) -> RenderReport:
    """Render every folder: ``images/<name>_NN.png`` (one per view) and ``<name>.blend``.

    With ``animation`` (the default), also ``images/<name>_solution.webp``: the
    certificate played in a few seconds (see :mod:`.animation`), keyframed in
    the ``.blend`` too.

    ``engine`` is ``auto`` (Workbench, Cycles where Workbench cannot run),
    ``workbench`` or ``cycles``. Folders are split over ``workers``
    processes. Raises RenderError naming the folders that could not be rendered,
    and, before any worker starts, :func:`check_render_folders`' errors.
    """
    if engine not in ENGINES:
        raise ValueError(f"render engine {engine!r} is not known; valid: {', '.join(ENGINES)}")
    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    folders = check_render_folders(puzzle_dirs)
    engines = ["WORKBENCH", "CYCLES"] if engine == "auto" else [engine.upper()]
    started = time.perf_counter()
    rendered: list[RenderedPuzzle] = []
    remaining = list(folders)
    failures: list[str] = []
    for engine_name in engines:
        if not remaining:
            break
        done, failures = _run_workers(remaining, engine_name, size, views, workers, on_done, animation)
        rendered += done
        finished = {r.folder for r in done}
        remaining = [f for f in remaining if f not in finished]
    if remaining:
        raise RenderError(f"could not render {[str(f) for f in remaining]}: " + " | ".join(failures))
    return RenderReport(tuple(rendered), time.perf_counter() - started, tuple(failures))


def check_render_folders(puzzle_dirs: Sequence[str | Path], writable: bool = True) -> list[Path]:
    """The puzzle folders as paths, each read in full and (``writable``) found writable for the render stage.

    Runs before any Blender starts, so that a broken folder is reported as what
    it is, bad input naming the folder, and not as a worker (or engine) that failed.
    Raises :class:`~phyrogen_core.folder.PuzzleFormatError` or
    :class:`~phyrogen_core.folder.OutputError` (``images`` a file, ``<name>.blend``
    a folder, no permission to write), one line each.
    """
    from phyrogen_core.export import read_puzzle_dir
    from phyrogen_core.folder import OutputError, PuzzleFolder, require_stage_folder

    folders = [Path(p) for p in puzzle_dirs]
    for folder in folders:
        read_puzzle_dir(folder)
        if not writable:
            continue
        place = PuzzleFolder.open(folder)
        if os.path.lexists(place.images) and not place.images.is_symlink() and not place.images.is_dir():
            raise OutputError(f"{place.images} is not a folder; the render stage writes its images there")
        # The puzzle folder and images/ real folders: a link would send the renders elsewhere.
        require_stage_folder(place.images, "images folder", root=place.path)
        if place.blend.is_dir():
            raise OutputError(f"{place.blend} is a folder; the render stage writes the Blender scene there")
    return folders


def _run_workers(folders: list[Path], engine: str, size: tuple[int, int], views: Sequence[str], workers: int,
                 on_done: Callable[[RenderedPuzzle], None] | None,
                 animation: bool = True) -> tuple[list[RenderedPuzzle], list[str]]:
    shares = [folders[i::workers] for i in range(min(workers, len(folders)))]
    with tempfile.TemporaryDirectory(prefix="phyrogen-render-") as home:
        environment = dict(os.environ)
        # Blender would otherwise write its configuration under the user's home folder.
        environment["BLENDER_USER_CONFIG"] = str(Path(home) / "config")
        environment["BLENDER_USER_RESOURCES"] = str(Path(home) / "resources")
        environment["PYTHONPATH"] = os.pathsep.join([str(Path(__file__).resolve().parent.parent),
                                                    environment.get("PYTHONPATH", "")]).rstrip(os.pathsep)
        processes = []
        before = _unfinished_outputs(folders)
        try:
            for share in shares:
                command = [*render_worker_command(), "--engine", engine,
                           "--size", f"{size[0]}x{size[1]}", "--views", ",".join(views),
                           *([] if animation else ["--no-animation"]), *map(str, share)]
                log = tempfile.TemporaryFile(mode="w+", dir=home)
                with deferred_signals():  # interrupted between fork and return, a worker would go unknown
                    processes.append((subprocess.Popen(command, stdout=subprocess.PIPE, stderr=log, text=True,
                                                       env=environment), log))
            done: list[RenderedPuzzle] = []
            failures: list[str] = []
            # Reading one worker to its end at a time cannot block the others: they log to files.
            for process, log in processes:
                assert process.stdout is not None
                for line in process.stdout:
                    if line.startswith("RENDERED "):
                        folder, seconds, images, animated = line[len("RENDERED "):].rstrip("\n").rsplit(" ", 3)
                        result = RenderedPuzzle(Path(folder), engine.lower(), float(seconds), int(images),
                                                None if animated == "-" else float(animated))
                        done.append(result)
                        if on_done is not None:
                            on_done(result)
                process.wait()
                log.seek(0)
                stderr = log.read()
                if process.returncode != 0:
                    tail = stderr.strip().splitlines()[-3:]
                    failures.append(f"{engine.lower()} worker exited with {process.returncode}: " + " / ".join(tail))
            return done, failures
        except BaseException:  # Ctrl-C, SIGTERM, a bug: no worker may outlive the command
            _stop_workers([process for process, _ in processes])
            # A worker killed at the end of its grace (a long render on a busy machine) could not
            # remove its unfinished output itself; only what appeared during this run is removed.
            for path in _unfinished_outputs(folders) - before:
                if path.is_dir():
                    shutil.rmtree(path, ignore_errors=True)
                else:
                    path.unlink(missing_ok=True)
            raise
        finally:
            for process, log in processes:
                log.close()
                if process.stdout is not None:
                    process.stdout.close()


def _unfinished_outputs(folders: Sequence[Path]) -> set[Path]:
    """The render worker's temporary images folders and scenes in ``folders``
    (:func:`~phyrogen_core.folder.atomic_directory`'s ``.images.*.tmp``, ``.<name>.tmp.blend``)."""
    return {path for folder in folders for pattern in (".images.*.tmp", ".*.tmp.blend")
            for path in folder.glob(pattern)}


WORKER_GRACE_SECONDS = 5.0
"""How long a stopped render worker may take to remove its unfinished output before it is killed."""


def _stop_workers(processes: list[subprocess.Popen]) -> None:
    # Ctrl-C in a terminal has reached the workers already (one process group): give them a
    # moment to end on their own, as a second SIGINT could cut their clean-up short. Then
    # SIGINT, not SIGTERM: it raises KeyboardInterrupt in the worker, whose unfinished images
    # and scene are removed on the way out; SIGTERM would end it on the spot.
    deadline = time.monotonic() + 1.0
    for process in processes:
        with contextlib.suppress(subprocess.TimeoutExpired):
            process.wait(max(0.0, deadline - time.monotonic()))
    for process in processes:
        if process.poll() is None:
            process.send_signal(signal.SIGINT)
    deadline = time.monotonic() + WORKER_GRACE_SECONDS
    for process in processes:
        try:
            process.wait(max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()

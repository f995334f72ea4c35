"""Render many puzzle folders in worker subprocesses, Workbench first and Cycles as the fallback.

No bpy here: the work happens in ``python -m blender_addon.render_worker``
processes (the bpy wheel of the project's environment). Workbench needs an
OpenGL context (Mesa through EGL on a machine without a GPU) and aborts the
process without one, so the engine ``auto`` starts with Workbench and renders
whatever is left with Cycles on the CPU when a worker dies.
"""

from __future__ import annotations

import os
import subprocess
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from .environment import worker_python
from .views import DEFAULT_VIEWS

ENGINES = ("auto", "workbench", "cycles")


class RenderError(RuntimeError):
    """A worker failed and no fallback engine was left."""


@dataclass(frozen=True)
class RenderedPuzzle:
    folder: Path
    engine: str
    seconds: float
    images: int


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


def render_puzzles(puzzle_dirs: Sequence[str | Path], engine: str = "auto", size: tuple[int, int] = (480, 360),
                   views: Sequence[str] = DEFAULT_VIEWS, workers: int = 1,
                   on_done: Callable[[RenderedPuzzle], None] | None = None) -> RenderReport:
    """Render every folder: ``images/<name>_NN.png`` (one per view) and ``<name>.blend``.

    ``engine`` is ``auto`` (Workbench, Cycles where Workbench cannot run),
    ``workbench`` or ``cycles``. Folders are split over ``workers``
    processes. Raises RenderError naming the folders that could not be rendered.
    """
    if engine not in ENGINES:
        raise ValueError(f"render engine {engine!r} is not known; valid: {', '.join(ENGINES)}")
    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    folders = [Path(p) for p in puzzle_dirs]
    for folder in folders:
        if not (folder / "puzzle.json").is_file():
            raise FileNotFoundError(f"{folder}: not a puzzle folder (no puzzle.json)")
    engines = ["WORKBENCH", "CYCLES"] if engine == "auto" else [engine.upper()]
    started = time.perf_counter()
    rendered: list[RenderedPuzzle] = []
    remaining = list(folders)
    failures: list[str] = []
    for engine_name in engines:
        if not remaining:
            break
        done, failures = _run_workers(remaining, engine_name, size, views, workers, on_done)
        rendered += done
        finished = {r.folder for r in done}
        remaining = [f for f in remaining if f not in finished]
    if remaining:
        raise RenderError(f"could not render {[str(f) for f in remaining]}: " + " | ".join(failures))
    return RenderReport(tuple(rendered), time.perf_counter() - started, tuple(failures))


def _run_workers(folders: list[Path], engine: str, size: tuple[int, int], views: Sequence[str], workers: int,
                 on_done: Callable[[RenderedPuzzle], None] | None) -> tuple[list[RenderedPuzzle], list[str]]:
    shares = [folders[i::workers] for i in range(min(workers, len(folders)))]
    with tempfile.TemporaryDirectory(prefix="phyrogen-render-") as home:
        environment = dict(os.environ)
        # Blender would otherwise write its configuration under the user's home folder.
        environment["BLENDER_USER_CONFIG"] = str(Path(home) / "config")
        environment["BLENDER_USER_RESOURCES"] = str(Path(home) / "resources")
        environment["PYTHONPATH"] = os.pathsep.join([str(Path(__file__).resolve().parent.parent),
                                                    environment.get("PYTHONPATH", "")]).rstrip(os.pathsep)
        processes = []
        for share in shares:
            command = [worker_python(), "-m", "blender_addon.render_worker", "--engine", engine,
                       "--size", f"{size[0]}x{size[1]}", "--views", ",".join(views), *map(str, share)]
            log = tempfile.TemporaryFile(mode="w+", dir=home)
            processes.append((subprocess.Popen(command, stdout=subprocess.PIPE, stderr=log, text=True,
                                               env=environment), log))
        done: list[RenderedPuzzle] = []
        failures: list[str] = []
        # Reading one worker to its end at a time cannot block the others: they log to files.
        for process, log in processes:
            assert process.stdout is not None
            for line in process.stdout:
                if line.startswith("RENDERED "):
                    folder, seconds, images = line[len("RENDERED "):].rsplit(" ", 2)
                    result = RenderedPuzzle(Path(folder), engine.lower(), float(seconds), int(images))
                    done.append(result)
                    if on_done is not None:
                        on_done(result)
            process.wait()
            log.seek(0)
            stderr = log.read()
            log.close()
            if process.returncode != 0:
                tail = stderr.strip().splitlines()[-3:]
                failures.append(f"{engine.lower()} worker exited with {process.returncode}: " + " / ".join(tail))
        return done, failures

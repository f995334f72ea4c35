"""Execute several puzzle folders, with progress, outputs and a summary table."""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

from phyrogen_core.atomic_writes import OutputError, require_writable_dir, write_file_atomic
from phyrogen_core.errors import PuzzleFormatError
from phyrogen_core.export import read_puzzle_dir
from phyrogen_core.folder_layout import METADATA_FILE
from solver.parallel.pool import deferred_signals
from solver.planning.problem import verify_certificate

from .execution import ExecutionSettings, ManipulationReport, execute_puzzle, scene_placement
from .outputs import summary_table, write_outputs
from .solution import BenchmarkRun, candidate_solutions


def manipulate_folders(folders: Sequence[Path], out_root: Path, video: bool = True, table: Path | None = None,
                       gui: bool = False, quiet: bool = False, settings: ExecutionSettings | None = None,
                       runs: Mapping[Path, Sequence[BenchmarkRun]] | None = None) -> list[ManipulationReport]:
    """Execute each puzzle folder, write its outputs under ``out_root``, print one line per puzzle.

    ``runs``: per folder, the benchmark's solved LA-RRT runs on that puzzle; the
    least-costly are tried before the certificate (:func:`~manipulation.solution.candidate_solutions`).
    Raises, before any simulation, :func:`check_inputs`' errors.
    """
    from tqdm import tqdm

    runs = runs or {}
    settings = settings or ExecutionSettings()
    check_inputs(folders, out_root, table, runs, settings)
    reports = []
    for folder in folders:
        with tqdm(total=1, desc=Path(folder).name, unit="action", disable=quiet, file=sys.stderr,
                  leave=False) as bar:

            def progress(done: int, total: int, bar=bar) -> None:
                bar.total = total
                bar.n = done
                bar.refresh()

            report, recording, setup = execute_puzzle(Path(folder), settings, gui, progress,
                                                      runs.get(Path(folder), ()))
        # Ctrl-C or SIGTERM while a simulated puzzle's outputs are written takes effect once they
        # are, and reported (seconds): an interrupted write would feed ffmpeg a torn frame, which
        # it reports on stderr, and lose a finished simulation.
        with deferred_signals():
            bar_output = write_outputs(out_root, report, recording, setup, video=video)
            reports.append(report)
            status = "ok" if report.success else "FAILED: " + report.message
            print(f"{report.puzzle:22s} actions {report.actions:3d} regrasps {report.regrasps:2d} "
                  f"planning {report.planning_seconds:6.1f} s execution {report.execution_seconds:6.1f} s "
                  f"{report.solution} ({report.solutions_tried} tried) {status}  -> {bar_output}", flush=True)
    if table is not None:
        # Whole or not at all, and into the file a link names (the user's link stays).
        write_file_atomic(os.path.realpath(table), summary_table(reports).encode("utf-8"))
    return reports


def check_inputs(folders: Sequence[Path], out_root: Path, table: Path | None = None,
                 runs: Mapping[Path, Sequence[BenchmarkRun]] | None = None,
                 settings: ExecutionSettings | None = None) -> None:
    """Everything a run reads and writes, checked before the first simulation: a bad folder or
    output path found after an hour of simulating others is bad input found too late.

    Every folder must read (puzzle and solutions, ``runs`` included) and fit the base's floor at
    its scale (:func:`~manipulation.execution.scene_placement`); ``out_root``, the folder of
    ``table`` and ``<out_root>/<puzzle>`` must be writable as folders
    (``table`` as a file). Raises :class:`~phyrogen_core.folder.PuzzleFormatError`
    or :class:`~phyrogen_core.folder.OutputError`, one line naming the path, or ValueError naming
    a puzzle too large for the base's floor at its scale.
    """
    from phyrogen_core.atomic_writes import require_stage_folder

    runs = runs or {}
    settings = settings or ExecutionSettings()
    out_root = require_writable_dir(out_root, "manipulation output folder")
    if table is not None:
        table = Path(table)
        if table.is_dir():
            raise OutputError(f"summary table {table} is a folder; name a file")
        if table.exists() and not table.is_file():  # a FIFO would block the write forever, a device take it
            raise OutputError(f"summary table {table} is a FIFO, device or socket, not a regular file; name a file")
        if os.path.lexists(table) and not os.access(table, os.W_OK):
            raise OutputError(f"summary table {table}: no permission to write it")
        require_writable_dir(table.parent, f"folder of the summary table {table}:")
    for folder in folders:
        loaded = read_puzzle_dir(folder)
        if loaded.certificate:
            # The robot may fall back to the certificate: one that ``phyrogen check`` refuses (it
            # crosses other objects, it does not begin at the start) is bad input, not a plan.
            problems = verify_certificate(loaded.chain, loaded.certificate, loaded.goal, start=loaded.start)
            if problems:
                raise PuzzleFormatError(f"{Path(folder) / METADATA_FILE}: the certificate is not valid "
                                        f"(phyrogen check): {problems[0]}")
        for solution in candidate_solutions(Path(folder), loaded, runs.get(Path(folder), ())):
            scene_placement(loaded, solution.path, settings)
        target = out_root / loaded.name
        if os.path.lexists(target) and not target.is_symlink() and not target.is_dir():
            raise OutputError(f"{target} is not a folder; the outputs of puzzle {target.name} go there")
        require_stage_folder(target, "manipulation output folder")  # a link would be swapped away

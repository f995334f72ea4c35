"""Execute several puzzle folders, with progress, outputs and a summary table."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from .execution import ExecutionSettings, ManipulationReport, execute_puzzle
from .outputs import summary_table, write_outputs

OMPL_SEED = 1
"""BIT* draws from OMPL's global generator, seeded once per process."""


def manipulate_folders(folders: Sequence[Path], out_root: Path, video: bool = True, table: Path | None = None,
                       gui: bool = False, quiet: bool = False,
                       settings: ExecutionSettings | None = None) -> list[ManipulationReport]:
    """Execute each puzzle folder, write its outputs under ``out_root``, print one line per puzzle."""
    from tqdm import tqdm

    from .reaching import seed_reaching

    settings = settings or ExecutionSettings()
    seed_reaching(OMPL_SEED)
    reports = []
    for folder in folders:
        with tqdm(total=1, desc=Path(folder).name, unit="action", disable=quiet, file=sys.stderr,
                  leave=False) as bar:

            def progress(done: int, total: int, bar=bar) -> None:
                bar.total = total
                bar.n = done
                bar.refresh()

            report, recording, setup = execute_puzzle(Path(folder), settings, gui=gui, progress=progress)
        bar_output = write_outputs(out_root, report, recording, setup, video=video)
        reports.append(report)
        status = "ok" if report.success else "FAILED: " + report.message
        print(f"{report.puzzle:22s} actions {report.actions:3d} regrasps {report.regrasps:2d} "
              f"planning {report.planning_seconds:6.1f} s execution {report.execution_seconds:6.1f} s "
              f"{status}  -> {bar_output}", flush=True)
    if table is not None:
        table.parent.mkdir(parents=True, exist_ok=True)
        table.write_text(summary_table(reports), encoding="utf-8")
    return reports

"""Per-puzzle output folders (frames, video, report) and the summary table."""

from __future__ import annotations

import dataclasses
import json
import re
from collections.abc import Sequence
from pathlib import Path

from phyrogen_core.stage_writes import owned_directory

from .execution_records import ManipulationReport, Recording, SceneSetup
from .media import Renderer, write_frames, write_grip_frames, write_video


def write_outputs(out_root: Path, report: ManipulationReport, recording: Recording, setup: SceneSetup,
                  video: bool = True) -> Path:
    """``<out_root>/<puzzle>/``: frames/frame_1..4.png, frames/grip_<k>.png (the fingers on the handle
    in action k), <puzzle>.mp4, report.json (written atomically)."""
    final = Path(out_root) / report.puzzle
    with owned_directory(final, lambda path: owns_output(report.puzzle, path)) as folder:
        if recording.robot:  # a puzzle refused before any simulation has nothing to show
            with Renderer(setup) as renderer:
                write_frames(renderer, recording, folder / "frames")
                write_grip_frames(renderer, recording, folder / "frames")
                if video:
                    write_video(renderer, recording, folder / f"{report.puzzle}.mp4")
        (folder / "report.json").write_text(report_json(report), encoding="utf-8")
    return final


def owns_output(puzzle: str, path: str) -> bool:
    """Whether ``path`` (inside ``<out_root>/<puzzle>/``) is a file :func:`write_outputs` writes: only
    these are replaced, and any other file a user keeps there stays."""
    return path in ("report.json", f"{puzzle}.mp4") or re.fullmatch(r"frames/(frame|grip)_\d+\.png", path) is not None


def report_json(report: ManipulationReport) -> str:
    return json.dumps(dataclasses.asdict(report), indent=2, sort_keys=True) + "\n"


TABLE_HEADER = ("| puzzle | solution | scale | actions | regrasps | benchmark [s] | planning [s] | execution [s] | "
                "total [s] | simulated [s] | max penetration [mm] | result |")


def summary_table(reports: Sequence[ManipulationReport]) -> str:
    """A Markdown table, one row per puzzle, and a closing line with counts and the median total time
    (planning and execution; the short benchmark's wall time is its own column)."""
    lines = [TABLE_HEADER, "|" + "---|" * TABLE_HEADER.count(" | ") + "---|"]
    for r in reports:
        total = r.planning_seconds + r.execution_seconds
        result = "success" if r.success else "FAILED: " + r.message.replace("|", "/")
        solution = r.solution if r.solutions_tried == 1 else f"{r.solution} ({r.solutions_tried} tried)"
        lines.append(f"| {r.puzzle} | {solution} | {r.scale:.3f} | {r.actions} | {r.regrasps} | "
                     f"{r.benchmark_seconds:.1f} | {r.planning_seconds:.1f} | {r.execution_seconds:.1f} | "
                     f"{total:.1f} | {r.simulated_seconds:.1f} | {r.max_penetration * 1000:.2f} | {result} |")
    if reports:
        totals = sorted(r.planning_seconds + r.execution_seconds for r in reports)
        middle = len(totals) // 2
        median = totals[middle] if len(totals) % 2 else (totals[middle - 1] + totals[middle]) / 2
        ok = sum(r.success for r in reports)
        lines += ["", f"{ok}/{len(reports)} executed successfully; planning + execution per puzzle: "
                      f"median {median:.1f} s, range {totals[0]:.1f}-{totals[-1]:.1f} s."]
    return "\n".join(lines) + "\n"

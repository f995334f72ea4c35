"""``export``: other formats written into puzzle folders."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from .base import StageRequest, StageResult


@dataclass(frozen=True)
class ExportRequest(StageRequest):
    STAGE = "export"

    folders: tuple[str, ...]
    """Puzzle folders, or folders of generated puzzles (all of them)."""
    format: Literal["mjcf"] = "mjcf"
    """mjcf: MuJoCo, ``<folder>/mjcf/<name>.xml``."""

    def problem(self) -> str | None:
        return None if self.folders else "'folders' names no folder"


@dataclass(frozen=True)
class ExportResult(StageResult):
    STAGE = "export"

    files: tuple[str, ...]
    """The files written, one per puzzle folder."""

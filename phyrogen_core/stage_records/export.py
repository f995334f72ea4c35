"""``export``: other formats written into puzzle folders."""

from __future__ import annotations

from typing import Literal

from .base import StageResult
from .shared import FoldersRequest


class ExportRequest(FoldersRequest, stage="export"):
    format: Literal["mjcf"] = "mjcf"
    """mjcf: MuJoCo, ``<folder>/mjcf/<name>.xml``."""


class ExportResult(StageResult, stage="export"):
    files: tuple[str, ...]
    """The files written, one per puzzle folder."""

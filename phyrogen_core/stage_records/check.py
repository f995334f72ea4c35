"""``check``: a puzzle folder's certificate checked again at fine resolution."""

from __future__ import annotations

from .base import Count
from .shared import FolderRequest, PuzzleResult


class CheckRequest(FolderRequest, stage="check"):
    """``folder``: the puzzle folder."""


class CheckResult(PuzzleResult, stage="check"):
    folder: str
    states: Count
    """States of the certificate checked."""
    edited: bool
    """The puzzle was edited after its certificate was found (the panel's Export keeps the old one)."""
    problems: tuple[str, ...]
    """What is wrong with the certificate; empty when it is valid."""

    @property
    def valid(self) -> bool:
        return not self.problems

    def done(self) -> bool:
        return self.valid

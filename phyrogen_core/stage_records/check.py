"""``check``: a puzzle folder's certificate checked again at fine resolution."""

from __future__ import annotations

from dataclasses import dataclass

from .base import Count, StageRequest, StageResult


@dataclass(frozen=True)
class CheckRequest(StageRequest):
    STAGE = "check"

    folder: str
    """The puzzle folder."""


@dataclass(frozen=True)
class CheckResult(StageResult):
    STAGE = "check"

    puzzle: str
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

    @property
    def exit_code(self) -> int:
        return 0 if self.valid else 1

"""Bases of the fields several stages' records share, declared once (each a frozen dataclass, as
:class:`~.base.StageRecord` makes every subclass)."""

from __future__ import annotations

from .base import Count, StageRequest, StageResult


class FolderRequest(StageRequest):
    """A request about one folder: a puzzle folder or, where the stage says so, a folder of them."""

    folder: str


class FoldersRequest(StageRequest):
    """A request about puzzle folders, at least one."""

    folders: tuple[str, ...]
    """Puzzle folders, or folders of generated puzzles (all of them)."""

    def problem(self) -> str | None:
        return None if self.folders else "'folders' names no folder"


class OutputResult(StageResult):
    """A result of a stage that wrote into an output folder of its own."""

    out: str
    """The output folder."""


class TimedResult(StageResult):
    """A result of a stage run over many puzzles, their work timed whole."""

    wall_seconds: float
    """Wall-clock seconds the puzzles took, from the first started to the last done."""


class PuzzleResult(StageResult):
    """A result about one puzzle."""

    puzzle: str
    """The puzzle's name."""


class SearchResult(PuzzleResult):
    """A search by planners for a puzzle's certificate within a budget of collision queries; done when
    one was found."""

    solved: bool
    budget: Count
    seed: int
    notices: tuple[str, ...]
    """What writing the folder did beside (old outputs moved away)."""

    def done(self) -> bool:
        return self.solved

"""The error of a puzzle folder that cannot be trusted, in a module of its own so that the folder
(:mod:`phyrogen_core.folder`) and ``puzzle.json``'s record (:mod:`phyrogen_core.record`) both raise it
without importing each other."""


class PuzzleFormatError(ValueError):
    """A puzzle folder, its ``puzzle.json``, its URDF or a mesh is missing or malformed."""

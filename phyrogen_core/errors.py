"""The error of a puzzle folder that cannot be trusted, in a module of its own so that the folder
(:mod:`phyrogen_core.folder`) and ``puzzle.json``'s record (:mod:`phyrogen_core.record`) both raise it
without importing each other."""


class PuzzleFormatError(ValueError):
    """A puzzle folder, its ``puzzle.json``, its URDF or a mesh is missing or malformed."""


def one_line(exc: BaseException) -> str:
    """``exc``'s message on one line (its type's name when it has none): for one-line error reports."""
    return " ".join(str(exc).split()) or type(exc).__name__


def os_reason(exc: BaseException) -> str:
    """Why an operating-system call failed, in the system's words (``Permission denied``), else :func:`one_line`."""
    return exc.strerror if isinstance(exc, OSError) and exc.strerror else one_line(exc)

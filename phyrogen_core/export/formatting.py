"""Text conventions shared by the URDF, SRDF and OBJ writers.

Numbers are written as the shortest decimal that reads back to the same
float (Python's ``repr``), so a written chain parses back *exactly*, and the
same chain always gives the same bytes. ``-0.0`` is written as ``0`` so that
values which differ only in the sign of zero do not change the output.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from xml.sax.saxutils import escape


def number(value: float) -> str:
    """``value`` as the shortest text that round-trips; integers without ``.0``."""
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"cannot write {value!r}: only finite numbers are valid in URDF, SRDF and OBJ")
    if value == 0.0:
        return "0"
    text = repr(value)
    return text[:-2] if text.endswith(".0") else text


def numbers(values: Iterable[float]) -> str:
    """Space-separated :func:`number` texts, as URDF vectors are written."""
    return " ".join(number(v) for v in values)


def attribute(value: str) -> str:
    """``value`` quoted for an XML attribute, always with double quotes."""
    return '"' + escape(str(value), {'"': "&quot;", "\n": "&#10;", "\t": "&#9;"}) + '"'

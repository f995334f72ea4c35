"""Text for the sidebar, whose labels neither wrap nor scroll (no bpy here)."""

from __future__ import annotations

import re


def wrap_lines(text: str, width: int, indent: str = "") -> list[str]:
    """``text`` in lines of at most ``width`` characters, broken at spaces; a word longer than a line (a
    path) is broken only after a ``/``, so that no folder's or file's name is split, unless the name alone
    is longer than a line: then after an ``_`` or ``-`` in it. ``indent`` starts every line but the first.
    A piece without such a place that is longer than a line stays whole on a line of its own."""
    pieces: list[tuple[str, bool]] = []  # (piece, whether it continues the previous piece's word)
    for word in text.split():
        parts = [word] if len(word) <= width else re.findall(r"[^/]+/*|/+", word)
        # A name longer than a line itself: after its underscores or hyphens (Blender would cut it).
        parts = [piece for part in parts
                 for piece in ([part] if len(part) <= width else re.findall(r"[^_-]+[_-]*|[_-]+", part))]
        pieces.extend((part, index > 0) for index, part in enumerate(parts))
    lines: list[str] = []
    line = ""
    for piece, continued in pieces:
        joined = line + ("" if continued or not line else " ") + piece
        if line and line != indent and len(joined) > width:
            lines.append(line)
            line = indent + piece
        else:
            line = joined
    if line:
        lines.append(line)
    return lines

"""The sidebar's wrapped text (``blender_addon/text.py``): no folder's or file's name is split."""

from __future__ import annotations

import pytest

from blender_addon.text import wrap_lines

MESSAGE = ("simple_slider_1: written to /home/researcher/projects/phyrogen-output/simple_slider/simple_slider_1; "
           "Blender's untouched default cube removed (it hid the puzzle)")


@pytest.mark.parametrize("width", [20, 27, 33, 48, 80])
def test_paths_break_only_after_a_slash(width):
    lines = wrap_lines(MESSAGE, width, "  ")
    assert all(len(line) <= width for line in lines), lines
    # Read back (indents and the spaces between words dropped), the text is the message, and every line
    # of a path but its last ends at a folder's slash: no name is split.
    assert "".join(line.strip() for line in lines).replace(" ", "") == MESSAGE.replace(" ", "")
    names = "/home/researcher/projects/phyrogen-output/simple_slider/simple_slider_1;".split("/")
    for line in lines:
        for piece in line.strip().split(" "):
            if "/" in piece:
                assert all(part in names or part == "" for part in piece.split("/")), (piece, lines)


def test_a_name_longer_than_a_line_breaks_after_its_underscores_or_stays_whole():
    assert wrap_lines("see /a/" + "x" * 30 + "/b", 12) == ["see /a/", "x" * 30 + "/", "b"]
    assert wrap_lines("in /tmp/test_panel_generate_replan_man0/output", 22, "  ") == [
        "in /tmp/test_panel_", "  generate_replan_", "  man0/output"]


def test_the_old_wrapping_split_names():
    """The control: textwrap, which the panel used, splits a path inside a folder's name."""
    import textwrap

    lines = textwrap.wrap(MESSAGE, 27, subsequent_indent="  ", break_on_hyphens=False)
    names = set("/home/researcher/projects/phyrogen-output/simple_slider/simple_slider_1;".split("/"))
    assert any(part not in names and part for line in lines for piece in line.split() if "/" in piece
               for part in piece.split("/"))

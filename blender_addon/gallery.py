"""The HTML gallery of an output folder, laid out like the paper's Fig. 3.

Generators are columns (the paper's order first), seeds are rows; each cell
shows the puzzle's oblique view and links its other views, URDF, puzzle.json
and .blend. Where the puzzle has a solution animation, it plays in place of
the still while the pointer is over it, a click keeps it playing (or stops
it), and ``index.html#play`` plays them all. Paths are relative, so the folder
can be moved or served as is.
"""

from __future__ import annotations

import html
import os
import tempfile
from pathlib import Path

from phyrogen_core.folder import OutputError, PuzzleFolder, find_puzzle_folders

from .views import DEFAULT_VIEWS, GALLERY_VIEW, VIEWS, animation_name, image_name

GALLERY_FILE = "index.html"
GALLERY_MARKER = '<meta name="generator" content="phyrogen render gallery">'
"""The line every gallery page holds, as ``audit.json`` its ``format`` key: the page at an output
root is replaced only when it carries it, so a user's own ``index.html`` there is never overwritten."""


EARLIER_GALLERY_HEAD = (b'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
                        b"<title>PhyRoGen puzzles</title>\n")
"""How the pages of versions before the marker begin, exactly: an existing output/index.html of
``scripts/paper.sh`` is still replaced."""


def check_gallery_target(out_root: str | Path) -> Path:
    """``<out_root>/index.html``, checked before any work: missing, or a regular file (not a link)
    that holds :data:`GALLERY_MARKER` within its first 4 KiB (or begins exactly as an earlier
    version's page, :data:`EARLIER_GALLERY_HEAD`). Raises
    :class:`~phyrogen_core.folder.OutputError` naming the file otherwise."""
    target = Path(out_root) / GALLERY_FILE
    if not os.path.lexists(target):
        return target
    if target.is_symlink() or not target.is_file():
        raise OutputError(f"{target} is not a gallery page phyrogen render wrote (a link or not a file); "
                          "move it, or render into another folder")
    try:
        with open(target, "rb") as stream:
            head = stream.read(4096)
    except OSError as exc:
        raise OutputError(f"{target} cannot be read: {exc.strerror or exc}") from None
    if GALLERY_MARKER.encode() not in head and not head.startswith(EARLIER_GALLERY_HEAD):
        raise OutputError(f"{target} was not written by phyrogen render (no gallery marker); move it, or render "
                          "into another folder, and the gallery is written there")
    return target


def write_gallery(out_root: str | Path, views: tuple[str, ...] = DEFAULT_VIEWS) -> Path:
    """Write ``<out_root>/index.html`` (atomically) and return its path."""
    root = Path(out_root)
    cells: dict[tuple[str, int], PuzzleFolder] = {}
    try:
        found = find_puzzle_folders(root)
    except FileNotFoundError:
        found = []
    for folder in found:  # in the registry's generator order
        cells[(folder.generator, folder.seed)] = folder  # both as its puzzle.json states them
    generators = list(dict.fromkeys(g for g, _ in cells))
    seeds = sorted({s for _, s in cells})
    titles = _titles()
    rows = []
    for seed in seeds:
        row = [f'<th class="seed">Seed {seed}</th>']
        for generator in generators:
            folder = cells.get((generator, seed))
            row.append("<td></td>" if folder is None else _cell(root, folder, titles.get(generator, generator),
                                                               seed, views))
        rows.append("<tr>" + "".join(row) + "</tr>")
    header = "".join(f"<th>{html.escape(titles.get(g, g))}</th>" for g in generators)
    page = _PAGE.format(marker=GALLERY_MARKER, count=len(cells), header=header, rows="\n".join(rows))
    target = check_gallery_target(root)
    descriptor, temporary = tempfile.mkstemp(prefix=".index.", suffix=".html.tmp", dir=root)
    with os.fdopen(descriptor, "w", encoding="utf-8") as stream:
        stream.write(page)
    os.chmod(temporary, 0o644)
    os.replace(temporary, target)
    return target


def _cell(root: Path, folder: PuzzleFolder, title: str, seed: int, views: tuple[str, ...]) -> str:
    name = folder.name

    def relative(path: Path) -> str:
        return path.relative_to(root).as_posix()

    images = [(VIEWS[v].title, relative(folder.images / image_name(name, i))) for i, v in enumerate(views)]
    present = [(t, p) for t, p in images if (root / p).is_file()]
    shown = dict(zip(views, images, strict=True)).get(GALLERY_VIEW, images[0] if images else None)
    animation = relative(folder.images / animation_name(name))
    has_animation = (root / animation).is_file()
    if shown is not None and (root / shown[1]).is_file():
        still = f'<img class="still" src="{html.escape(shown[1])}" alt="{html.escape(name)}">'
        if has_animation:
            picture = (f'<div class="picture" data-animation="{html.escape(animation)}" tabindex="0" '
                       f'title="hover or click: the solution">{still}'
                       f'<img class="solution" alt="{html.escape(name)}: solution" hidden>'
                       '<span class="badge">&#9654; solution</span></div>')
        else:
            picture = f'<a href="{html.escape(shown[1])}">{still}</a>'
    else:
        picture = '<div class="missing">not rendered</div>'
    links = [f'<a href="{html.escape(p)}">{html.escape(t)}</a>' for t, p in present]
    if has_animation:
        links.append(f'<a href="{html.escape(animation)}">solution</a>')
    links.append(f'<a href="{html.escape(relative(folder.urdf))}">URDF</a>')
    links.append(f'<a href="{html.escape(relative(folder.metadata))}">metadata</a>')
    if folder.blend.is_file():
        links.append(f'<a href="{html.escape(relative(folder.blend))}">.blend</a>')
    caption = f"{html.escape(title)} {seed}"
    return f'<td><figure>{picture}<figcaption>{caption}<br>{" · ".join(links)}</figcaption></figure></td>'


def _titles() -> dict[str, str]:
    from phyrogen_core.registry import all_generators

    return {name: spec.title for name, spec in all_generators().items()}


_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
{marker}
<title>PhyRoGen puzzles</title>
<style>
body {{ font-family: sans-serif; margin: 1em; background: #fff; color: #222; }}
table {{ border-collapse: collapse; width: 100%; }}
th {{ font-weight: 600; padding: 4px; }}
th.seed {{ writing-mode: vertical-rl; transform: rotate(180deg); white-space: nowrap; }}
td {{ padding: 4px; vertical-align: top; }}
figure {{ margin: 0; text-align: center; }}
/* Pictures shrink with the window (up to 240 px), so that the six columns fit without sideways scrolling. */
img {{ width: 100%; max-width: 240px; height: auto; display: block; border: 1px solid #ccc; box-sizing: border-box; }}
.picture {{ position: relative; cursor: pointer; }}
.picture img.solution {{ position: absolute; left: 0; top: 0; }}
.picture img.solution[hidden] {{ display: none; }}
.badge {{ position: absolute; right: 4px; bottom: 4px; font-size: 11px; padding: 1px 5px; border-radius: 3px;
          background: rgba(0, 0, 0, 0.55); color: #fff; pointer-events: none; }}
.picture.playing .badge {{ background: rgba(30, 120, 40, 0.85); }}
figcaption {{ font-size: 12px; margin-top: 2px; }}
.missing {{ width: 100%; max-width: 240px; height: 180px; line-height: 180px; background: #eee; color: #888; }}
</style>
</head>
<body>
<h1>PhyRoGen puzzles</h1>
<p>{count} puzzles. Generators as columns, seeds as rows (as in the paper's Fig. 3). The goal of each
green target is shown as a translucent green copy. Point at a puzzle to watch its solution, click to keep it
playing; <a href="#play" onclick="setTimeout(() => location.reload())">play all</a>.</p>
<table>
<tr><th></th>{header}</tr>
{rows}
</table>
<script>
function play(picture, on) {{
  const solution = picture.querySelector("img.solution");
  if (on && !solution.getAttribute("src")) solution.src = picture.dataset.animation;  // from its first frame
  if (!on) solution.removeAttribute("src");
  solution.hidden = !on;
  picture.classList.toggle("playing", on);
}}
const pictures = document.querySelectorAll(".picture[data-animation]");
for (const picture of pictures) {{
  picture.addEventListener("mouseenter", () => play(picture, true));
  picture.addEventListener("mouseleave", () => play(picture, picture.classList.contains("pinned")));
  picture.addEventListener("click", () => play(picture, picture.classList.toggle("pinned")));
  picture.addEventListener("keydown", (e) => {{
    if (e.key === "Enter" || e.key === " ") {{ e.preventDefault(); picture.click(); }}
  }});
}}
if (location.hash === "#play") {{
  for (const picture of pictures) {{ picture.classList.add("pinned"); play(picture, true); }}
}}
window.addEventListener("load", () => {{
  // How many animations the browser decoded: tests read it from the page.
  const shown = [...document.querySelectorAll("img.solution")].filter((i) => !i.hidden && i.naturalWidth > 0);
  document.body.dataset.animationsShown = String(shown.length);
  document.body.dataset.animations = String(pictures.length);
}});
</script>
</body>
</html>
"""

"""The docs index, docs/README.md, lists every page, and no relative link in the docs leads nowhere.

The rule for a page under docs/ (``*.md``, docs/README.md itself aside): a page directly in docs/
must be linked from docs/README.md; a page in a subfolder (docs/benchmark/, docs/manipulation/)
must be linked from docs/README.md or from its own folder's README.md, which must be linked from
docs/README.md. Every page must also be reachable from the project's README.md by following links.

A relative link (``[text](path)`` or ``![alt](path)``, outside code) in README.md or any page under
docs/ must name a file or folder that exists; ``path#anchor`` into a Markdown file must name one
of its headings (as GitHub makes anchors of them). Web links are not followed.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
INDEX = Path("docs/README.md")

_FENCE = re.compile(r"^(```|~~~).*?^\1[^\n]*$", re.MULTILINE | re.DOTALL)
_CODE_SPAN = re.compile(r"`[^`\n]*`")
_LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_EXTERNAL = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:")  # https:, mailto:, ...


def _prose(text: str) -> str:
    return _CODE_SPAN.sub("", _FENCE.sub("", text))


def _links(path: Path) -> list[str]:
    return [m[1] for m in _LINK.finditer(_prose(path.read_text()))]


def _anchors(path: Path) -> set[str]:
    """GitHub's heading anchors: lower case, punctuation dropped, spaces to hyphens, -1, -2 for repeats."""
    seen: dict[str, int] = {}
    anchors = set()
    for line in _FENCE.sub("", path.read_text()).splitlines():
        heading = re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line)
        if heading:
            slug = re.sub(r"[^\w\- ]", "", heading[1].strip().lower()).replace(" ", "-")
            count = seen.get(slug, 0)
            seen[slug] = count + 1
            anchors.add(slug if count == 0 else f"{slug}-{count}")
    return anchors


def _pages(root: Path) -> list[Path]:
    """README.md and every Markdown page under docs/, relative to ``root``."""
    docs = sorted(p.relative_to(root) for p in (root / "docs").rglob("*.md"))
    return [Path("README.md"), *docs]


def _targets(root: Path, page: Path) -> set[Path]:
    """The files under ``root`` that ``page`` links to (existing ones, relative to ``root``)."""
    found = set()
    for link in _links(root / page):
        if _EXTERNAL.match(link) or link.startswith("#"):
            continue
        target = (root / page).parent / link.split("#", 1)[0]
        if target.exists():
            found.add(Path(target.resolve().relative_to(root.resolve())))
    return found


def broken_links(root: Path) -> list[str]:
    """``page: link`` for each relative link that names no file, or no heading of its file."""
    broken = []
    for page in _pages(root):
        for link in _links(root / page):
            if _EXTERNAL.match(link):
                continue
            path, _, anchor = link.partition("#")
            target = (root / page).parent / path if path else root / page
            if not target.exists():
                broken.append(f"{page}: {link} (no such file)")
            elif anchor and target.suffix == ".md" and anchor not in _anchors(target):
                broken.append(f"{page}: {link} (no such heading)")
    return broken


def unlisted_docs(root: Path) -> list[str]:
    """The pages under docs/ that the index does not list (see the module docstring)."""
    listed = _targets(root, INDEX) if (root / INDEX).exists() else set()
    missing = []
    for page in _pages(root)[1:]:
        if page == INDEX or page in listed:
            continue
        folder_index = page.parent / "README.md"
        in_subfolder = page.parent != INDEX.parent and page != folder_index
        if in_subfolder and folder_index in listed and page in _targets(root, folder_index):
            continue
        missing.append(str(page))
    return missing


def unreachable_docs(root: Path) -> list[str]:
    """The pages under docs/ that no chain of links from README.md reaches."""
    reached, todo = {Path("README.md")}, [Path("README.md")]
    while todo:
        for target in _targets(root, todo.pop()):
            if target.suffix == ".md" and target not in reached:
                reached.add(target)
                todo.append(target)
    return [str(page) for page in _pages(root)[1:] if page not in reached]


def test_the_index_lists_every_page_under_docs():
    assert unlisted_docs(ROOT) == []


def test_no_relative_link_in_the_docs_leads_nowhere():
    assert broken_links(ROOT) == []


def test_every_page_is_reachable_from_the_readme():
    assert INDEX in _targets(ROOT, Path("README.md"))
    assert unreachable_docs(ROOT) == []


def _plant(root: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    return root


def test_the_checks_catch_an_unlisted_page_a_missing_file_and_a_missing_heading(tmp_path):
    root = _plant(tmp_path, {
        "README.md": "# P\n\n[docs](docs/README.md)\n",
        "docs/README.md": "# Index\n\n- [a](a.md)\n- [results](results/README.md)\n",
        "docs/a.md": "# A\n\n## Some heading\n\n[ok](#some-heading) [gone](gone.md) [bad](a.md#no-heading)\n"
                     "`[in code](ignored.md)`\n\n```\n[in a fence](ignored.md)\n```\n",
        "docs/unlisted.md": "# Not in the index\n",
        "docs/results/README.md": "# Results\n\n[table](table.md)\n",
        "docs/results/table.md": "| a |\n",
        "docs/results/orphan.md": "| b |\n",
    })
    assert unlisted_docs(root) == ["docs/results/orphan.md", "docs/unlisted.md"]
    assert broken_links(root) == ["docs/a.md: gone.md (no such file)", "docs/a.md: a.md#no-heading (no such heading)"]
    assert unreachable_docs(root) == ["docs/results/orphan.md", "docs/unlisted.md"]
    (root / "docs/a.md").write_text("# A\n")
    (root / "docs/README.md").write_text("# Index\n\n[a](a.md) [u](unlisted.md) [r](results/README.md) "
                                         "[o](results/orphan.md)\n")
    assert (unlisted_docs(root), broken_links(root), unreachable_docs(root)) == ([], [], [])

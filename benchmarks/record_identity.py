"""Compare two output folders of ``phyrogen generate`` file by file, and read every ``puzzle.json``
of the second back through :class:`phyrogen_core.record.PuzzleRecord`.

Used when ``puzzle.json`` got its typed owner: the folders generated before and after the change
must be byte-identical, and ``PuzzleRecord.to_json()`` must give each file's text back.

    python benchmarks/record_identity.py BEFORE AFTER [--beside-necessity]

Prints the number of files compared and every difference; exits 1 when there is one. With
``--beside-necessity`` two ``puzzle.json`` also count as the same when they differ only by what format
4 added (``format_version`` and the objects' ``necessity``): for comparing puzzles generated before
that key came with those generated after; every other file must still be byte-identical.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from phyrogen_core.export import read_puzzle_dir


def _beside_necessity(path: Path) -> object:
    data = json.loads(path.read_text(encoding="utf-8"))
    data.pop("format_version", None)
    for entry in data.get("objects", []):
        entry.pop("necessity", None)
    return data


def _same(before: Path, after: Path, beside_necessity: bool) -> bool:
    if before.read_bytes() == after.read_bytes():
        return True
    return beside_necessity and before.name == "puzzle.json" and _beside_necessity(before) == _beside_necessity(after)


def compare(before: Path, after: Path, beside_necessity: bool = False) -> list[str]:
    """Every difference between the trees ``before`` and ``after``, and every ``puzzle.json`` under
    ``after`` that the record does not write back byte for byte."""
    old = {p.relative_to(before) for p in before.rglob("*") if p.is_file()}
    new = {p.relative_to(after) for p in after.rglob("*") if p.is_file()}
    problems = [f"only in {before}: {p}" for p in sorted(old - new)]
    problems += [f"only in {after}: {p}" for p in sorted(new - old)]
    problems += [f"differs: {p}" for p in sorted(old & new) if not _same(before / p, after / p, beside_necessity)]
    for path in sorted(after.rglob("puzzle.json")):
        if read_puzzle_dir(path.parent).record.to_json() != path.read_text(encoding="utf-8"):
            problems.append(f"the record does not write back: {path}")
    print(f"{len(old | new)} files compared, {len(list(after.rglob('puzzle.json')))} puzzle.json read back")
    return problems


def main(argv: list[str]) -> int:
    beside = "--beside-necessity" in argv
    argv = [a for a in argv if a != "--beside-necessity"]
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    problems = compare(Path(argv[0]), Path(argv[1]), beside)
    for line in problems:
        print(line)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

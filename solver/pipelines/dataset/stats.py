"""``phyrogen dataset --stats``: what a dataset holds, as text and as a figure.

Per generator: entries, puzzles made, failures, distinct puzzles (by the
canonical hash, which ignores object names and order) and distinct puzzles
per 1,000 seeds; then histograms of the difficulty columns (movable objects,
actions, dependency depth), drawn as text and into ``<root>/plots/difficulty.png``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from phyrogen_core.folder import atomic_file
from phyrogen_core.registry import all_generators
from solver.pipelines.dataset.manifest import read_manifest

HISTOGRAMS = (("movable_objects", "movable objects"), ("actions", "actions (minimal known)"),
              ("depth", "dependency depth"))
"""The difficulty columns shown, with their labels."""
PLOT_FILE = Path("plots") / "difficulty.png"
BAR_WIDTH = 40
"""Characters of the longest bar of a text histogram."""


@dataclass(frozen=True)
class GeneratorStats:
    generator: str
    entries: int
    ok: int
    failed: int
    distinct: int
    median_seconds: float | None
    histograms: dict[str, dict[int, int]]  # column -> value -> puzzles

    @property
    def distinct_per_thousand(self) -> float:
        """Distinct puzzles per 1,000 seeds tried (failed seeds count as tried)."""
        return 1000.0 * self.distinct / self.entries if self.entries else 0.0


@dataclass(frozen=True)
class DatasetStats:
    root: Path
    complete: bool  # False: read from the parts of an unfinished dataset
    generators: tuple[GeneratorStats, ...]

    @property
    def entries(self) -> int:
        return sum(g.entries for g in self.generators)

    def text(self) -> str:
        """The statistics as plain text (tables and histograms of ``#`` bars)."""
        lines = [f"dataset {self.root}: {self.entries} entries"
                 + ("" if self.complete else " so far (unfinished: read from parts/, not manifest.parquet)")]
        header = (f"{'generator':18s} {'entries':>8s} {'ok':>8s} {'failed':>7s} {'distinct':>8s} "
                  f"{'distinct/1000 seeds':>19s} {'median time [s]':>15s}")
        lines += ["", header, "-" * len(header)]
        for g in self.generators:
            median = "-" if g.median_seconds is None else f"{g.median_seconds:.2f}"
            lines.append(f"{g.generator:18s} {g.entries:8d} {g.ok:8d} {g.failed:7d} {g.distinct:8d} "
                         f"{g.distinct_per_thousand:19.1f} {median:>15s}")
        for column, label in HISTOGRAMS:
            for g in self.generators:
                counts = g.histograms.get(column, {})
                if not counts:
                    continue
                lines += ["", f"{label}, {g.generator} ({sum(counts.values())} puzzles):"]
                top = max(counts.values())
                for value in range(min(counts), max(counts) + 1):
                    n = counts.get(value, 0)
                    bar = "#" * (round(BAR_WIDTH * n / top) if n else 0)
                    lines.append(f"  {value:4d} | {bar:{BAR_WIDTH}s} {n}")
        return "\n".join(lines) + "\n"


def dataset_stats(root: str | Path) -> DatasetStats:
    """Read the manifest of the dataset at ``root`` (or its parts, when unfinished) and count.

    Raises FileNotFoundError when ``root`` holds no dataset."""
    import pyarrow.compute as pc

    from phyrogen_core.folder import DATASET_FILE

    root = Path(root)
    if not (root / DATASET_FILE).is_file():
        raise FileNotFoundError(f"{root}: no dataset here (no {DATASET_FILE}; make one with `phyrogen dataset`)")
    check_dataset_files(root)
    columns = ["generator", "status", "canonical_hash", "generation_seconds", *(c for c, _ in HISTOGRAMS)]
    table, complete = read_manifest(root, columns)
    order = {name: i for i, name in enumerate(all_generators())}
    names = sorted(set(table.column("generator").to_pylist()), key=lambda n: (order.get(n, len(order)), n))
    out = []
    for name in names:
        mine = table.filter(pc.equal(table.column("generator"), name))
        ok = mine.filter(pc.equal(mine.column("status"), "ok"))
        seconds = pc.approximate_median(mine.column("generation_seconds")).as_py()
        histograms = {}
        for column, _ in HISTOGRAMS:
            counts = ok.group_by(column).aggregate([(column, "count")])
            histograms[column] = {int(v): int(n) for v, n in zip(counts.column(column).to_pylist(),
                                                                 counts.column(f"{column}_count").to_pylist(),
                                                                 strict=True) if v is not None}
        distinct = pc.count_distinct(ok.column("canonical_hash")).as_py() if ok.num_rows else 0
        out.append(GeneratorStats(name, mine.num_rows, ok.num_rows, mine.num_rows - ok.num_rows, int(distinct),
                                  seconds, histograms))
    return DatasetStats(root, complete, tuple(out))


def check_dataset_files(root: Path) -> None:
    """What ``--stats`` reads and writes, checked before it reads: ``dataset.json`` a JSON object
    written by ``phyrogen dataset``, it and the manifest (or its parts) regular files inside the
    dataset (:func:`~phyrogen_core.folder.require_folder_file`: a link to another dataset's file is
    refused), and ``plots/`` a real folder inside it. Raises
    :class:`~phyrogen_core.folder.PuzzleFormatError` or :class:`~phyrogen_core.folder.OutputError`."""
    from phyrogen_core.folder import (
        DATASET_FILE,
        PuzzleFormatError,
        read_folder_json,
        require_folder_file,
        require_stage_folder,
    )
    from solver.pipelines.dataset.manifest import MANIFEST_FILE, PARTS_FOLDER

    request = root / DATASET_FILE
    require_folder_file(request, root, what="dataset")
    data = read_folder_json(request, root)
    if not isinstance(data, dict) or "generators" not in data:
        raise PuzzleFormatError(f"{request}: not a dataset request written by phyrogen dataset")
    if os.path.lexists(root / MANIFEST_FILE):
        files = [root / MANIFEST_FILE]
    else:
        files = sorted((root / PARTS_FOLDER).glob("shard-*.parquet")) if (root / PARTS_FOLDER).is_dir() else []
    if os.path.lexists(root / PARTS_FOLDER):
        require_stage_folder(root / PARTS_FOLDER, "dataset parts folder", root=root)
    for path in files:
        require_folder_file(path, root, limit=MAX_MANIFEST_BYTES, what="dataset")
    require_stage_folder(root / PLOT_FILE.parent, "plots folder", root=root)


MAX_MANIFEST_BYTES = 2**40
"""No real bound on a manifest's size (a billion rows is a few GiB): only its kind and place are checked."""


def plot_stats(stats: DatasetStats, out_path: str | Path | None = None) -> Path:
    """The difficulty histograms, one panel per column and a bar colour per generator (PNG, written
    atomically; default ``<root>/plots/difficulty.png``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_path = Path(out_path) if out_path is not None else stats.root / PLOT_FILE
    figure, axes = plt.subplots(1, len(HISTOGRAMS), figsize=(4.2 * len(HISTOGRAMS), 3.4), squeeze=False)
    shown = [g for g in stats.generators if g.ok]
    width = 0.8 / max(1, len(shown))
    for axis, (column, label) in zip(axes[0], HISTOGRAMS, strict=True):
        for k, g in enumerate(shown):
            counts = g.histograms.get(column, {})
            values = sorted(counts)
            axis.bar([v - 0.4 + width * (k + 0.5) for v in values], [counts[v] for v in values], width=width,
                     color=f"C{k}", label=g.generator)
        axis.set_xlabel(label, fontsize=9)
        axis.set_ylabel("puzzles", fontsize=9)
        axis.tick_params(labelsize=8)
        axis.xaxis.get_major_locator().set_params(integer=True)
        axis.grid(alpha=0.3, axis="y")
    if len(shown) > 1:
        axes[0][0].legend(fontsize=8)
    names = ", ".join(g.generator for g in shown)
    figure.suptitle(f"{stats.root.name}: {sum(g.ok for g in stats.generators)} puzzles ({names})", fontsize=10)
    figure.tight_layout()
    try:
        with atomic_file(out_path, suffix=".tmp.png") as temporary:  # the suffix tells savefig the format
            figure.savefig(temporary, dpi=80)
    finally:
        plt.close(figure)
    return out_path

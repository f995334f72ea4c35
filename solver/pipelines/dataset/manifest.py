"""The manifest: one Parquet row per dataset entry, failed ones included.

Parquet rather than SQLite: it is columnar (a histogram over a million rows
reads two columns, not the table), pandas, Polars, DuckDB, Spark and Arrow
read it as it is, a dataset can be appended to one shard at a time (each
shard's rows are a file of their own, ``parts/shard-00000.parquet``, and
``manifest.parquet`` is their concatenation, a row group per shard), and a
file written once is never updated in place, so copying a finished dataset
can never catch a half-written database page.

Every column of a puzzle's row except the two cost columns is computed from
its folder (``puzzle.json``, the URDF, the export files' bytes), so a row
recovered from a folder that an interrupted run wrote is the row an
uninterrupted run writes.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from phyrogen_core.chain import KinematicChain, Role
from phyrogen_core.dependencies import DependencyShape
from phyrogen_core.folder import Stage, atomic_file, read_folder_file, stage_entries
from phyrogen_core.folder_reads import real_folder
from phyrogen_core.geometry import Box, ConvexPrism, Cylinder, Pose, Shape
from solver.pipelines.dataset.manifest_row import ManifestRow
from solver.pipelines.dataset.request import Entry

MANIFEST_FILE = "manifest.parquet"
PARTS_FOLDER = "parts"

COLUMNS: tuple[tuple[str, str, str], ...] = (
    ("index", "int64", "the entry's position in the dataset (0-based): generators in request order, seeds increasing"),
    ("generator", "string", "generator name"),
    ("name", "string", "puzzle name, <generator>_<seed>"),
    ("seed", "int64", "the puzzle's seed"),
    ("parameters", "string", "the generator's parameters, JSON with sorted keys"),
    ("shard", "int32", "the shard number (folder shard-<nnnnn>)"),
    ("path", "string", "the puzzle folder relative to the dataset root (null for a failed entry)"),
    ("status", "string", "ok or failed"),
    ("error", "string", "why generation failed (null when ok)"),
    ("content_hash", "string", "sha256 over the folder's export files (urdf/, srdf/, meshes/, puzzle.json)"),
    ("canonical_hash", "string", "sha256 of the puzzle's geometry and joints, independent of object names and order"),
    ("movable_objects", "int32", "objects with a joint, the target included"),
    ("actions", "int32", "the minimal known action count: actions in the stored (defragmented) certificate"),
    ("depth", "int32", "the dependency graph's depth (puzzle.json dependency_graph.depth)"),
    ("branching", "int32", "the dependency graph's branching (puzzle.json dependency_graph.branching)"),
    ("shape", "string", "the dependency graph's shape: none, chain or tree (phyrogen_core.dependencies)"),
    ("interlock_margin", "float64", "the smallest measured interlock margin over the blocking objects [m] "
                                    "(null when the puzzle has no blocker)"),
    ("necessity", "string", "how the weakest necessity verdict over the blocking objects was reached: geometry "
                            "(every blocker proven by geometry), goal sampler (no goal state found with one fixed) "
                            "or search (no path within the budgets); null when the puzzle has no blocker or its "
                            "puzzle.json predates format 4"),
    ("validation_checks", "int64", "collision queries the Maker's validator spent on the puzzle (planning, "
                                   "necessity judging, certifying): a machine-independent generation cost"),
    ("generation_seconds", "float64", "wall time of generating the puzzle in its worker process [s] (a timing "
                                      "column: differs between runs and machines)"),
    ("difficulty_runs", "int32", "runs of the difficulty measurement (puzzle.json difficulty; null unless the "
                                 "dataset was made with --difficulty)"),
    ("difficulty_budget_checks", "int64", "collision checks per difficulty run (null without --difficulty)"),
    ("difficulty_success_rate", "float64", "the reference planner's (BIT*) share of runs solved within the "
                                           "budget (null without --difficulty)"),
    ("difficulty_success_low", "float64", "lower end of the success rate's 95 % Wilson interval"),
    ("difficulty_success_high", "float64", "upper end of the success rate's 95 % Wilson interval"),
    ("difficulty_median_checks", "float64", "median collision checks to the first solution over the solved runs "
                                            "(null when none solved, or without --difficulty)"),
)
"""The manifest's columns: (name, Arrow type, meaning). docs/datasets.md lists them too."""
TIMING_COLUMNS = ("generation_seconds",)
"""Columns that depend on the machine and the moment; every other column is the same on every run of a request."""
CANONICAL_DECIMALS = 6
"""Numbers in the canonical description are rounded to micrometres and microradians."""


def schema():
    import pyarrow as pa

    types = {"int64": pa.int64(), "int32": pa.int32(), "string": pa.string(), "float64": pa.float64()}
    return pa.schema([pa.field(name, types[kind]) for name, kind, _ in COLUMNS])


# -- rows ----------------------------------------------------------------------------
def base_row(entry: Entry, shard: int, record: Mapping[str, Any] | None) -> dict[str, Any]:
    """The columns every row has, from the entry and (when there is one) its generation record."""
    record = record or {}
    return {
        "index": entry.index, "generator": entry.generator, "name": entry.name, "seed": entry.seed,
        "parameters": entry.parameters_json, "shard": shard, "path": None, "status": "failed", "error": None,
        "content_hash": None, "canonical_hash": None, "movable_objects": None, "actions": None, "depth": None,
        "branching": None, "shape": None, "interlock_margin": None, "necessity": None,
        "validation_checks": record.get("validation_checks"), "generation_seconds": record.get("seconds"),
        "difficulty_runs": None, "difficulty_budget_checks": None, "difficulty_success_rate": None,
        "difficulty_success_low": None, "difficulty_success_high": None, "difficulty_median_checks": None,
    }


def failed_row(entry: Entry, shard: int, error: str, record: Mapping[str, Any] | None = None) -> ManifestRow:
    row = base_row(entry, shard, record)
    row["error"] = error
    return ManifestRow(**row)


def puzzle_row(entry: Entry, shard: int, root: Path, folder: Path,
               record: Mapping[str, Any] | None = None) -> ManifestRow:
    """The row of a puzzle folder, read strictly (:func:`~phyrogen_core.export.read_puzzle_dir`).

    Raises :class:`~phyrogen_core.folder.PuzzleFormatError` (a ValueError) when the folder is not a
    valid puzzle folder of exactly this entry: its generator, seed, name or parameters differ.
    """
    from phyrogen_core.export import read_puzzle_dir
    from phyrogen_core.folder import PuzzleFormatError

    loaded = read_puzzle_dir(folder)
    stored = loaded.record
    found = (("generator", stored.generator, entry.generator), ("seed", stored.seed, entry.seed),
             ("name", stored.name, entry.name),
             ("parameters", dict(stored.parameters), json.loads(entry.parameters_json)))
    for key, value, wanted in found:
        if value != wanted:
            raise PuzzleFormatError(f"{folder}: puzzle.json {key} is {value!r}, the dataset asks for {wanted!r}")
    graph = stored.dependency_graph
    if graph.depth is None or graph.branching is None:
        raise PuzzleFormatError(f"{folder}: puzzle.json has no dependency graph depth and branching (edited "
                                "in Blender and not planned again)")
    margins = list(stored.margins.values())
    row = base_row(entry, shard, record)
    row.update({
        "path": folder.relative_to(root).as_posix(), "status": "ok",
        "content_hash": content_hash(folder, entry.name),
        "canonical_hash": canonical_hash(loaded.chain, dict(zip(loaded.joint_order, loaded.start, strict=True)),
                                         loaded.goal.values),
        "movable_objects": len(loaded.chain.object_names),
        "actions": stored.certificate_actions,
        "depth": graph.depth, "branching": graph.branching,
        "shape": DependencyShape(graph.depth, graph.branching).kind,
        "interlock_margin": float(min(margins)) if margins else None,
        "necessity": weakest_necessity(stored.necessity.values()) if len(stored.necessity) == len(margins) else None,
    })
    if stored.difficulty is not None:
        measured = stored.difficulty
        row.update({"difficulty_runs": measured.runs, "difficulty_budget_checks": measured.budget_checks,
                    "difficulty_success_rate": measured.success_rate, "difficulty_success_low": measured.success_low,
                    "difficulty_success_high": measured.success_high,
                    "difficulty_median_checks": measured.median_checks_to_first})
    return ManifestRow(**row)


# -- hashes --------------------------------------------------------------------------
def weakest_necessity(kinds) -> str | None:
    """The weakest of necessity kinds (:data:`~phyrogen_core.maker.NECESSITY_KINDS`, strongest first); None for none."""
    from phyrogen_core.maker import NECESSITY_KINDS

    return max(kinds, key=NECESSITY_KINDS.index, default=None)


def content_hash(folder: Path, name: str) -> str:
    """sha256 over the export stage's files of a puzzle folder: each file's path (relative, POSIX),
    its length and its bytes, files in path order. Renders, solutions and MJCF files do not count."""
    digest = hashlib.sha256()
    files: list[Path] = []
    for entry in stage_entries(Stage.EXPORT, name):
        path = folder / entry
        if path.is_dir():
            files += [p for p in path.rglob("*") if p.is_file()]
        elif path.is_file():
            files.append(path)
    real_root = real_folder(folder)  # resolved once for every file
    for relative, path in sorted((p.relative_to(folder).as_posix(), p) for p in files):
        data = read_folder_file(path, folder, real_root=real_root)
        digest.update(f"{relative}\0{len(data)}\0".encode())
        digest.update(data)
    return digest.hexdigest()


def canonical_hash(chain: KinematicChain, start: Mapping[str, float], goal: Mapping[str, float]) -> str:
    """sha256 of :func:`canonical_description`: two puzzles that differ only in the names or the
    order of their objects have the same hash; any change of a shape, a pose, a joint, a limit,
    the start or the goal beyond :data:`CANONICAL_DECIMALS` changes it."""
    text = "\n".join(["phyrogen-canonical-1", *canonical_description(chain, start, goal)])
    return hashlib.sha256(text.encode()).hexdigest()


def canonical_description(chain: KinematicChain, start: Mapping[str, float],
                          goal: Mapping[str, float]) -> list[str]:
    """One JSON line per object, sorted: the object's links in tree order, each with its role, the
    joint that carries it (type, origin, whether it hangs from the base; for a moving joint also
    axis, limits, start value and goal value) and its collision shapes with their poses, numbers
    rounded. No name appears: objects are told apart by what they are and where."""
    objects: dict[str, list[Any]] = {}
    for link_name in chain.links_in_tree_order:
        link = chain.link(link_name)
        if link.role in (Role.BASE, Role.GOAL_MARKER):
            continue
        joint = chain.parent_joint(link_name)
        carried: dict[str, Any] | None = None
        if joint is not None:
            carried = {"type": joint.type.value, "origin": _pose(joint.origin), "from_base": joint.parent == chain.root}
            if joint.is_active:
                carried.update(axis=[_round(v) for v in joint.axis], limits=[_round(joint.lower), _round(joint.upper)],
                               start=_round(start.get(joint.name, 0.0)),
                               goal=_round(goal[joint.name]) if joint.name in goal else None)
        shapes = sorted(json.dumps([_shape(g.shape), _pose(g.origin)], separators=(",", ":"))
                        for g in link.collisions)
        objects.setdefault(link.object_name or link.name, []).append(
            {"role": link.role.value, "joint": carried, "collisions": shapes})
    return sorted(json.dumps(links, sort_keys=True, separators=(",", ":")) for links in objects.values())


def _round(value: float) -> float:
    return round(float(value), CANONICAL_DECIMALS) + 0.0  # -0.0 -> 0.0


def _pose(pose: Pose) -> list[list[float]]:
    return [[_round(v) for v in pose.xyz], [_round(v) for v in pose.rpy]]


def _shape(shape: Shape) -> list[Any]:
    if isinstance(shape, Box):
        return ["box", [_round(v) for v in shape.size]]
    if isinstance(shape, Cylinder):
        return ["cylinder", _round(shape.radius), _round(shape.length)]
    if isinstance(shape, ConvexPrism):
        pieces = sorted([[_round(x), _round(y)] for x, y in piece] for piece in shape.pieces)
        return ["prism", _round(shape.height), pieces]
    raise TypeError(f"no canonical form for shape {type(shape).__name__}")


# -- files ---------------------------------------------------------------------------
def part_path(root: Path, shard: int) -> Path:
    from phyrogen_core.folder import shard_name

    return Path(root) / PARTS_FOLDER / f"{shard_name(shard)}.parquet"


def write_part(path: Path, rows: Sequence[ManifestRow]) -> Path:
    """One shard's rows (in index order) as a Parquet file, written atomically."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from phyrogen_core.folder import write_file_atomic

    table = pa.Table.from_pylist([r.to_dict() for r in sorted(rows, key=lambda r: r.index)], schema=schema())
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return write_file_atomic(path, sink.getvalue().to_pybytes())


def part_is_complete(path: Path, indices: range) -> bool:
    """Whether ``path`` is a readable manifest part holding exactly the rows ``indices``."""
    import pyarrow.parquet as pq

    if not path.is_file():
        return False
    try:
        table = read_parquet(path, ["index"])
        if table.schema.names != ["index"] or pq.read_schema(path) != schema():
            return False
        return table.column("index").to_pylist() == list(indices)
    except Exception:  # unreadable, truncated or another format: the shard is done again
        return False


def write_manifest(root: Path, parts: Sequence[Path]) -> Path:
    """``manifest.parquet``: the parts' rows in order, a row group per part, written atomically
    (a temporary file beside it, renamed into place)."""
    import pyarrow.parquet as pq

    final = Path(root) / MANIFEST_FILE
    with atomic_file(final) as temporary, pq.ParquetWriter(temporary, schema()) as writer:
        for part in parts:
            writer.write_table(read_parquet(part))  # (a part of another schema is refused by the writer)
    return final


def read_parquet(path: Path, columns: Sequence[str] | None = None):
    """The table of one Parquet file (``columns``, default all). ``pq.read_table`` would read it as a
    dataset, and ``Table.cast`` import Arrow's compute functions: 0.05-0.08 CPU s of imports for the
    command's process, which only writes and merges the parts."""
    import pyarrow.parquet as pq

    with pq.ParquetFile(path) as file:
        return file.read(columns=None if columns is None else list(columns))


def manifest_files(root: Path) -> tuple[list[Path], bool]:
    """The files that hold the manifest of the dataset at ``root``, and whether it is complete: the
    merged ``manifest.parquet`` when the dataset is finished, else the parts written so far."""
    root = Path(root)
    if (root / MANIFEST_FILE).is_file():
        return [root / MANIFEST_FILE], True
    return sorted((root / PARTS_FOLDER).glob("shard-*.parquet")), False


def read_manifest(root: Path, columns: Sequence[str] | None = None):
    """The manifest of the dataset at ``root`` as an Arrow table (``columns``, default all), and whether
    it is complete (:func:`manifest_files`). Each file must be Parquet with exactly the manifest's
    columns and types (:func:`schema`); :class:`~phyrogen_core.errors.PuzzleFormatError` names the
    file and the first difference otherwise. Its values are checked row by row by :func:`manifest_rows`."""
    import pyarrow as pa

    files, complete = manifest_files(root)
    cols = None if columns is None else list(columns)
    if not files:
        return schema().empty_table() if cols is None else schema().empty_table().select(cols), False
    return pa.concat_tables([_read_file(path, cols) for path in files]), complete


def manifest_rows(root: Path) -> tuple[tuple[ManifestRow, ...], bool]:
    """The manifest of the dataset at ``root`` as its typed rows, in file order, and whether it is
    complete: the one strict reader of a manifest's rows. :class:`~phyrogen_core.errors.PuzzleFormatError`,
    one line naming the file and the row (0-based, within the file), when a file or a row is not one
    ``phyrogen dataset`` writes (:class:`~solver.pipelines.dataset.manifest_row.ManifestRow`)."""
    from phyrogen_core.errors import PuzzleFormatError
    from phyrogen_core.stage_records.base import RecordError

    files, complete = manifest_files(root)
    rows: list[ManifestRow] = []
    for path in files:
        for number, data in enumerate(_read_file(path, None).to_pylist()):
            try:
                rows.append(ManifestRow.from_dict(data, f"{path}: row {number}"))
            except RecordError as exc:
                raise PuzzleFormatError(str(exc)) from None
    return tuple(rows), complete


def _read_file(path: Path, columns: list[str] | None):
    """One manifest file (the merged manifest or a part), its schema the manifest's."""
    import pyarrow.parquet as pq

    from phyrogen_core.errors import PuzzleFormatError

    try:
        found = pq.read_schema(path)
    except (OSError, ValueError) as exc:  # pyarrow's ArrowInvalid is a ValueError
        raise PuzzleFormatError(f"{path}: not a Parquet manifest ({str(exc).splitlines()[0]})") from None
    wanted = schema()
    if found != wanted:
        missing = [f.name for f in wanted if f.name not in found.names]
        unknown = [name for name in found.names if name not in wanted.names]
        if missing or unknown:
            what = f"no column {missing[0]!r}" if missing else f"an unknown column {unknown[0]!r}"
        else:
            other = next((f for f in wanted if found.field(f.name).type != f.type), None)
            what = (f"column {other.name!r} of type {found.field(other.name).type}, not {other.type}" if other
                    else "its columns in another order")
        raise PuzzleFormatError(f"{path}: not a manifest phyrogen dataset writes: {what}")
    try:
        return pq.read_table(path, columns=columns)
    except (OSError, ValueError) as exc:
        raise PuzzleFormatError(f"{path}: unreadable Parquet ({str(exc).splitlines()[0]})") from None

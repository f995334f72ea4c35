"""A dataset manifest's row is one typed record with one strict reader: a malformed manifest file or
row gets one clear error naming the file and the row, beside the valid manifest that reads."""

from __future__ import annotations

import dataclasses
import shutil

import pytest

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

from phyrogen.cli import main  # noqa: E402
from phyrogen_core.errors import PuzzleFormatError  # noqa: E402
from solver.pipelines.dataset import COLUMNS, MANIFEST_FILE, ManifestRow, manifest_rows  # noqa: E402
from solver.pipelines.dataset.manifest import schema, write_part  # noqa: E402


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """Two fresh grid_world seeds, one of them with a difficulty measured; the rows the builder wrote."""
    root = tmp_path_factory.mktemp("manifest") / "dataset"
    assert main(["dataset", "--generator", "grid_world", "--seeds", "6817-6818", "--set", "n_objects=2",
                 "--difficulty", "--difficulty-runs", "2", "--difficulty-checks", "3000", "--workers", "1",
                 "--quiet", "--out", str(root)]) == 0
    return root


def _valid(dataset):
    rows, complete = manifest_rows(dataset)
    assert complete and len(rows) == 2 and all(row.ok for row in rows)
    return rows


def test_the_fields_are_the_manifests_columns_in_order():
    assert [field.name for field in dataclasses.fields(ManifestRow)] == [name for name, _, _ in COLUMNS]


def test_the_builders_manifest_reads_and_writes_back_the_same_rows(dataset, tmp_path):
    rows = _valid(dataset)
    assert rows[0].name == "grid_world_6817" and rows[0].difficulty_runs == 2 and rows[0].actions >= 2
    assert [ManifestRow.from_dict(row.to_dict()) for row in rows] == list(rows)
    copy = tmp_path / "copy"
    copy.mkdir()
    write_part(copy / MANIFEST_FILE, rows)
    assert pq.read_table(copy / MANIFEST_FILE).equals(pq.read_table(dataset / MANIFEST_FILE))
    assert manifest_rows(copy) == (rows, True)


def _failed(row: dict) -> dict:
    keep = ("index", "generator", "name", "seed", "parameters", "shard", "validation_checks", "generation_seconds")
    return {name: row[name] if name in keep else None for name, _, _ in COLUMNS} | {"status": "failed",
                                                                                   "error": "no puzzle"}


ROW_CASES = {
    "status": (lambda r: r | {"status": "maybe"}, "'status': expected one of 'ok', 'failed'"),
    "ok without actions": (lambda r: r | {"actions": None}, "an ok row with no 'actions'"),
    "ok without path": (lambda r: r | {"path": None}, "an ok row with no 'path'"),
    "ok with an error": (lambda r: r | {"error": "boom"}, "an ok row with an error"),
    "failed with a hash": (lambda r: _failed(r) | {"content_hash": r["content_hash"]},
                           "a failed row with 'content_hash'"),
    "failed without error": (lambda r: _failed(r) | {"error": None}, "a failed row with no error"),
    "path up": (lambda r: r | {"path": "../elsewhere/grid_world_6817"}, "not a folder inside the dataset"),
    "absolute path": (lambda r: r | {"path": "/etc"}, "not a folder inside the dataset"),
    "nan": (lambda r: r | {"interlock_margin": float("nan")}, "'interlock_margin': the non-finite number nan"),
    "infinity": (lambda r: r | {"generation_seconds": float("inf")}, "'generation_seconds': the non-finite number"),
    "hash": (lambda r: r | {"canonical_hash": "zz" * 32}, "'canonical_hash' is not a sha256"),
    "name": (lambda r: r | {"name": "grid_world_1"}, "'name' is 'grid_world_1', not <generator>_<seed>"),
    "parameters": (lambda r: r | {"parameters": "[1, 2]"}, "'parameters' is not a JSON object"),
    "negative count": (lambda r: r | {"movable_objects": -2}, "'movable_objects' is -2, expected a count"),
    "necessity": (lambda r: r | {"necessity": "a hunch"}, "'necessity' is 'a hunch'"),
    "difficulty in part": (lambda r: r | {"difficulty_success_low": None}, "'difficulty_success_low' is null"),
    "interval": (lambda r: r | {"difficulty_success_low": 0.9, "difficulty_success_rate": 0.5},
                 "are not rates in order"),
}


@pytest.mark.parametrize("case", ROW_CASES)
def test_a_malformed_row_gets_one_line_naming_the_file_and_the_row(dataset, tmp_path, case):
    change, words = ROW_CASES[case]
    rows = [row.to_dict() for row in _valid(dataset)]
    rows[1] = change(rows[1])
    root = tmp_path / "bad"
    root.mkdir()
    pq.write_table(pa.Table.from_pylist(rows, schema=schema()), root / MANIFEST_FILE)
    with pytest.raises(PuzzleFormatError) as caught:
        manifest_rows(root)
    message = str(caught.value)
    assert message.startswith(f"{root / MANIFEST_FILE}: row 1: ") and words in message, message
    assert "\n" not in message
    # The control: the failed row of a real failure, as the builder writes it, reads.
    rows[1] = _failed(_valid(dataset)[1].to_dict())
    pq.write_table(pa.Table.from_pylist(rows, schema=schema()), root / MANIFEST_FILE)
    assert [row.status for row in manifest_rows(root)[0]] == ["ok", "failed"]


FILE_CASES = {
    "missing column": (lambda t: t.drop_columns(["shape"]), "no column 'shape'"),
    "unknown column": (lambda t: t.append_column("notes", pa.array(["a", "b"])), "an unknown column 'notes'"),
    "wrong type": (lambda t: t.set_column(t.schema.get_field_index("seed"), "seed",
                                          pa.array(["6817", "6818"])), "column 'seed' of type string, not int64"),
    "order": (lambda t: t.select([*t.schema.names[1:], "index"]), "its columns in another order"),
}


@pytest.mark.parametrize("case", [*FILE_CASES, "not parquet", "torn"])
def test_a_malformed_manifest_file_gets_one_line_naming_it(dataset, tmp_path, case, capsys):
    root = tmp_path / "bad"
    shutil.copytree(dataset, root)
    file = root / MANIFEST_FILE
    if case == "not parquet":
        file.write_text("index,generator\n0,grid_world\n")
        words = "not a Parquet manifest"
    elif case == "torn":
        file.write_bytes(file.read_bytes()[:-200])
        words = "not a Parquet manifest"
    else:
        change, words = FILE_CASES[case]
        pq.write_table(change(pq.read_table(dataset / MANIFEST_FILE)), file)
    with pytest.raises(PuzzleFormatError) as caught:
        manifest_rows(root)
    assert str(caught.value).startswith(f"{file}: ") and words in str(caught.value), caught.value
    assert "\n" not in str(caught.value)
    # Every reader is the same one: `dataset --stats` refuses the file, one line, exit 2.
    assert main(["dataset", "--stats", str(root)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(file) in err, err


def test_stats_reads_the_valid_manifest(dataset, capsys):
    """The control of the command: the builder's manifest is described."""
    shutil.rmtree(dataset / "plots", ignore_errors=True)
    assert main(["dataset", "--stats", str(dataset)]) == 0
    assert "grid_world" in capsys.readouterr().out


@pytest.mark.parametrize("tamper", [None, {"seconds": "fast"}, {"seconds": float("nan")}, {"seconds": -1.0},
                                    {"validation_checks": 2.5}, {"ok": 0}, {"error": ["no"]}])
def test_a_resumed_dataset_makes_again_a_generation_record_no_worker_writes(tmp_path, tamper):
    """An unfinished shard's generation records become manifest rows when the dataset resumes; a record
    whose values are of other kinds than a worker writes is made again, as a torn one is, rather than
    read into a row. The control (None): the record as written is a row, and not made again."""
    import json
    from pathlib import Path

    from solver.pipelines.dataset import EntryOutcome, build_dataset, local_backend, make_request
    from solver.pipelines.dataset.build import write_record

    request = make_request(["grid_world"], [(6831, 6832)], ["n_objects=2"], shard_size=4)
    root = tmp_path / "d"

    def fail_first_then_stop(tasks, workers, on_running=None):
        task = next(iter(tasks))
        write_record(Path(task.shard_dir), task, EntryOutcome(task.index, False, "no puzzle", 0.5, 7))
        yield EntryOutcome(task.index, False, "no puzzle", 0.5, 7)
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        build_dataset(request, root, 1, backend=fail_first_then_stop)
    (record,) = root.glob("shard-00000/.records/*.json")
    if tamper is not None:
        record.write_text(json.dumps(json.loads(record.read_text()) | tamper))
    made = []

    def logging(tasks, workers, on_running=None):
        tasks = list(tasks)
        made.extend(task.index for task in tasks)
        yield from local_backend(tasks, workers, on_running)

    build_dataset(request, root, 1, backend=logging)
    rows, complete = manifest_rows(root)
    assert complete and [row.seed for row in rows] == [6831, 6832]
    if tamper is None:
        assert made == [1]
        assert (rows[0].status, rows[0].error, rows[0].generation_seconds) == ("failed", "no puzzle", 0.5)
    else:
        assert made == [0, 1] and rows[0].ok

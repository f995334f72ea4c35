"""``phyrogen dataset``: the request's rules, bad input refused up front, determinism, resuming after
an interruption (an exception, Ctrl-C, a real SIGKILL) without making anything twice, failed seeds as
manifest rows, the canonical hash, ``--stats``, and a dataset root read by the other stages.

Seeds 9100-9199 are this file's; no other test uses them. Every dataset here is Grid World with two to
four boxes (a few tenths of a second a puzzle) in shards of five.
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from waiting import BACKSTOP, wait_until

pq = pytest.importorskip("pyarrow.parquet")

from phyrogen.cli import main  # noqa: E402
from phyrogen_core.export import read_puzzle_dir  # noqa: E402
from phyrogen_core.folder import find_puzzle_folders  # noqa: E402
from solver.pipelines.dataset import (  # noqa: E402
    TIMING_COLUMNS,
    DatasetError,
    EntryOutcome,
    build_dataset,
    canonical_hash,
    content_hash,
    local_backend,
    make_request,
    manifest_rows,
)
from solver.pipelines.dataset.build import write_record  # noqa: E402
from solver.pipelines.dataset.manifest import canonical_description  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SEEDS = (9100, 9115)  # 16 puzzles: shards of 5, 5, 5 and 1
OPTIONS = ["--generator", "grid_world", "--seeds", f"{SEEDS[0]}-{SEEDS[1]}", "--set", "n_objects=2:4",
           "--shard-size", "5", "--quiet"]
ARGS = (["grid_world"], [SEEDS], ["n_objects=2:4"])  # the same request, for make_request
SKIPPED = ("parts", "plots", "manifest.parquet")  # compared apart: the manifest has timing columns


def run(out: Path, *extra: str) -> int:
    return main(["dataset", *OPTIONS, "--out", str(out), *extra])


def files(root: Path) -> dict[str, bytes]:
    """Every file of a dataset but the manifest and its parts (and plots), by relative path."""
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and p.relative_to(root).parts[0] not in SKIPPED}


def manifest(root: Path):
    return pq.read_table(root / "manifest.parquet").drop_columns(list(TIMING_COLUMNS))


def manifest_dicts(root: Path) -> list[dict]:
    """The rows of a finished dataset's manifest, read by its strict reader."""
    rows, complete = manifest_rows(root)
    assert complete
    return [row.to_dict() for row in rows]


def assert_same_dataset(root: Path, reference: Path) -> None:
    assert files(root) == files(reference)
    assert manifest(root).equals(manifest(reference))
    for part in sorted((reference / "parts").iterdir()):
        mine = pq.read_table(root / "parts" / part.name).drop_columns(list(TIMING_COLUMNS))
        assert mine.equals(pq.read_table(part).drop_columns(list(TIMING_COLUMNS))), part.name


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    """The request made once, without interruption."""
    root = tmp_path_factory.mktemp("dataset") / "reference"
    assert run(root) == 0
    return root


# -- the request -------------------------------------------------------------------------
def test_sweeps_give_each_seed_its_parameters_by_the_seed_alone():
    request = make_request(["grid_world"], [(9110, 9115)], ["n_objects=2:4", "branching=0,3"])
    combos = [(e.seed, e.params.n_objects, e.params.branching) for e in request.entries()]
    # cross: K = 6 combinations, the first --set slowest; seed s gets combination s mod 6 (9110 mod 6 = 2)
    assert combos == [(9110, 3, 0), (9111, 3, 3), (9112, 4, 0), (9113, 4, 3), (9114, 2, 0), (9115, 2, 3)]
    zipped = make_request(["grid_world"], [(9110, 9115)], ["n_objects=2:4", "branching=0,3"], sweep_mode="zip")
    assert [(e.params.n_objects, e.params.branching) for e in zipped.entries()] == [
        (2 + s % 3, (0, 3)[s % 2]) for s in range(9110, 9116)]
    # A seed's puzzle does not depend on the rest of the request.
    longer = make_request(["grid_world"], [(9100, 9130)], ["n_objects=2:4", "branching=0,3"])
    assert {e.seed: e.params for e in longer.entries()}.items() >= {e.seed: e.params for e in
                                                                    request.entries()}.items()
    # A float sweep beside a fixed setting.
    floats = make_request(["grid_world"], [(9100, 9103)], ["clearance=0.1:0.3:0.1", "n_objects=3"])
    assert [e.params.clearance for e in floats.entries()] == [0.2, 0.3, 0.1, 0.2]
    assert {e.params.n_objects for e in floats.entries()} == {3}
    assert floats.to_json()["set"] == {"n_objects": 3}


def test_a_request_with_several_generators_keeps_generator_then_seed_order():
    request = make_request(["rooms", "grid_world"], [(9100, 9101), (9105, 9105)], shard_size=4)
    assert [(e.index, e.generator, e.seed) for e in request.entries()] == [
        (0, "rooms", 9100), (1, "rooms", 9101), (2, "rooms", 9105),
        (3, "grid_world", 9100), (4, "grid_world", 9101), (5, "grid_world", 9105)]
    assert [list(request.shard_entries(k)) for k in range(request.shard_count)] == [[0, 1, 2, 3], [4, 5]]


@pytest.mark.parametrize(("settings", "needle"), [
    (["n_objects=2:x"], "n_objects=2:x"),
    (["n_objects=5:2"], "LOW <= HIGH"),
    (["clearance=0.1:0.3"], "float parameter"),
    (["clearance=0.1:inf:0.1"], "finite"),
    (["clearance=nan"], "nan"),
    (["n_objects=2,2"], "twice"),
    (["n_objects=2", "n_objects=3"], "twice"),
    (["colour=red"], "colour"),
    (["n_objects"], "KEY=VALUE"),
    (["n_objects=1:20000"], "at most"),
])
def test_bad_settings_are_refused_naming_the_value(settings, needle):
    with pytest.raises(ValueError) as caught:
        make_request(["grid_world"], [(9100, 9101)], settings)
    assert needle in str(caught.value) and "\n" not in str(caught.value)


def test_infeasible_sizes_and_absurd_requests_are_refused():
    with pytest.raises(ValueError, match="n_objects"):  # Seed + 1 sliders: seed 9100 is far too large
        make_request(["simple_slider"], [(9100, 9101)])
    with pytest.raises(ValueError, match="n_objects"):
        make_request(["grid_world"], [(9100, 9106)], ["n_objects=20:26"])  # 26 boxes for seed 9105
    with pytest.raises(DatasetError, match="at most 10,000,000"):
        make_request(["grid_world", "rooms"], [(9100, 6_009_099)])
    with pytest.raises(DatasetError, match="shard size"):
        make_request(["grid_world"], [(9100, 9101)], shard_size=0)


@pytest.mark.parametrize("argv", [
    ["--generator", "no_such_generator", "--count", "3"],
    ["--generator", "grid_world", "--count", "0"],
    ["--generator", "grid_world", "--count", "-4"],
    ["--generator", "grid_world", "--count", "1000000000000"],
    ["--generator", "grid_world", "--count", "3", "--set", "clearance=nan"],
    ["--generator", "grid_world", "--count", "3", "--set", "n_objects=3:inf"],
    ["--generator", "grid_world", "--count", "3", "--set", "n_objects=99"],
    ["--generator", "simple_slider", "--count", "3", "--start", "9100"],
    ["--generator", "grid_world", "--count", "3", "--seeds", "1-3"],
    ["--generator", "grid_world", "--seeds", "3-1"],
    ["--generator", "grid_world", "--count", "3", "--shard-size", "0"],
    ["--generator", "grid_world", "--count", "3", "--start", "9223372036854775807"],
    ["--generator", "grid_world,rooms", "--count", "3", "--set", "n_objects=3"],
    ["--generator", "grid_world"],
])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(argv, tmp_path, capsys):
    out = tmp_path / "new"
    assert main(["dataset", *argv, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("phyrogen: error: ") and err.count("\n") == 1, err
    assert not out.exists()


# -- making a dataset ----------------------------------------------------------------------
def test_a_dataset_has_every_seed_once_in_valid_folders(reference):
    rows = manifest_dicts(reference)
    assert [r["seed"] for r in rows] == list(range(SEEDS[0], SEEDS[1] + 1))
    assert [r["index"] for r in rows] == list(range(len(rows)))
    assert {r["status"] for r in rows} == {"ok"} and {r["error"] for r in rows} == {None}
    assert [r["shard"] for r in rows] == [0] * 5 + [1] * 5 + [2] * 5 + [3]
    for row in rows:
        folder = reference / row["path"]
        assert row["path"] == f"shard-{row['shard']:05d}/grid_world/grid_world_{row['seed']}"
        loaded = read_puzzle_dir(folder)  # strict: a torn or inconsistent folder raises
        params = json.loads(row["parameters"])
        record = loaded.record
        assert params == record.parameters and params["n_objects"] == 2 + row["seed"] % 3
        assert row["movable_objects"] == params["n_objects"] == len(record.dependency_graph.nodes)
        assert row["actions"] == record.certificate_actions >= row["movable_objects"]
        assert row["depth"] == record.dependency_graph.depth
        assert row["branching"] == record.dependency_graph.branching
        blocked = [edge[1] for edge in record.dependency_graph.edges]
        fan_in = max((blocked.count(name) for name in blocked), default=0)
        assert row["shape"] == ("none" if not blocked else "chain" if fan_in == 1 else "tree")
        assert row["interlock_margin"] == min(record.margins.values())
        assert row["content_hash"] == content_hash(folder, row["name"])
        assert row["validation_checks"] > 0 and row["generation_seconds"] > 0
    assert [p.name for p in sorted((reference / "parts").iterdir())] == [f"shard-{k:05d}.parquet" for k in range(4)]
    leftovers = [p for p in reference.rglob(".*")]
    assert leftovers == []  # no generation records, no temporary files
    stored = json.loads((reference / "dataset.json").read_text())
    assert (stored["entries"], stored["shards"], stored["sweeps"]) == (16, 4, [{"key": "n_objects",
                                                                               "values": [2, 3, 4]}])


def test_the_same_request_twice_gives_the_same_bytes(reference, tmp_path):
    again = tmp_path / "again"
    assert run(again, "--workers", "1") == 0  # another worker count: the same dataset
    assert_same_dataset(again, reference)
    timing = pq.read_table(again / "manifest.parquet").column("generation_seconds").to_pylist()
    assert all(t > 0 for t in timing)


def test_a_rerun_of_a_finished_dataset_makes_nothing_and_another_request_is_refused(reference, capsys):
    before = files(reference)
    assert run(reference) == 0
    out = capsys.readouterr().out
    assert "0 made now, 16 found done" in out
    assert files(reference) == before
    assert main(["dataset", *OPTIONS[:-3], "--shard-size", "4", "--quiet", "--out", str(reference)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "another request" in err and "shard_size 5 there, 4 now" in err
    assert files(reference) == before


def recording(backend, log: list, stop_after: int | None = None,
              stop_when: Callable[[list[int]], bool] | None = None):
    """A backend that logs the tasks it is given and is interrupted after ``stop_after`` outcomes, or after
    the first outcome at which ``stop_when(indices of the outcomes given so far)`` holds."""
    def wrapped(tasks, workers, on_running=None):
        def logged():
            for task in tasks:
                log.append(task.index)
                yield task
        given: list[int] = []
        for outcome in backend(logged(), workers, on_running):
            yield outcome
            given.append(outcome.index)
            if (stop_after is not None and len(given) >= stop_after) or (stop_when is not None and stop_when(given)):
                raise KeyboardInterrupt
    return wrapped


def test_an_interrupted_dataset_resumes_without_making_anything_twice(reference, tmp_path):
    request = make_request(*ARGS, shard_size=5)
    root = tmp_path / "resumed"
    first: list[int] = []
    made: list[int] = []

    def completed(indices) -> set[int]:
        return {s for s in range(request.shard_count) if set(request.shard_entries(s)) <= set(indices)}

    # The backend returns batches in the order they finish (imap_unordered over two workers), so which
    # entries are done after n outcomes depends on the machine's load: a fixed n can complete no shard.
    # Stopped at the outcome that completes the first shard, the run has a complete shard and others not.
    with pytest.raises(KeyboardInterrupt):
        build_dataset(request, root, 2, backend=recording(local_backend, first, stop_when=lambda i: bool(completed(i))),
                      on_row=lambda row, now: made.append(row.index) if now else None)
    # Its last outcome completed the shard: that part is written before the interrupt comes back out.
    assert completed(made) and not completed(made[:-1]) and len(made) < request.size
    parts = {int(p.stem.split("-")[1]) for p in (root / "parts").glob("*.parquet")}
    assert parts == completed(made)  # every completed shard kept; none of those still waiting (the control)
    assert completed(made) != set(range(request.shard_count))
    assert not (root / "manifest.parquet").exists()
    done = {int(p.parent.name.rsplit("_", 1)[1]) - SEEDS[0]
            for p in root.glob("shard-*/grid_world/*/puzzle.json")}
    assert set(made) <= done  # workers still running when stopped may have finished theirs too
    # What writers killed mid-write leave (a puzzle folder, a record, a part, the manifest): removed.
    (root / "shard-00002" / "grid_world" / ".grid_world_9112.k1ll3d.tmp" / "urdf").mkdir(parents=True)
    (root / "shard-00002" / "grid_world" / ".grid_world_9112.k1ll3d.tmp" / "urdf" / "x.urdf").write_text("<rob")
    (root / "shard-00002" / ".records").mkdir(parents=True, exist_ok=True)
    (root / "shard-00002" / ".records" / ".grid_world_9113.json.k1ll3d.tmp").write_text('{"ind')
    (root / "parts" / ".shard-00002.parquet.k1ll3d.tmp").write_bytes(b"PAR1")
    (root / ".manifest.parquet.k1ll3d.tmp").write_bytes(b"PAR1")
    second: list[int] = []
    result = build_dataset(request, root, 2, backend=recording(local_backend, second))
    assert not set(second) & done  # nothing made twice
    assert sorted(second) == sorted(set(range(16)) - done)
    assert (result.generated, result.ok, result.failed) == (len(second), 16, 0)
    assert_same_dataset(root, reference)
    assert list(root.rglob(".*")) == []


def test_failed_seeds_are_rows_and_are_not_retried(tmp_path):
    request = make_request(["grid_world"], [(9120, 9125)], ["n_objects=2"], shard_size=4)
    failing = {9121, 9124}

    def failing_backend(tasks, workers, on_running=None):
        """Generation's own failures for some seeds (recorded as a worker records them), real puzzles else."""
        real = []
        for task in tasks:
            if task.seed in failing:
                outcome = EntryOutcome(task.index, False, f"no puzzle for seed {task.seed}", 0.5, None)
                write_record(Path(task.shard_dir), task, outcome)
                yield outcome
            else:
                real.append(task)
        yield from local_backend(real, workers, on_running)

    with pytest.raises(KeyboardInterrupt):
        build_dataset(request, tmp_path / "d", 2, backend=recording(failing_backend, [], stop_after=5))
    log: list[int] = []
    result = build_dataset(request, tmp_path / "d", 2, backend=recording(local_backend, log))
    assert (result.ok, result.failed) == (4, 2)
    assert not {i for i in log if request.entry(i).seed in failing}  # a recorded failure is not retried
    rows = manifest_dicts(tmp_path / "d")
    assert [r["seed"] for r in rows] == list(range(9120, 9126))
    for row in rows:
        if row["seed"] in failing:
            assert (row["status"], row["error"], row["path"], row["content_hash"]) == (
                "failed", f"no puzzle for seed {row['seed']}", None, None)
            assert row["generation_seconds"] == 0.5
        else:
            assert row["status"] == "ok" and row["error"] is None


@pytest.mark.parametrize("stop", [SystemExit(1), KeyboardInterrupt()])
def test_a_worker_told_to_stop_inside_compiled_code_records_nothing(tmp_path, monkeypatch, stop):
    """Ray ends the workers of a killed command with SIGTERM (SystemExit from its handler); inside
    compiled code it surfaces as a SystemError caused by it. That is no failure of the puzzle: the
    worker writes no record, so a resume makes the puzzle. A plain bug is still a recorded failure
    (the control)."""
    import solver.pipelines.dataset.build as build
    from phyrogen_core.registry import all_generators

    params = dataclasses.replace(all_generators()["grid_world"].default_params(), n_objects=2)
    task = build.EntryTask(0, "grid_world", 9190, params, str(tmp_path))

    def stopped(*args, **kwargs):
        try:
            raise stop
        except BaseException as exc:
            raise SystemError("CPUDispatcher(<function resume>) returned a result with an exception set") from exc

    monkeypatch.setattr(build, "generate_here", stopped)
    with pytest.raises(SystemError):
        build.make_entry(task)
    assert not list(tmp_path.rglob("*.json"))

    def bug(*args, **kwargs):
        raise SystemError("a bug in compiled code")

    monkeypatch.setattr(build, "generate_here", bug)
    outcome = build.make_entry(task)
    assert not outcome.ok and "a bug in compiled code" in outcome.error
    assert len(list(tmp_path.rglob("*.json"))) == 1


def group_alive(group: int) -> bool:
    try:
        os.killpg(group, 0)
    except ProcessLookupError:
        return False
    return True


def test_killed_with_sigkill_and_interrupted_with_ctrl_c_it_resumes_to_the_same_dataset(reference, tmp_path):
    root = tmp_path / "killed"

    def start() -> subprocess.Popen:
        return subprocess.Popen([sys.executable, "-m", "phyrogen", "dataset", *OPTIONS, "--out", str(root)],
                                cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                start_new_session=True)

    def finished() -> list[Path]:
        return sorted(root.glob("shard-*/grid_world/[!.]*/puzzle.json"))

    def stop(process: subprocess.Popen, signum: int, after: int) -> int:
        def enough() -> bool:
            assert process.poll() is None, process.communicate()
            return len(finished()) >= after

        wait_until(enough, f"{after} finished puzzles", poll=0.02)
        os.killpg(process.pid, signum)
        process.communicate(timeout=BACKSTOP)
        wait_until(lambda: not group_alive(process.pid), "the end of the stopped command's fork server and workers")
        return process.returncode

    for after in (1, 7):  # in the first shard, then in the second with the first one's part written
        assert stop(start(), signal.SIGKILL, after=after) == -signal.SIGKILL
        count = len(finished())
        assert after <= count < 16, "the kill came too late to test anything"
        for meta in finished():  # no torn folder: each one present reads strictly
            read_puzzle_dir(meta.parent)
        assert not (root / "manifest.parquet").exists()
        parts = sorted((root / "parts").glob("*.parquet")) if (root / "parts").exists() else []
        assert [pq.read_table(part).num_rows for part in parts] == [5] * len(parts)  # only complete shards

    assert stop(start(), signal.SIGINT, after=count + 2) == 128 + signal.SIGINT  # Ctrl-C reaches the group
    assert not list(root.rglob(".*.tmp"))  # stopped cleanly: no temporary file or folder

    process = start()
    out, err = process.communicate(timeout=BACKSTOP)
    assert process.returncode == 0, err
    assert "16/16 puzzles ok" in out
    assert_same_dataset(root, reference)


# -- hashes, statistics, readers -----------------------------------------------------------
def test_the_canonical_hash_ignores_names_and_order_and_sees_geometry(reference):
    from phyrogen_core.chain import KinematicChain

    folder = reference / "shard-00000" / "grid_world" / "grid_world_9101"  # four boxes
    loaded = read_puzzle_dir(folder)
    chain = loaded.chain
    start = dict(zip(loaded.joint_order, loaded.start, strict=True))
    original = canonical_hash(chain, start, loaded.goal.values)

    def rename(name: str) -> str:
        return name if name == chain.root else f"renamed_{name[::-1]}"

    links = tuple(dataclasses.replace(link, name=rename(link.name),
                                      object_name=rename(link.object_name) if link.object_name else "")
                  for link in reversed(chain.links))
    joints = tuple(dataclasses.replace(j, name=rename(j.name), parent=rename(j.parent), child=rename(j.child))
                   for j in reversed(chain.joints))
    renamed = KinematicChain(links, joints, chain.root, "another_name")
    assert canonical_hash(renamed, {rename(k): v for k, v in start.items()},
                          {rename(k): v for k, v in loaded.goal.values.items()}) == original
    assert not any("obj_" in line for line in canonical_description(renamed, {}, {}))
    k = next(i for i, j in enumerate(chain.joints) if j.is_active)
    moved = dataclasses.replace(chain.joints[k], upper=chain.joints[k].upper + 0.01)
    changed = KinematicChain(chain.links, (*chain.joints[:k], moved, *chain.joints[k + 1:]), chain.root, chain.name)
    assert canonical_hash(changed, start, loaded.goal.values) != original
    assert canonical_hash(chain, start, {k: v + 0.5 for k, v in loaded.goal.values.items()}) != original
    rows = manifest_dicts(reference)
    assert rows[1]["canonical_hash"] == original
    assert len({r["canonical_hash"] for r in rows}) == len({r["content_hash"] for r in rows})


def test_stats_prints_counts_and_histograms_and_draws_them(reference, capsys):
    assert main(["dataset", "--stats", str(reference)]) == 0
    out = capsys.readouterr().out
    assert "grid_world" in out and "distinct/1000 seeds" in out
    assert "movable objects, grid_world (16 puzzles):" in out
    assert "dependency depth" in out and "actions (minimal known)" in out
    histogram = out.split("movable objects, grid_world (16 puzzles):\n")[1].splitlines()[:3]
    assert [line.split()[0] for line in histogram] == ["2", "3", "4"]
    assert [int(line.split()[-1]) for line in histogram] == [5, 6, 5]  # seeds 9100-9115, n_objects 2 + s mod 3
    png = reference / "plots" / "difficulty.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["dataset", "--stats", str(reference), "--generator", "grid_world"]) == 2
    assert main(["dataset", "--stats", str(reference.parent / "missing")]) == 2


def test_a_dataset_root_is_a_folder_of_puzzles_for_the_other_stages(reference):
    found = find_puzzle_folders(reference)
    assert [f.seed for f in found] == list(range(SEEDS[0], SEEDS[1] + 1))
    assert [f.seed for f in find_puzzle_folders(reference / "shard-00001")] == list(range(9105, 9110))
    gym = pytest.importorskip("gymnasium")  # noqa: F841
    from phyrogen.env import PuzzleEnv

    env = PuzzleEnv(reference)
    assert len(env.puzzle_names) == 16
    env.reset(seed=0)


@pytest.mark.parametrize(("seed", "shard"), [(9100, 0), (9101, 0), (9105, 1)])
def test_a_dataset_folder_is_the_folder_generate_writes(reference, tmp_path, seed, shard):
    # generate makes each puzzle in a process of its own; a dataset makes 9101 and 9105 in the
    # process that made the seeds before them in their batch.
    assert main(["generate", "--generator", "grid_world", "--seeds", str(seed), "--set", f"n_objects={2 + seed % 3}",
                 "--out", str(tmp_path), "--quiet"]) == 0
    generated = tmp_path / "grid_world" / f"grid_world_{seed}"
    in_dataset = reference / f"shard-0000{shard}" / "grid_world" / f"grid_world_{seed}"
    assert files(generated) == files(in_dataset)


def test_mjcf_on_request_beside_every_urdf_and_made_again_when_missing(tmp_path, capsys):
    from phyrogen_core.export import chain_to_mjcf, mjcf_path

    root = tmp_path / "with-mjcf"
    options = ["dataset", "--generator", "grid_world", "--seeds", "9120-9122", "--set", "n_objects=2",
               "--shard-size", "2", "--mjcf", "--quiet", "--out", str(root)]
    assert main(options) == 0
    folders = find_puzzle_folders(root)
    assert len(folders) == 3
    for folder in folders:
        written = mjcf_path(folder.path, folder.name).read_bytes()
        loaded = read_puzzle_dir(folder.path)
        assert written == chain_to_mjcf(loaded.chain, loaded.certificate).encode()
    assert json.loads((root / "dataset.json").read_text())["mjcf"] is True
    # A folder whose MJCF is missing (a worker killed between the two) is not done: resumed, it is
    # made again. The shard's part file is removed too, or the shard would count as complete.
    last = folders[-1]
    mjcf_path(last.path, last.name).unlink()
    (root / "parts" / "shard-00001.parquet").unlink()
    assert main(options) == 0
    assert "1 made now, 2 found done" in capsys.readouterr().out
    assert mjcf_path(last.path, last.name).is_file()
    # Without --mjcf it is another request.
    assert main([o for o in options if o != "--mjcf"]) == 2

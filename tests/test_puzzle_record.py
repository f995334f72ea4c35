"""``puzzle.json`` has one typed owner, :class:`phyrogen_core.record.PuzzleRecord`.

Its text round-trips exactly, files of the first format are upgraded when
read, bad values are refused naming the key, and no product module reads the
file by string key any more (a grep, shown to catch what it looks for).
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path

import pytest

from phyrogen_core.errors import PuzzleFormatError
from phyrogen_core.export import read_puzzle_dir, write_puzzle
from phyrogen_core.export.metadata import metadata_json, puzzle_record
from phyrogen_core.provenance import PlannerRun
from phyrogen_core.record import FORMAT_VERSION, NECESSITY_VERSION, PROVENANCE_VERSION, PuzzleRecord
from phyrogen_core.registry import all_generators, get_generator
from solver.pipelines.generation import generate_here

ROOT = Path(__file__).resolve().parent.parent
PRODUCT_PACKAGES = ("phyrogen_core", "solver", "blender_addon", "manipulation", "phyrogen")
RECORD_MODULE = Path("phyrogen_core") / "record.py"

# Keys only puzzle.json has (no other file or mapping of the product uses them).
_PUZZLE_KEYS = ("certificate", "certificate_actions", "certificate_verified", "dependency_graph", "joint_limits",
                "replanned_by", "certified_by", "provenance")
_KEYS = "|".join(_PUZZLE_KEYS)
_KEY_READ = re.compile(rf"""(\[|\.get\(|\.pop\(|\.setdefault\()\s*["']({_KEYS})["']"""
                       rf"""|["']({_KEYS})["']\s+(not\s+)?in\b""")
# The first format's two homes of provenance, in any form (a dict literal's key too).
_OLD_PROVENANCE = re.compile(r"""["'](replanned_by|certified_by)["']""")
# A mapping called metadata read by key; ``f.metadata`` (a dataclass field's) and ``self.metadata``
# (the Gymnasium environment's render modes) are other things of that name.
_METADATA_READ = re.compile(r"""(?<!\bf\.)(?<!\bself\.)\bmeta(data)?\s*(\[|\.get\()\s*["']""")
# puzzle.json parsed as plain JSON (PuzzleFolder.metadata is its path).
_RAW_PARSE = re.compile(r"""json\.loads?\(.*\.metadata\b""")
PATTERNS = (_KEY_READ, _OLD_PROVENANCE, _METADATA_READ, _RAW_PARSE)

# Fresh seeds (no other test uses them), and sizes that keep each puzzle quick.
SEEDS = {"simple_slider": 804_113_457, "continuous_space": 590_233_871, "grid_world": 377_650_129,
         "lockbox_random": 912_004_663, "move_n_times": 655_781_203, "rooms": 148_392_517}
SIZES = {"simple_slider": {"n_objects": "3"}, "move_n_times": {"n": "2"}, "lockbox_random": {"n_objects": "3"}}


def metadata_key_reads(root: Path, packages: tuple[str, ...] = PRODUCT_PACKAGES) -> list[str]:
    """``path:line: text`` of every line of ``root/<package>/**/*.py`` (but the record module) that
    reads puzzle metadata by string key or parses puzzle.json as plain JSON."""
    found = []
    for package in packages:
        for path in sorted((root / package).rglob("*.py")):
            relative = path.relative_to(root)
            if relative == RECORD_MODULE:
                continue
            for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                code = line.split("#", 1)[0]
                if any(pattern.search(code) for pattern in PATTERNS):
                    found.append(f"{relative}:{number}: {line.strip()}")
    return found


def test_no_product_module_reads_puzzle_metadata_by_string_key():
    assert metadata_key_reads(ROOT) == []


@pytest.mark.parametrize("snippet", [
    'name = loaded.metadata["name"]',
    'seed = meta.get("seed", 0)',
    'data["replanned_by"] = {"planner": planner}',
    'parameters = {**puzzle.parameters, "certified_by": run}',
    'if "certificate_verified" not in stored:',
    'graph = data.get("dependency_graph", {})',
    'actions = int(record["certificate_actions"])',
    'name = json.loads(read_folder_file(puzzle.metadata, puzzle.path))["name"]',
])
def test_the_grep_catches_a_planted_read(tmp_path, snippet):
    package = tmp_path / "solver"
    package.mkdir()
    (package / "planted.py").write_text(f"def f(loaded, meta, data, puzzle, stored, record):\n    {snippet}\n")
    (tmp_path / "phyrogen_core").mkdir()
    (tmp_path / RECORD_MODULE).write_text(f"def g(data):\n    {snippet}\n")  # the owner may
    assert metadata_key_reads(tmp_path, ("solver", "phyrogen_core")) == [f"solver/planted.py:2: {snippet}"]


def test_the_grep_lets_other_metadata_be():
    lines = ['doc = f.metadata.get("doc", "")', 'modes = self.metadata["render_modes"]',
             'order = data["joint_order"]  # a solution file']
    assert not [line for line in lines if any(p.search(line.split("#", 1)[0]) for p in PATTERNS)]


@pytest.fixture(scope="module")
def puzzles():
    out = {}
    for generator in all_generators():
        spec = get_generator(generator)
        out[generator] = generate_here(generator, SEEDS[generator], spec.parse_params(SIZES.get(generator, {})))
    return out


def test_every_generator_is_in_the_seed_table():
    assert set(all_generators()) == set(SEEDS)


@pytest.mark.parametrize("generator", list(SEEDS))
def test_the_text_round_trips_exactly(puzzles, generator):
    puzzle = puzzles[generator]
    record = puzzle_record(puzzle, {"phyrogen": "1.2.3"})
    text = record.to_json()
    assert text == metadata_json(puzzle, {"phyrogen": "1.2.3"})  # what write_puzzle writes
    again = PuzzleRecord.from_json(text)
    assert again == record and again.to_json() == text
    assert again.seed == SEEDS[generator] and again.generator == generator
    # No provenance: the first format, unless the Maker said how its blockers were shown needed (format 4).
    assert again.necessity and json.loads(text)["format_version"] == NECESSITY_VERSION == again.format_version
    plain = dataclasses.replace(again, objects=tuple(dataclasses.replace(o, necessity=None) for o in again.objects))
    assert json.loads(plain.to_json())["format_version"] == 1 == plain.format_version
    with pytest.raises(dataclasses.FrozenInstanceError):
        again.seed = 1  # type: ignore[misc]
    with pytest.raises(TypeError):
        again.parameters["x"] = 1  # type: ignore[index]


def _without_necessity(record: PuzzleRecord) -> PuzzleRecord:
    return dataclasses.replace(record, objects=tuple(dataclasses.replace(o, necessity=None) for o in record.objects))


def test_a_record_with_provenance_is_written_as_the_new_format(puzzles):
    record = _without_necessity(puzzle_record(puzzles["grid_world"]))
    run = PlannerRun("rrt_connect", 1000, 7, 250)
    replanned = dataclasses.replace(record, provenance=dataclasses.replace(record.provenance, replanned=run))
    data = json.loads(replanned.to_json())
    assert data["format_version"] == PROVENANCE_VERSION == 2  # (version 3 only with a difficulty)
    assert data["provenance"] == {"replanned": {"planner": "rrt_connect", "budget": 1000, "seed": 7, "queries": 250}}
    assert PuzzleRecord.from_json(replanned.to_json()) == replanned


def _first_format(data: dict) -> dict:
    """``data`` as the writer before the record wrote it: provenance in two places, or no version at all,
    and no object's necessity (format 4)."""
    old = json.loads(json.dumps(data))
    for entry in old["objects"]:
        entry.pop("necessity", None)
    return old


def test_a_file_of_the_first_format_is_upgraded_when_read(puzzles, tmp_path):
    folder = write_puzzle(puzzles["simple_slider"], tmp_path)
    data = json.loads((folder / "puzzle.json").read_text())
    old = _first_format(data)
    del old["format_version"]  # files older still had none
    old["replanned_by"] = {"planner": "la_rrt_push", "budget": 100000, "seed": 123, "queries": 4567}
    (folder / "puzzle.json").write_text(json.dumps(old, sort_keys=True, indent=2) + "\n")
    record = read_puzzle_dir(folder).record
    assert record.provenance.replanned == PlannerRun("la_rrt_push", 100000, 123, 4567)
    upgraded = json.loads(record.to_json())
    assert "replanned_by" not in upgraded and upgraded["format_version"] == 2
    assert upgraded["provenance"]["replanned"]["queries"] == 4567
    assert {k: v for k, v in upgraded.items() if k not in ("provenance", "format_version")} == {
        k: v for k, v in old.items() if k != "replanned_by"}


def test_an_imported_file_of_the_first_format_moves_source_and_certifier_into_provenance(puzzles):
    old = _first_format(puzzle_record(puzzles["simple_slider"]).to_dict())
    old.update(generator="imported", format_version=1)
    old["parameters"] = {"goal_from": "goal link", "notes": ["a note"],
                         "source": {"file": "door.urdf", "sha256": "ab" * 32, "robot": "door"},
                         "certified_by": {"planner": "la_rrt_push", "budget": 100000, "seed": 9, "queries": 40}}
    record = PuzzleRecord.from_dict(old)
    assert dict(record.parameters) == {"goal_from": "goal link", "notes": ["a note"]}
    assert record.provenance.certified == PlannerRun("la_rrt_push", 100000, 9, 40)
    imported = record.provenance.imported
    assert (imported.file, imported.sha256, imported.robot, imported.joints) == ("door.urdf", "ab" * 32, "door", ())
    assert PuzzleRecord.from_json(record.to_json()) == record


def _refused(data: dict, key: str) -> str:
    with pytest.raises(PuzzleFormatError) as caught:
        PuzzleRecord.from_dict(data, "x/puzzle.json")
    message = str(caught.value)
    assert message.startswith("x/puzzle.json: ") and key in message and "\n" not in message
    return message


@pytest.mark.parametrize("edit, key", [
    (lambda d: d["start"].__setitem__(0, math.nan), "start[0]"),
    (lambda d: d["certificate"][1].__setitem__(0, math.inf), "certificate[1][0]"),
    (lambda d: d["goal"].__setitem__("tolerance", math.nan), "goal.tolerance"),
    (lambda d: d["parameters"].__setitem__("gap", math.nan), "parameters.gap"),
    (lambda d: d["joint_limits"]["obj_00"].__setitem__("upper", math.nan), "joint_limits.obj_00.upper"),
    (lambda d: d["objects"][1].__setitem__("interlock_margin", math.inf), "objects[1].interlock_margin"),
    (lambda d: d.__setitem__("seed", "7"), "seed"),
    (lambda d: d.__setitem__("seed", True), "seed"),
    (lambda d: d.__setitem__("certificate_actions", 2.0), "certificate_actions"),
    (lambda d: d.__setitem__("certificate_verified", "no"), "certificate_verified"),
    (lambda d: d["objects"][0].__setitem__("motion", "hover"), "objects[0].motion"),
    (lambda d: d["joint_limits"]["obj_00"].__setitem__("type", "continuous"), "joint_limits.obj_00.type"),
    (lambda d: d["dependency_graph"]["edges"].append(["a"]), "dependency_graph.edges"),
    (lambda d: d["versions"].__setitem__("numpy", 2), "versions.numpy"),
    (lambda d: d.__setitem__("format_version", FORMAT_VERSION + 1), "format_version"),
    (lambda d: d.__setitem__("provenance", {"replanned": {"planner": "x", "budget": 1, "seed": 1,
                                                          "queries": "many"}}), "provenance.replanned.queries"),
    (lambda d: d.pop("certificate_actions"), "'certificate_actions'"),
    (lambda d: d.pop("goal"), "'goal'"),
    (lambda d: d["goal"].pop("target"), "'goal.target'"),
    (lambda d: d.__setitem__("colour", "red"), "'colour'"),
])
def test_bad_values_are_refused_naming_the_key(edit, key):
    from hostile_support import hostile_puzzle

    data = puzzle_record(hostile_puzzle()).to_dict()
    data["parameters"]["gap"] = 0.1
    data["format_version"] = 2
    edit(data)
    _refused(data, key)


def test_a_version_1_file_may_not_use_the_new_key():
    from hostile_support import hostile_puzzle

    data = puzzle_record(hostile_puzzle()).to_dict()
    data["provenance"] = {}
    assert "provenance" in _refused(data, "format_version 2")

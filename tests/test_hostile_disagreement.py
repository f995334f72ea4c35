"""Hostile input, class 2: a puzzle folder whose parts disagree, or whose certificate proves nothing.

``puzzle.json`` must agree with the URDF and with itself: ``joint_limits``
states every active joint of the URDF (type, lower, upper) and nothing else;
``start`` lies within the limits and is the start state every planner uses
(each joint at 0 clipped into its limits); the goal's target is an object,
its joints are active joints, its values reachable, its tolerance positive
and below a tenth of each goal joint's range, and the start is not already in
it. A folder that breaks this is a :class:`PuzzleFormatError` naming
``puzzle.json`` and the field (``phyrogen check``: one line, exit 2).

``solver.planning.problem.verify_certificate`` (what ``phyrogen check`` runs) holds a
certificate to the same rules: it must begin at the start state, stay within
the limits, end in a sensible goal; a check that would take more than
``MAX_CHECKED_STATES`` states is refused, not attempted.

The cases change every joint in turn, every field of every ``joint_limits``
entry, and the URDF side as well as the metadata side.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from hostile_support import (
    assert_cli_rejects,
    cli_check,
    copy_folder,
    edit_json,
    format_error,
    hostile_puzzle,
    urdf_file,
    written,  # noqa: F401 (fixture)
)

import solver.planning.problem
from phyrogen_core.export import read_puzzle_dir
from phyrogen_core.export.metadata import record_for_chain
from phyrogen_core.export.output import write_export_files
from phyrogen_core.export.reader import GOAL_TOLERANCE_SHARE, goal_problems, start_state
from phyrogen_core.folder import PuzzleFolder
from phyrogen_core.puzzle import Goal, Puzzle
from phyrogen_core.record import PuzzleRecord
from solver.planning.problem import verify_certificate

PUZZLE = hostile_puzzle()
JOINTS = PUZZLE.joint_order
LIMITS = {j.name: (j.type.value, j.lower, j.upper) for j in PUZZLE.planning_chain.active_joints}
OTHER_TYPE = {"prismatic": "revolute", "revolute": "prismatic"}


def _json_rejects(written, tmp_path, change, *fragments: str) -> str:  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    edit_json(folder, change)
    message = format_error(lambda: read_puzzle_dir(folder))
    assert message.startswith(f"{folder / 'puzzle.json'}: "), message
    for fragment in fragments:
        assert fragment in message, (fragment, message)
    return message


# -- joint_limits against the URDF ------------------------------------------------------------
@pytest.mark.parametrize("joint", JOINTS)
@pytest.mark.parametrize(
    "change",
    [
        lambda entry: entry.__setitem__("type", OTHER_TYPE[entry["type"]]),
        lambda entry: entry.__setitem__("type", "fixed"),
        lambda entry: entry.__setitem__("lower", entry["lower"] - 0.5),
        lambda entry: entry.__setitem__("upper", entry["upper"] + 0.5),
        lambda entry: entry.__setitem__("lower", entry["upper"] + 1.0),
        lambda entry: entry.__setitem__("upper", entry["lower"]),
    ],
    ids=["other-type", "fixed", "lower", "upper", "lower-above-upper", "zero-width"],
)
def test_joint_limits_must_match_the_urdf(written, tmp_path, joint, change):  # noqa: F811
    _json_rejects(written, tmp_path, lambda m: change(m["joint_limits"][joint]), f"joint_limits.{joint}")


@pytest.mark.parametrize("joint", JOINTS)
def test_joint_limits_must_name_every_active_joint(written, tmp_path, joint):  # noqa: F811
    _json_rejects(written, tmp_path, lambda m: m["joint_limits"].pop(joint), "joint_limits names the joints")


@pytest.mark.parametrize(
    ("change", "fragment"),
    [
        (lambda m: m["joint_limits"].__setitem__("ghost", {"type": "prismatic", "lower": 0, "upper": 1}),
         "joint_limits names the joints"),
        (lambda m: m.pop("joint_limits"), "missing key 'joint_limits'"),
        (lambda m: m.__setitem__("joint_limits", [0, 1]), "joint_limits must be a dict"),
        (lambda m: m["joint_limits"].__setitem__(JOINTS[0], [0, 1]), f"joint_limits.{JOINTS[0]} must be an object"),
        (lambda m: m["joint_limits"][JOINTS[0]].pop("upper"), f"joint_limits.{JOINTS[0]}.upper must be a number"),
        (lambda m: m["joint_limits"][JOINTS[0]].pop("type"), f"missing key 'joint_limits.{JOINTS[0]}.type'"),
    ],
)
def test_joint_limits_must_be_complete(written, tmp_path, change, fragment):  # noqa: F811
    _json_rejects(written, tmp_path, change, fragment)


@pytest.mark.parametrize("joint", JOINTS)
@pytest.mark.parametrize("attribute", ["lower", "upper", "type"])
def test_a_urdf_edited_without_its_metadata_is_rejected(written, tmp_path, joint, attribute):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    urdf = urdf_file(folder)
    text = urdf.read_text()
    kind, lower, upper = LIMITS[joint]
    element = re.search(rf'<joint name="{joint}" type="{kind}">.*?</joint>', text, re.S)
    assert element is not None
    old = element.group(0)
    if attribute == "type":
        new = old.replace(f'type="{kind}"', f'type="{OTHER_TYPE[kind]}"', 1)
    else:
        value = lower - 0.25 if attribute == "lower" else upper + 0.25
        new = re.sub(rf'{attribute}="[^"]*"', f'{attribute}="{value!r}"', old, count=1)
    assert new != old
    urdf.write_text(text.replace(old, new))
    message = format_error(lambda: read_puzzle_dir(folder))
    assert message.startswith(f"{folder / 'puzzle.json'}: joint_limits.{joint} says "), message


# -- start -------------------------------------------------------------------------------------
@pytest.mark.parametrize("index", range(len(JOINTS)))
def test_start_must_be_the_planners_start_state(written, tmp_path, index):  # noqa: F811
    _json_rejects(written, tmp_path, lambda m: m["start"].__setitem__(index, 0.5), f"start[{index}]",
                  "is not the start state every planner uses")


@pytest.mark.parametrize("index", range(len(JOINTS)))
@pytest.mark.parametrize("side", ["below", "above"])
def test_start_must_lie_within_the_limits(written, tmp_path, index, side):  # noqa: F811
    _, lower, upper = LIMITS[JOINTS[index]]
    value = lower - 0.5 if side == "below" else upper + 0.5
    _json_rejects(written, tmp_path, lambda m: m["start"].__setitem__(index, value), f"start[{index}]",
                  "lies outside the joint's limits")


@pytest.mark.parametrize("change", [lambda s: s.pop(), lambda s: s.append(0.0), lambda s: s.clear()],
                         ids=["short", "long", "empty"])
def test_start_must_have_one_value_per_joint(written, tmp_path, change):  # noqa: F811
    _json_rejects(written, tmp_path, lambda m: change(m["start"]), "start must be a list of 5 numbers")


def test_start_state_is_zero_clipped_into_the_limits():
    chain = PUZZLE.planning_chain
    assert start_state(chain) == PUZZLE.start
    from phyrogen_core.chain import Joint, KinematicChain

    shifted = KinematicChain(chain.links, tuple(
        Joint(j.name, j.type, j.parent, j.child, j.origin, j.axis, 0.25, 0.75) if j.name == "obj_00" else j
        for j in chain.joints), chain.root, chain.name)
    assert start_state(shifted)[JOINTS.index("obj_00")] == 0.25


# -- goal --------------------------------------------------------------------------------------
RANGE = LIMITS["obj_00"][2] - LIMITS["obj_00"][1]


@pytest.mark.parametrize(
    ("change", "fragment"),
    [
        (lambda g: g.__setitem__("tolerance", 0.0), "must be a finite positive number"),
        (lambda g: g.__setitem__("tolerance", -1e-3), "must be a finite positive number"),
        (lambda g: g.__setitem__("tolerance", GOAL_TOLERANCE_SHARE * RANGE), "is not small against"),
        (lambda g: g.__setitem__("tolerance", 0.5), "is not small against"),
        (lambda g: g.__setitem__("tolerance", 1e5), "is not small against"),
        (lambda g: g.__setitem__("tolerance", 1e9), "must be a finite number within"),
        (lambda g: g["values"].__setitem__("obj_00", 1.5), "lies outside its limits"),
        (lambda g: g["values"].__setitem__("obj_00", -0.5), "lies outside its limits"),
        (lambda g: g["values"].__setitem__("obj_00", 0.0), "the start state is already in the goal"),
        # 0.15 is small against obj_02_x's range (2), not against obj_00's (1): every goal joint counts.
        (lambda g: (g["values"].__setitem__("obj_02_x", 0.5), g.__setitem__("tolerance", 0.15)),
         "is not small against joint 'obj_00'"),
        (lambda g: g["values"].__setitem__("ghost", 0.5), "goal joint 'ghost' is not in joint_order"),
        (lambda g: g["values"].clear(), "constrains no joint"),
        (lambda g: g.__setitem__("target", "ghost"), "goal.target 'ghost' is not one of the objects"),
        (lambda g: g.pop("tolerance"), "goal.tolerance must be a number"),
    ],
)
def test_the_goal_must_be_sensible(written, tmp_path, change, fragment):  # noqa: F811
    _json_rejects(written, tmp_path, lambda m: change(m["goal"]), fragment)


@pytest.mark.parametrize("tolerance", [1e-9, 1e-3, 0.099 * RANGE])
def test_small_goal_tolerances_are_accepted(written, tmp_path, tolerance):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    edit_json(folder, lambda m: m["goal"].__setitem__("tolerance", tolerance))
    assert read_puzzle_dir(folder).goal.tolerance == tolerance


def test_goal_problems_checks_every_goal_joint():
    chain = PUZZLE.planning_chain
    assert goal_problems(PUZZLE.goal, chain, PUZZLE.start) == []
    # obj_02_yaw's range is 6.28: 0.5 is fine for it, not for obj_00 (range 1).
    goal = Goal("obj_00", {"obj_02_yaw": 1.0, "obj_00": 1.0}, 0.5)
    assert [p for p in goal_problems(goal, chain) if "not small" in p] == [
        f"tolerance 0.5 is not small against joint 'obj_00''s range 1.0: it must be less than "
        f"{GOAL_TOLERANCE_SHARE} x the range"]


# -- the certificate check --------------------------------------------------------------------
def _loaded(written):  # noqa: F811
    loaded = read_puzzle_dir(written)
    assert verify_certificate(loaded.chain, loaded.certificate, loaded.goal) == []
    return loaded


@pytest.mark.parametrize("index", range(len(JOINTS)))
def test_a_certificate_must_begin_at_the_start_state(written, index):  # noqa: F811
    loaded = _loaded(written)
    path = np.array(loaded.certificate)
    path[0, index] += 0.25
    problems = verify_certificate(loaded.chain, path, loaded.goal)
    assert any(p.startswith(f"certificate does not begin at the start state (joint {JOINTS[index]!r}")
               for p in problems), problems


def test_a_certificate_is_checked_against_a_given_start(written):  # noqa: F811
    loaded = _loaded(written)
    start = np.array(loaded.start)
    start[1] = 0.25  # obj_01, a disc far from everything
    path = np.array(loaded.certificate)
    assert any("does not begin" in p for p in verify_certificate(loaded.chain, path, loaded.goal, start=start))
    path[:, 1] = 0.25
    assert verify_certificate(loaded.chain, path, loaded.goal, start=start) == []
    assert any("does not begin" in p for p in verify_certificate(loaded.chain, path, loaded.goal))


@pytest.mark.parametrize("index", range(len(JOINTS)))
@pytest.mark.parametrize("side", ["below", "above"])
def test_a_certificate_must_stay_within_the_limits(written, index, side):  # noqa: F811
    loaded = _loaded(written)
    _, lower, upper = LIMITS[JOINTS[index]]
    path = np.array(loaded.certificate)
    path[-1, index] = lower - 0.01 if side == "below" else upper + 0.01
    problems = verify_certificate(loaded.chain, path, loaded.goal)
    assert any(p.startswith(f"certificate leaves the joint limits (state 1, joint {JOINTS[index]!r}")
               for p in problems), problems


def test_a_certificate_must_end_in_the_goal(written):  # noqa: F811
    loaded = _loaded(written)
    assert verify_certificate(loaded.chain, loaded.certificate[:1], loaded.goal) == [
        "certificate does not end in the goal"]
    path = np.array(loaded.certificate)
    path[-1, 0] = 0.9
    assert verify_certificate(loaded.chain, path, loaded.goal) == ["certificate does not end in the goal"]


@pytest.mark.parametrize("tolerance", [1e9, 1.0, 0.2])
def test_a_huge_goal_tolerance_does_not_make_a_one_state_certificate_valid(written, tolerance):  # noqa: F811
    loaded = _loaded(written)
    goal = Goal(loaded.goal.target, loaded.goal.values, tolerance)
    problems = verify_certificate(loaded.chain, loaded.certificate[:1], goal)
    assert any("is not small against" in p for p in problems), problems


def test_a_goal_at_the_start_does_not_make_a_one_state_certificate_valid(written):  # noqa: F811
    loaded = _loaded(written)
    goal = Goal(loaded.goal.target, {"obj_00": 0.0}, loaded.goal.tolerance)
    assert verify_certificate(loaded.chain, loaded.certificate[:1], goal) == [
        "goal: the start state is already in the goal"]


@pytest.mark.parametrize("path", [[], [[]], [[0.0, 0.0]], [[0.0] * 5, [0.0] * 4], [["a"] * 5]],
                         ids=["empty", "empty-state", "short-state", "ragged", "text"])
def test_a_malformed_certificate_is_reported_not_raised(written, path):  # noqa: F811
    loaded = _loaded(written)
    problems = verify_certificate(loaded.chain, path, loaded.goal)
    assert len(problems) == 1 and problems[0].startswith("certificate"), problems


def test_a_check_too_long_to_run_is_refused(written, monkeypatch):  # noqa: F811
    loaded = _loaded(written)
    monkeypatch.setattr(solver.planning.problem, "MAX_CHECKED_STATES", 10)
    problems = verify_certificate(loaded.chain, loaded.certificate, loaded.goal)
    assert len(problems) == 1 and "more than the 10 a check may take" in problems[0], problems


# -- the command line and the writers ----------------------------------------------------------
def test_check_reports_a_certificate_off_the_start_as_invalid(written, tmp_path):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    edit_json(folder, lambda m: m["certificate"][0].__setitem__(1, 0.5))
    code, out, err = cli_check(folder)
    assert code == 1 and err == "", (code, out, err)
    assert "INVALID" in out and "does not begin at the start state (joint 'obj_01'" in out


@pytest.mark.parametrize(
    ("change", "fragment"),
    [
        (lambda m: m["start"].__setitem__(0, 0.5), "start[0]"),
        (lambda m: m["joint_limits"]["obj_00"].__setitem__("upper", 5.0), "joint_limits.obj_00"),
        (lambda m: m["goal"].__setitem__("tolerance", 1e5), "goal: tolerance"),
        (lambda m: (m["goal"].__setitem__("tolerance", 1e5), m.__setitem__("certificate", [m["start"]])),
         "goal: tolerance"),
    ],
)
def test_check_rejects_a_disagreeing_folder_with_one_line(written, tmp_path, change, fragment):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    edit_json(folder, change)
    assert_cli_rejects(folder, "puzzle.json", fragment)


def test_an_edited_puzzle_written_by_the_panel_reads(written, tmp_path):  # noqa: F811
    stored = PuzzleRecord.from_json((written / "puzzle.json").read_text())
    # Same joints: the certificate is kept, marked as not verified.
    same = PUZZLE.chain
    place = PuzzleFolder(tmp_path / "same", stored.name)
    write_export_files(place, same, record_for_chain(stored, same).to_json())
    loaded = read_puzzle_dir(place.path)
    assert loaded.record.certificate_verified is False and len(loaded.certificate) == 2
    # One object fewer: a new start state for the new joints, no certificate.
    fewer = Puzzle(tuple(o for o in PUZZLE.objects if o.name != "obj_02"), PUZZLE.goal, "hostile", 1).chain
    place = PuzzleFolder(tmp_path / "fewer", stored.name)
    write_export_files(place, fewer, record_for_chain(stored, fewer).to_json())
    loaded = read_puzzle_dir(place.path)
    assert loaded.joint_order == ("obj_00", "obj_01") and loaded.certificate == ()

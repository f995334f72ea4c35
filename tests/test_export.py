"""Export: URDF/SRDF/puzzle.json written from the chain, checked against PyBullet and read back."""

from __future__ import annotations

import dataclasses
import json
import math
import os
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from phyrogen_core import __version__
from phyrogen_core.chain import GREEN, RED, YELLOW, Geometry, KinematicChain, Role, pose_matrix
from phyrogen_core.export import (
    PuzzleFormatError,
    atomic_directory,
    chain_to_srdf,
    chain_to_urdf,
    metadata_json,
    puzzle_metadata,
    read_puzzle_dir,
    write_puzzle,
)
from phyrogen_core.export import output as output_module
from phyrogen_core.geometry import Box, ConvexPrism, Cylinder, Pose, slot_disc
from phyrogen_core.objects import Motion, PuzzleObject, build_chain
from phyrogen_core.puzzle import Goal, Puzzle

# Bullet pads the bounds of cylinders and convex meshes by its collision margin (4 mm here),
# in the link frame, before turning them into world bounds: up to sqrt(3) times that.
BULLET_MARGIN = 0.008


@dataclasses.dataclass(frozen=True)
class Params:
    size: int = 3
    mode: str = "easy"


def sample_objects() -> tuple[PuzzleObject, ...]:
    robot = Box((0.375, 0.5, 0.5))
    slider = Box((1.4, 0.2, 1.0))
    bar = Box((1.2, 0.2, 0.4))
    disc = slot_disc(0.6, 0.3, sides=16)
    wall = Box((0.1, 2.0, 0.5))
    return (
        PuzzleObject("robot", Motion.SE2, Pose.planar(0.2, -0.3, 0.25, 0.4),
                     (Geometry(robot, color=GREEN, name="body"),),
                     (Geometry(robot, color=GREEN, name="body"),), Role.TARGET,
                     ((-2.0, 2.0), (-1.5, 0.5), (-math.pi, math.pi))),
        PuzzleObject("slider", Motion.PRISMATIC, Pose.planar(1.0, 1.0, 0.5, math.pi / 2),
                     (Geometry(slider, color=RED),
                      Geometry(Box((0.05, 0.05, 0.2)), Pose((0.3, 0.0, 0.6)), YELLOW)),
                     (Geometry(slider, color=RED),), Role.BLOCKER, ((0.0, 1.0),), (1.0, 0.0, 0.0)),
        # A bar turning about a hinge at one end: the hinge is drawn but does not collide.
        PuzzleObject("bar", Motion.REVOLUTE, Pose.planar(-1.0, 1.5, 0.2, -0.3),
                     (Geometry(bar, Pose((0.6, 0.0, 0.0))), Geometry(Cylinder(0.05, 0.5), color=YELLOW)),
                     (Geometry(bar, Pose((0.6, 0.0, 0.0))),), Role.BLOCKER, ((-math.pi / 2, 0.0),)),
        PuzzleObject("disc", Motion.REVOLUTE, Pose.planar(-1.5, -1.0, 0.15, 0.25),
                     (Geometry(disc),), (Geometry(disc),), Role.BLOCKER, ((-math.pi, math.pi),)),
        # A fixed wall with a lying cylinder on top: a collision shape that is not vertical.
        PuzzleObject("wall", Motion.FIXED, Pose.planar(2.5, 0.0, 0.25),
                     (Geometry(wall),),
                     (Geometry(wall),
                      Geometry(Cylinder(0.05, 1.8), Pose((0.0, 0.0, 0.3), (math.pi / 2, 0.0, 0.0)))),
                     Role.STATIC),
    )


def sample_puzzle(seed: int = 7) -> Puzzle:
    objects = sample_objects()
    order = build_chain(objects).joint_order
    goal = Goal("robot", {"robot_x": 1.5, "robot_y": -1.5, "robot_yaw": -0.5})
    halfway = [0.0] * len(order)
    halfway[order.index("robot_x")] = 0.75
    end = list(halfway)
    end[order.index("robot_x")], end[order.index("robot_y")], end[order.index("robot_yaw")] = 1.5, -1.5, -0.5
    return Puzzle(objects, goal, "sample", seed, Params(), (("slider", "robot"), ("bar", "slider")),
                  (tuple(0.0 for _ in order), tuple(halfway), tuple(end)))


# -- helpers -------------------------------------------------------------------
def shape_corners(geometry: Geometry) -> np.ndarray:
    """Points whose bounds are the shape's bounds as Bullet computes them (cylinders by their box)."""
    shape = geometry.shape
    if isinstance(shape, Box):
        half = np.asarray(shape.size) / 2
        return np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    if isinstance(shape, Cylinder):
        half = np.array([shape.radius, shape.radius, shape.length / 2])
        return np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    assert isinstance(shape, ConvexPrism)
    h = shape.height / 2
    return np.array([(x, y, z) for piece in shape.pieces for x, y in piece for z in (-h, h)])


def chain_bounds(chain: KinematicChain, state: dict[str, float], link_name: str
                 ) -> tuple[np.ndarray, np.ndarray]:
    """World bounds of a link's collision shapes, computed the way Bullet does.

    Bullet keeps a link's shapes in one compound whose box in the link frame
    it then carries into the world, so the world bounds are those of that box.
    """
    points = []
    for geometry in chain.link(link_name).collisions:
        m = pose_matrix(geometry.origin)
        points.append(shape_corners(geometry) @ m[:3, :3].T + m[:3, 3])
    stacked = np.vstack(points)
    low, high = stacked.min(axis=0), stacked.max(axis=0)
    box = np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1])
                    for z in (low[2], high[2])])
    world = chain.link_transforms(state)[link_name]
    moved = box @ world[:3, :3].T + world[:3, 3]
    return moved.min(axis=0), moved.max(axis=0)


def assert_same(a, b, where: str = "") -> None:
    """Dataclasses field by field, floats within 1e-9."""
    if dataclasses.is_dataclass(a):
        assert type(a) is type(b), where
        for f in dataclasses.fields(a):
            if f.compare:
                assert_same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, tuple | list):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_same(x, y, f"{where}[{i}]")
    elif isinstance(a, float | int) and not isinstance(a, bool):
        assert b == pytest.approx(a, abs=1e-9), where
    else:
        assert a == b, where


def all_files(folder: Path) -> dict[str, bytes]:
    return {str(f.relative_to(folder)): f.read_bytes() for f in sorted(folder.rglob("*")) if f.is_file()}


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> Path:
    return write_puzzle(sample_puzzle(), tmp_path_factory.mktemp("out"))


@pytest.fixture
def bullet(written, tmp_path, monkeypatch):
    """The written URDF loaded in PyBullet, from a different working directory."""
    monkeypatch.chdir(tmp_path)
    client = p.connect(p.DIRECT)
    try:
        body = p.loadURDF(str(written / "urdf" / "sample_7.urdf"), useFixedBase=True, physicsClientId=client)
        yield client, body
    finally:
        p.disconnect(client)


def bullet_joints(client: int, body: int) -> dict[str, tuple]:
    infos = [p.getJointInfo(body, i, physicsClientId=client) for i in range(p.getNumJoints(body, client))]
    return {info[1].decode(): info for info in infos}


# -- URDF ----------------------------------------------------------------------
def test_output_layout_uses_relative_mesh_paths(written):
    assert written.name == "sample_7" and written.parent.name == "sample"
    names = set(all_files(written))
    assert {"urdf/sample_7.urdf", "srdf/sample_7.srdf", "puzzle.json"} <= names
    meshes = {n for n in names if n.startswith("meshes/")}
    assert len(meshes) == 2 * 3  # the disc's three pieces, as visual and as collision
    text = (written / "urdf" / "sample_7.urdf").read_text()
    assert str(written) not in text and 'filename="../meshes/disc_collision_0_0.obj"' in text


def test_pybullet_loads_urdf_with_our_joints_and_limits(bullet):
    client, body = bullet
    chain = sample_puzzle().chain
    joints = bullet_joints(client, body)
    assert sorted(joints) == sorted(j.name for j in chain.joints)
    types = {p.JOINT_FIXED: "fixed", p.JOINT_PRISMATIC: "prismatic", p.JOINT_REVOLUTE: "revolute"}
    for joint in chain.joints:
        info = joints[joint.name]
        assert types[info[2]] == joint.type.value
        assert info[12].decode() == joint.child
        if joint.is_active:
            assert (info[8], info[9]) == pytest.approx((joint.lower, joint.upper), abs=1e-12)
            assert info[13] == pytest.approx(joint.axis, abs=1e-12)


def test_pybullet_link_bounds_match_chain_in_random_states(bullet):
    client, body = bullet
    chain = sample_puzzle().chain
    joints = bullet_joints(client, body)
    rng = np.random.default_rng(20240601)
    colliding = [link.name for link in chain.links if link.collisions]
    assert len(colliding) == 5
    for _ in range(6):
        state = {j.name: float(rng.uniform(j.lower, j.upper)) for j in chain.active_joints}
        for name, value in state.items():
            p.resetJointState(body, joints[name][0], value, physicsClientId=client)
        for link_name in colliding:
            index = next(info[0] for info in joints.values() if info[12].decode() == link_name)
            low, high = (np.array(v) for v in p.getAABB(body, index, physicsClientId=client))
            want_low, want_high = chain_bounds(chain, state, link_name)
            # Bullet's bounds contain ours and exceed them by at most its margin.
            assert np.all(low <= want_low + 1e-6) and np.all(low >= want_low - BULLET_MARGIN), link_name
            assert np.all(high >= want_high - 1e-6) and np.all(high <= want_high + BULLET_MARGIN), link_name


def test_prism_meshes_are_closed_with_outward_faces(written):
    disc = slot_disc(0.6, 0.3, sides=16)
    for index, piece in enumerate(disc.pieces):
        lines = (written / "meshes" / f"disc_collision_0_{index}.obj").read_text().splitlines()
        vertices = np.array([[float(v) for v in line.split()[1:]] for line in lines if line.startswith("v ")])
        faces = [[int(v) - 1 for v in line.split()[1:]] for line in lines if line.startswith("f ")]
        edges = [(f[i], f[(i + 1) % len(f)]) for f in faces for i in range(len(f))]
        # Closed and consistently wound: every directed edge appears once, its reverse once.
        assert len(set(edges)) == len(edges)
        assert all((b, a) in set(edges) for a, b in edges)
        volume = sum(np.dot(vertices[f[0]], np.cross(vertices[f[1]], vertices[f[2]])) for f in faces) / 6
        ring = zip(piece, piece[1:] + piece[:1], strict=True)
        area = 0.5 * sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in ring)
        assert volume == pytest.approx(area * disc.height, rel=1e-9)  # positive: normals point out


def test_equal_chains_give_identical_urdf_and_negative_zero_is_normalized():
    flipped = dataclasses.replace(sample_objects()[4], pose=Pose((2.5, -0.0, 0.25), (0.0, -0.0, -0.0)))
    objects = sample_objects()
    assert chain_to_urdf(build_chain(objects)) == chain_to_urdf(build_chain(sample_objects()))
    assert chain_to_urdf(build_chain(objects[:4] + (flipped,))) == chain_to_urdf(build_chain(objects))
    assert "-0 " not in chain_to_urdf(build_chain(objects[:4] + (flipped,)))[0]


def test_every_link_has_inertial_and_every_visual_a_named_colour():
    import xml.etree.ElementTree as ET

    chain = sample_puzzle().chain
    robot = ET.fromstring(chain_to_urdf(chain)[0])
    for link in robot.findall("link"):
        mass = float(link.find("inertial/mass").get("value"))
        assert mass == chain.link(link.get("name")).mass
        inertia = link.find("inertial/inertia")
        diagonal = [float(inertia.get(k)) for k in ("ixx", "iyy", "izz")]
        assert all(v > 0 for v in diagonal) or mass == 0
        for visual in link.findall("visual"):
            assert visual.find("material").get("name")
            assert len(visual.find("material/color").get("rgba").split()) == 4
    goal = robot.find("link[@name='goal']")
    assert goal.findall("visual") and not goal.findall("collision")


# -- SRDF ----------------------------------------------------------------------
def test_srdf_has_one_group_per_moving_object_and_adjacent_pairs(written):
    import xml.etree.ElementTree as ET

    chain = sample_puzzle().chain
    root = ET.parse(written / "srdf" / "sample_7.srdf").getroot()
    groups = {g.get("name"): [j.get("name") for j in g.findall("joint")] for g in root.findall("group")}
    assert groups == {"bar": ["bar"], "disc": ["disc"], "robot": ["robot_x", "robot_y", "robot_yaw"],
                      "slider": ["slider"]}
    pairs = {(d.get("link1"), d.get("link2")) for d in root.findall("disable_collisions")}
    assert pairs == {(j.parent, j.child) for j in chain.joints}
    assert {d.get("reason") for d in root.findall("disable_collisions")} == {"Adjacent"}
    assert chain_to_srdf(chain) == chain_to_srdf(sample_puzzle().chain)


# -- puzzle.json ---------------------------------------------------------------
def test_metadata_records_problem_and_provenance():
    puzzle = sample_puzzle()
    data = json.loads(metadata_json(puzzle))
    assert data == puzzle_metadata(puzzle)
    assert data["parameters"] == {"size": 3, "mode": "easy"}
    assert (data["generator"], data["seed"], data["name"]) == ("sample", 7, "sample_7")
    assert data["joint_order"] == list(puzzle.joint_order)
    assert data["joint_limits"]["slider"] == {"type": "prismatic", "lower": 0.0, "upper": 1.0}
    assert data["goal"] == {"target": "robot", "values": {"robot_x": 1.5, "robot_y": -1.5, "robot_yaw": -0.5},
                            "tolerance": puzzle.goal.tolerance}
    assert data["dependency_graph"]["edges"] == [["slider", "robot"], ["bar", "slider"]]
    assert data["objects"][0] == {"name": "robot", "motion": "se2", "role": "target",
                                  "joints": ["robot_x", "robot_y", "robot_yaw"]}
    assert data["certificate"] == [list(s) for s in puzzle.certificate]
    assert data["versions"] == {"phyrogen": __version__}
    assert puzzle_metadata(puzzle, {"phyrogen": "9", "ompl": "2.0.1"})["versions"] == {"phyrogen": "9",
                                                                                       "ompl": "2.0.1"}
    assert metadata_json(puzzle).endswith("}\n")


def test_metadata_rejects_certificate_of_wrong_length():
    puzzle = dataclasses.replace(sample_puzzle(), certificate=((0.0, 1.0),))
    with pytest.raises(ValueError, match="certificate state 0 has 2 values"):
        puzzle_metadata(puzzle)


# -- folders -------------------------------------------------------------------
def test_write_puzzle_twice_gives_identical_bytes(tmp_path, written):
    again = write_puzzle(sample_puzzle(), tmp_path / "a")
    assert all_files(again) == all_files(written)
    (again / "images").mkdir()
    (again / "images" / "x.png").write_bytes(b"png")
    (again / "notes.txt").write_bytes(b"mine")
    replaced = write_puzzle(sample_puzzle(), tmp_path / "a")
    assert replaced == again
    # Another stage's files and a user's are kept: the export stage replaces only its own entries.
    assert all_files(replaced) == {**all_files(written), "images/x.png": b"png", "notes.txt": b"mine"}
    assert [f.name for f in replaced.parent.iterdir()] == ["sample_7"]  # no temporary or old folders


def test_failure_while_writing_leaves_nothing_behind(tmp_path, monkeypatch):
    def broken(chain):
        raise RuntimeError("disk full")

    monkeypatch.setattr(output_module, "chain_to_srdf", broken)
    with pytest.raises(RuntimeError, match="disk full"):
        write_puzzle(sample_puzzle(), tmp_path)
    assert list((tmp_path / "sample").iterdir()) == []


def test_failure_while_replacing_keeps_the_old_folder(tmp_path, monkeypatch):
    folder = write_puzzle(sample_puzzle(), tmp_path)
    before = all_files(folder)

    def broken(puzzle, versions=None, **_):
        raise RuntimeError("interrupted")

    monkeypatch.setattr(output_module, "metadata_json", broken)
    with pytest.raises(RuntimeError, match="interrupted"):
        write_puzzle(sample_puzzle(), tmp_path, {"phyrogen": "other"})
    assert all_files(folder) == before
    assert [f.name for f in folder.parent.iterdir()] == ["sample_7"]


def test_atomic_directory_appears_only_when_complete(tmp_path):
    final = tmp_path / "renders" / "run"
    with atomic_directory(final) as scratch:
        assert scratch.parent == final.parent and scratch.name.startswith(".")
        (scratch / "a.txt").write_text("new")
        assert not final.exists()
    assert (final / "a.txt").read_text() == "new"
    assert os.listdir(final.parent) == ["run"]


# -- reading back ----------------------------------------------------------------
def test_read_puzzle_dir_gives_back_the_chain_and_problem(written):
    puzzle = sample_puzzle()
    loaded = read_puzzle_dir(written)
    expected = puzzle.chain
    assert [link.name for link in loaded.chain.links] == [link.name for link in expected.links]
    for link in expected.links:
        assert_same(loaded.chain.link(link.name), link, link.name)
    assert sorted(j.name for j in loaded.chain.joints) == sorted(j.name for j in expected.joints)
    for joint in expected.joints:
        assert_same(loaded.chain.joint(joint.name), joint, joint.name)
    assert loaded.chain == expected  # numbers are written so that they read back exactly
    assert loaded.joint_order == puzzle.joint_order
    assert loaded.start == puzzle.start
    assert loaded.goal == puzzle.goal
    assert loaded.certificate == puzzle.certificate
    assert loaded.chain.link("robot_base_x").role is Role.HELPER
    assert loaded.chain.link("goal").role is Role.GOAL_MARKER
    assert loaded.record.seed == 7


URDF = Path("urdf") / "sample_7.urdf"


def _copy(written: Path, tmp_path: Path) -> Path:
    target = tmp_path / "copy"
    for name, data in all_files(written).items():
        (target / name).parent.mkdir(parents=True, exist_ok=True)
        (target / name).write_bytes(data)
    return target


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (lambda d: (d / "puzzle.json").unlink(), "puzzle.json is missing"),
        (lambda d: (d / "puzzle.json").write_text("{not json"), "malformed JSON"),
        (lambda d: _edit(d / "puzzle.json", '"joint_order"', '"joints_order"'), "missing key 'joint_order'"),
        (lambda d: _edit(d / "puzzle.json", '"bar",\n    "disc"', '"disc",\n    "bar"'), "does not match"),
        (lambda d: _edit(d / "puzzle.json", '"role": "blocker"', '"role": "boss"'), "'boss' is not valid"),
        (lambda d: (d / URDF).unlink(), "URDF file is missing"),
        (lambda d: _edit(d / URDF, "</robot>", "</robt>"), "malformed XML"),
        (lambda d: _edit(d / URDF, '<parent link="base_link"/>', '<parent link="nowhere"/>'),
         "unknown link 'nowhere'"),
        (lambda d: _edit(d / URDF, '<box size="1.4', '<box size="x1.4'), "must be 3 numbers"),
        (lambda d: _edit(d / URDF, 'effort="100"', 'effort="lots"'), "is not a number"),
        (lambda d: _edit(d / URDF, 'type="revolute"', 'type="continuous"'), "unsupported type 'continuous'"),
        (lambda d: _edit(d / URDF, '<axis xyz="1 0 0"/>', '<axis xyz="2 0 0"/>'), "not a unit vector"),
        (lambda d: (d / "meshes" / "disc_collision_0_1.obj").unlink(), "cannot read mesh"),
        (lambda d: (d / "meshes" / "disc_visual_0_0.obj").write_text("v 0 0 0\n"), "not a convex prism"),
    ],
)
def test_malformed_folders_raise_puzzle_format_error(written, tmp_path, damage, message):
    folder = _copy(written, tmp_path)
    damage(folder)
    with pytest.raises(PuzzleFormatError, match=message):
        read_puzzle_dir(folder)


def test_missing_folder_raises_puzzle_format_error(tmp_path):
    with pytest.raises(PuzzleFormatError, match="no such puzzle folder"):
        read_puzzle_dir(tmp_path / "absent")

"""`phyrogen import URDF`: puzzles made elsewhere become puzzle folders every tool reads.

The fixtures are small URDFs written here, each built like the prototype's
(``ljdross/puzzle-generator``): a door whose panel and handle are fixed to
its hinge link, a slot disc as a binary STL with a mesh scale and an
absolute path from another machine, an SE(2) body whose helper links have
odd names, goals marked by a link named ``goal``. ``docs/import.md`` has the
table of the prototype's own 14 URDFs.
"""

from __future__ import annotations

import json
import math
import struct

import numpy as np
import pytest

from phyrogen.cli import main
from phyrogen_core.export import read_puzzle_dir
from phyrogen_core.geometry import ConvexPrism
from phyrogen_core.mesh_files import read_triangles
from phyrogen_core.objects import Motion
from phyrogen_core.urdf_import import GENERATOR, UrdfImportError, import_urdf
from phyrogen_core.urdf_import.footprint import footprint

# -- writing fixtures ------------------------------------------------------------------


def binary_stl(triangles) -> bytes:
    triangles = np.asarray(triangles, dtype="<f4").reshape(-1, 3, 3)
    records = b"".join(struct.pack("<3f", 0, 0, 0) + t.tobytes() + b"\0\0" for t in triangles)
    return b"binary STL written by a test".ljust(80, b" ") + struct.pack("<I", len(triangles)) + records


def ascii_stl(triangles) -> bytes:
    lines = ["solid test"]
    for t in np.asarray(triangles, dtype=float).reshape(-1, 3, 3):
        lines += ["facet normal 0 0 0", "outer loop", *(f"vertex {x} {y} {z}" for x, y, z in t), "endloop", "endfacet"]
    return ("\n".join(lines + ["endsolid test"]) + "\n").encode()


def prism_triangles(rects, z_low, z_high):
    """A closed prism over a union of axis-aligned rectangles (x0, y0, x1, y1) meeting along edges:
    each rectangle is two top and two bottom triangles; the side walls follow the outline."""
    triangles = []
    edges = {}
    for x0, y0, x1, y1 in rects:
        ring = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
        for a, b, c in ((0, 1, 2), (0, 2, 3)):
            triangles.append([(*ring[a], z_high), (*ring[b], z_high), (*ring[c], z_high)])
            triangles.append([(*ring[a], z_low), (*ring[c], z_low), (*ring[b], z_low)])
        for i in range(4):
            p, q = ring[i], ring[(i + 1) % 4]
            edges[(p, q)] = edges.get((p, q), 0) + 1
    for (p, q), _ in edges.items():
        if (q, p) in edges:
            continue  # an inner edge between two rectangles
        triangles.append([(*p, z_low), (*q, z_low), (*q, z_high)])
        triangles.append([(*p, z_low), (*q, z_high), (*p, z_high)])
    return triangles


def box(size, xyz=(0, 0, 0), rpy=(0, 0, 0), color=None, collision=True) -> str:
    geometry = f'<geometry><box size="{size[0]} {size[1]} {size[2]}"/></geometry>'
    origin = f'<origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/>'
    material = f'<material name="{color}"/>' if color else ""
    out = f"<visual>{origin}{geometry}{material}</visual>"
    return out + (f"<collision>{origin}{geometry}</collision>" if collision else "")


def link(name: str, body: str = "") -> str:
    return f'<link name="{name}">{body}</link>'


def joint(name, kind, parent, child, xyz=(0, 0, 0), yaw=0.0, axis=(0, 0, 1), limits=None) -> str:
    out = (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
           f'<origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" rpy="0 0 {yaw}"/>')
    if kind != "fixed":
        out += (f'<axis xyz="{axis[0]} {axis[1]} {axis[2]}"/>'
                f'<limit lower="{limits[0]}" upper="{limits[1]}" effort="0" velocity="0"/>')
    return out + "</joint>"


def robot(name: str, *parts: str) -> str:
    return (f'<?xml version="1.0"?>\n<robot name="{name}">'
            '<material name="red"><color rgba="1 0 0 1"/></material>' + "".join(parts) + "</robot>\n")


def write_urdf(folder, name, text):
    (folder / "urdf").mkdir(parents=True, exist_ok=True)
    path = folder / "urdf" / f"{name}.urdf"
    path.write_text(text)
    return path


def door_urdf(folder):
    """A door turning about its hinge link; panel, handle and knob are fixed to it (the handle
    overlaps the panel, as the prototype's connectors do); the goal: opened by 90 degrees."""
    return write_urdf(folder, "door", robot(
        "door",
        link("base_link"), link("goal"),
        link("hinge", '<visual><geometry><cylinder radius="0.05" length="0.8"/></geometry></visual>'),
        link("door_panel", box((1.6, 0.1, 0.8), color="red")),
        link("door_handle", box((0.1, 0.3, 0.1))),
        link("door_knob", box((0.1, 0.1, 0.1))),
        link("wall", box((0.2, 2.0, 0.8))), link("floor", box((20, 20, 0.1))),
        joint("floor", "fixed", "base_link", "floor", (0, 0, -0.05)),
        joint("hinge", "revolute", "base_link", "hinge", (0, 0, 0.4), limits=(0, 1.5708)),
        joint("door_panel", "fixed", "hinge", "door_panel", (0.8, 0, 0)),
        joint("door_handle", "fixed", "hinge", "door_handle", (1.2, 0.15, 0)),
        joint("door_knob", "fixed", "door_handle", "door_knob", (0, 0.15, 0)),
        joint("wall", "fixed", "base_link", "wall", (-1.0, 0, 0.4)),
        joint("goal", "fixed", "base_link", "goal", (0, 0, 0.4), yaw=1.5708),
    ))


SLOT_RECTS = [(-0.5, -0.5, -0.125, 0.5), (0.125, -0.5, 0.5, 0.5), (-0.125, -0.5, 0.125, 0.0)]
"""A square disc (unit size before the mesh's scale of 2) with a slot from its centre to its +y edge."""


def lockbox_urdf(folder):
    """A slot disc (binary STL, scale 2 2 1, given by absolute paths of another machine) must turn
    its slot toward the bolt before the bolt (the target) can slide in."""
    (folder / "meshes" / "stl").mkdir(parents=True, exist_ok=True)
    (folder / "meshes" / "stl" / "disc.stl").write_bytes(binary_stl(prism_triangles(SLOT_RECTS, 0.0, 0.5)))
    mesh = ('<geometry><mesh filename="{}" scale="2 2 1"/></geometry>')
    disc = (f'<visual>{mesh.format("file:///home/author/puzzles/lockbox/meshes/stl/disc.stl")}</visual>'
            f'<collision>{mesh.format("package://lockbox/meshes/stl/disc.stl")}</collision>')
    return write_urdf(folder, "lockbox", robot(
        "lockbox",
        link("base_link"), link("goal"), link("disc", disc), link("bolt", box((2.0, 0.3, 0.3), color="red")),
        joint("disc", "revolute", "base_link", "disc", limits=(-1.5708, 0)),
        joint("bolt", "prismatic", "base_link", "bolt", (2.6, 0, 0.25), axis=(-1, 0, 0), limits=(0, 1.6)),
        joint("goal", "fixed", "base_link", "goal", (1.0, 0, 0.25)),
    ))


def se2_urdf(folder, with_goal=True):
    """An SE(2) robot (helper links 'alpha' and 'omega', no names that say x or y; its body a 3D
    ASCII STL pyramid) between two walls; the goal link at (1, 2) turned by 0.5."""
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    apex, base = (0, 0, 0.3), [(-0.2, -0.2, 0), (0.2, -0.2, 0), (0.2, 0.2, 0), (-0.2, 0.2, 0)]
    pyramid = [[base[i], base[(i + 1) % 4], apex] for i in range(4)] + [[base[0], base[2], base[1]],
                                                                     [base[0], base[3], base[2]]]
    (folder / "meshes" / "pyramid.stl").write_bytes(ascii_stl(pyramid))
    mesh = '<geometry><mesh filename="/somewhere/else/pyramid.stl"/></geometry>'
    parts = [
        link("base_link"), link("alpha"), link("omega"),
        link("robot_body", f"<visual>{mesh}</visual><collision>{mesh}</collision>"),
        link("wall_left", box((0.2, 4, 0.5))), link("wall_right", box((0.2, 4, 0.5))),
        joint("j_a", "prismatic", "base_link", "alpha", (0, 0, 0.1), axis=(1, 0, 0), limits=(-2, 2)),
        joint("j_b", "prismatic", "alpha", "omega", axis=(0, 1, 0), limits=(-3, 3)),
        joint("j_c", "revolute", "omega", "robot_body", limits=(-3.1416, 3.1416)),
        joint("wl", "fixed", "base_link", "wall_left", (-2.5, 0, 0.25)),
        joint("wr", "fixed", "base_link", "wall_right", (2.5, 0, 0.25)),
    ]
    if with_goal:
        parts += [link("goal"), joint("goal", "fixed", "base_link", "goal", (1, 2, 0.1), yaw=0.5)]
    return write_urdf(folder, "se2", robot("se2", *parts))


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    """name -> (UrdfImport, folder written by `phyrogen import`)."""
    root = tmp_path_factory.mktemp("import")
    out = root / "out"
    made = {}
    for name, make in (("door", door_urdf), ("lockbox", lockbox_urdf), ("se2", se2_urdf)):
        path = make(root / name)
        assert main(["import", str(path), "--out", str(out)]) == 0
        made[name] = (import_urdf(path), out / GENERATOR / name)
    return made


# -- the folder contract -----------------------------------------------------------------


@pytest.mark.parametrize("name", ["door", "lockbox", "se2"])
def test_the_imported_folder_reads_back_and_its_certificate_checks(imported, name, capsys):
    result, folder = imported[name]
    loaded = read_puzzle_dir(folder)
    assert loaded.record.generator == GENERATOR and loaded.name == name
    assert len(loaded.certificate) >= 2
    capsys.readouterr()
    assert main(["check", str(folder)]) == 0
    assert "certificate valid" in capsys.readouterr().out
    source = loaded.record.provenance.imported
    assert source.file == f"{name}.urdf" and len(source.sha256) == 64 and source.robot == name
    # Every joint of the puzzle maps back to the URDF joint it was made from (the import renames them).
    back = {j.joint: j.urdf_joint for j in source.joints}
    assert set(back) == set(loaded.joint_order)
    assert set(back.values()) == {"door": {"hinge"}, "lockbox": {"disc", "bolt"}, "se2": {"j_a", "j_b", "j_c"}}[name]
    assert back == {m.joint: m.urdf for item in result.objects for m in item.joints}
    assert "source" not in loaded.record.parameters and "certified_by" not in loaded.record.parameters
    assert loaded.record.provenance.certified.planner == "la_rrt_push"


def test_a_door_with_its_panel_handle_and_knob_is_one_object(imported):
    result, folder = imported["door"]
    movable = [item for item in result.objects if item.obj.is_movable]
    assert [item.obj.name for item in movable] == ["hinge"]  # named after its body link (it has a visual)
    door = movable[0]
    assert set(door.links) == {"hinge", "door_panel", "door_handle", "door_knob"}
    assert len(door.obj.collisions) == 3  # panel, handle, knob: the hinge has a visual only
    assert len(door.obj.visuals) == 4
    # The handle sits where its fixed joint put it, in the hinge's frame: (1.2, 0.15), the knob 0.15 further.
    centres = sorted(tuple(round(v, 9) for v in g.origin.xyz[:2]) for g in door.obj.collisions)
    assert centres == [(0.8, 0.0), (1.2, 0.15), (1.2, 0.3)]
    assert result.puzzle.goal.values == {"hinge": 1.5708}
    # The grasp point is marked as generated puzzles mark it, on a part fixed to the hinge, off its axis.
    from manipulation.grasp import grasp_point

    assert sum(g.name == "knob" for g in door.obj.visuals) == 1
    grasp = grasp_point(read_puzzle_dir(folder).chain, "hinge")
    assert grasp.on_knob and math.hypot(*grasp.point[:2]) > 0.5
    # The wall stays; the floor (wholly below everything that moves) is left out, and said so.
    assert sorted(item.obj.name for item in result.objects if not item.obj.is_movable) == ["wall"]
    assert any("'floor' lies wholly below everything that moves" in note for note in result.notes)
    loaded = read_puzzle_dir(folder)
    assert [o.name for o in loaded.record.objects if o.motion != "fixed"] == ["hinge"]
    # Turned to its goal, the knob has swung round the hinge with the door.
    frames = loaded.chain.link_transforms(loaded.certificate[-1])
    knob = frames["hinge"] @ np.array([1.2, 0.3, 0, 1])
    assert np.allclose(knob[:2], [-0.3, 1.2], atol=1e-3)


def test_a_binary_stl_slot_disc_with_a_mesh_scale_and_a_foreign_path(imported):
    result, folder = imported["lockbox"]
    disc = next(item.obj for item in result.objects if item.obj.name == "disc")
    assert disc.motion is Motion.REVOLUTE
    for geometry in disc.visuals + disc.collisions:  # visual and collision alike
        shape = geometry.shape
        assert isinstance(shape, ConvexPrism) and len(shape.pieces) >= 2
        corners = np.array([p for piece in shape.pieces for p in piece])
        assert np.allclose(corners.min(axis=0), [-1, -1]) and np.allclose(corners.max(axis=0), [1, 1])  # scale 2
        area = sum(0.5 * abs(sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(p, p[1:] + p[:1], strict=True)))
                   for p in shape.pieces)
        assert area == pytest.approx(4 - 0.5 * 1.0)  # a 0.5 x 1 slot cut out: an exact prism, not its hull
        assert shape.height == pytest.approx(0.5) and geometry.origin.xyz[2] == pytest.approx(0.25)
    assert any("does not exist here" in note and "disc.stl" in note for note in result.notes)
    assert not any("no extruded outline" in note for note in result.notes)
    assert result.puzzle.goal.target == "bolt" and result.puzzle.goal.values == {"bolt": pytest.approx(1.6)}
    loaded = read_puzzle_dir(folder)
    # The bolt cannot enter before the disc turns its slot toward it: the certificate turns the disc.
    disc_column = loaded.joint_order.index("disc")
    assert min(state[disc_column] for state in loaded.certificate) < -1.0
    assert ("disc", "bolt") in loaded.record.dependency_graph.edges


def test_an_se2_body_is_one_object_whatever_its_helper_links_are_called(imported):
    result, folder = imported["se2"]
    movable = [item for item in result.objects if item.obj.is_movable]
    assert len(movable) == 1 and movable[0].obj.motion is Motion.SE2
    assert set(movable[0].links) == {"alpha", "omega", "robot_body"}
    assert result.puzzle.goal.values == {"robot_body_x": pytest.approx(1.0), "robot_body_y": pytest.approx(2.0),
                                         "robot_body_yaw": pytest.approx(0.5)}
    assert any("no extruded outline" in note and "pyramid.stl" in note for note in result.notes)
    hull = movable[0].obj.collisions[0].shape
    assert isinstance(hull, ConvexPrism) and len(hull.pieces) == 1 and len(hull.pieces[0]) == 4
    loaded = read_puzzle_dir(folder)
    assert sum(o.motion != "fixed" for o in loaded.record.objects) == 1
    assert len(loaded.joint_order) == 3


def test_import_is_deterministic(imported, tmp_path):
    _, folder = imported["lockbox"]
    source = folder.parent.parent.parent / "lockbox" / "urdf" / "lockbox.urdf"
    assert main(["import", str(source), "--out", str(tmp_path)]) == 0
    again = tmp_path / GENERATOR / "lockbox"
    for entry in ("puzzle.json", "urdf/lockbox.urdf", "srdf/lockbox.srdf"):
        assert (again / entry).read_bytes() == (folder / entry).read_bytes(), entry


# -- the goal ----------------------------------------------------------------------------


def test_the_goal_can_be_given_as_urdf_joint_values(tmp_path, capsys):
    path = se2_urdf(tmp_path, with_goal=False)
    out = tmp_path / "out"
    assert main(["import", str(path), "--out", str(out), "--target", "robot_body", "--goal=-1,2.5,0"]) == 0
    loaded = read_puzzle_dir(out / GENERATOR / "se2")
    assert loaded.goal.values == {"robot_body_x": -1.0, "robot_body_y": 2.5, "robot_body_yaw": 0.0}
    # One joint only, by its URDF name; the other joints are free.
    result = import_urdf(path, target="j_b", goal=[-2.0])
    assert result.puzzle.goal.values == {"robot_body_y": -2.0}


def test_a_downward_axis_and_limits_that_exclude_zero_keep_the_goal_pose(tmp_path):
    # The revolute axis points down (joint values turn clockwise) and its limits exclude 0: the
    # puzzle's joint turns counter-clockwise from a rest pose moved into the limits.
    path = write_urdf(tmp_path, "flip", robot(
        "flip", link("base_link"), link("goal"), link("bar", box((2, 0.2, 0.2))),
        joint("bar", "revolute", "base_link", "bar", (0, 0, 0.1), axis=(0, 0, -1), limits=(0.5, 2.0)),
        joint("goal", "fixed", "base_link", "goal", (0, 0, 0.1), yaw=-1.5),
    ))
    result = import_urdf(path)
    bar = result.objects[0]
    assert bar.obj.pose.yaw == pytest.approx(-0.5) and bar.obj.limits[0] == pytest.approx((-1.5, 0.0))
    assert result.puzzle.goal.values == {"bar": pytest.approx(-1.0)}
    assert bar.joints[0].value(1.5) == pytest.approx(-1.0)  # URDF value 1.5 is the goal's turn
    assert any("exclude 0" in note for note in result.notes)


# -- meshes --------------------------------------------------------------------------------


def test_binary_and_ascii_stl_give_the_same_triangles():
    triangles = prism_triangles(SLOT_RECTS, 0.0, 0.5)
    binary = read_triangles(binary_stl(triangles), "b.stl", ".stl")
    text = read_triangles(ascii_stl(triangles), "a.stl", ".stl")
    assert binary.shape == text.shape == (len(triangles), 3, 3)
    assert np.allclose(binary, text)
    shape = footprint(binary)
    assert shape.exact and (shape.z_low, shape.z_high) == (0.0, 0.5)


# -- bad input: one line, exit code 2, nothing written ---------------------------------------


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda d: d / "missing.urdf", "no such URDF file"),
        (lambda d: _write(d / "notes.urdf", "just some text\n"), "not a URDF file"),
        (lambda d: _write(d / "scene.urdf", '<?xml version="1.0"?><scene/>'), "not a URDF file"),
        (lambda d: se2_urdf(d, with_goal=False), "no goal link"),
    ],
)
def test_bad_input_is_one_line_exit_2_and_nothing_written(tmp_path, capsys, make, message):
    path = make(tmp_path)
    out = tmp_path / "out"
    code = main(["import", str(path), "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and message in err, err
    assert not out.exists()


def test_a_goal_no_object_can_reach_is_refused(tmp_path, capsys):
    path = se2_urdf(tmp_path)
    text = path.read_text().replace('<origin xyz="1 2 0.1" rpy="0 0 0.5"/>', '<origin xyz="9 2 0.1" rpy="0 0 0.5"/>')
    path.write_text(text)
    with pytest.raises(UrdfImportError, match="no movable object can be put on the goal link's pose"):
        import_urdf(path)
    with pytest.raises(UrdfImportError, match="--goal needs 3 values"):
        import_urdf(path, target="robot_body", goal=[1.0])


def test_an_unsolvable_puzzle_is_reported_and_not_written(tmp_path, capsys):
    # The wall stands in the way of the door's whole swing.
    path = door_urdf(tmp_path)
    path.write_text(path.read_text().replace('xyz="-1.0 0 0.4"', 'xyz="0.4 1.1 0.4"'))
    out = tmp_path / "out"
    code = main(["import", str(path), "--out", str(out), "--budget", "300"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1
    assert "not solved by LA-RRT within 300 collision queries" in err[-1]
    assert not (out / GENERATOR).exists()


def _write(path, text):
    path.write_text(text)
    return path


def test_notes_reach_puzzle_json(imported):
    _, folder = imported["se2"]
    notes = json.loads((folder / "puzzle.json").read_text())["parameters"]["notes"]
    assert any("pyramid.stl" in note for note in notes)
    assert math.isfinite(json.loads((folder / "puzzle.json").read_text())["goal"]["tolerance"])


def test_objects_that_overlap_at_the_start_are_refused(tmp_path, capsys):
    path = door_urdf(tmp_path)
    path.write_text(path.read_text().replace('xyz="-1.0 0 0.4"', 'xyz="0.5 0 0.4"'))  # the wall cuts the panel
    out = tmp_path / "out"
    assert main(["import", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "objects overlap at the start: hinge and wall" in err[-1]
    assert not out.exists()


# -- our own puzzles round-trip --------------------------------------------------------------


@pytest.mark.parametrize(("generator", "overrides"), [("lockbox_random", {}), ("move_n_times", {"n": 2})])
def test_a_generated_puzzle_imports_as_itself(tmp_path, generator, overrides):
    """Our URDF (OBJ prism pieces, SE(2) helper links, the goal marker named 'goal') imports as the
    same objects and goal, and the original certificate solves the import."""
    from phyrogen_core.export import write_puzzle
    from phyrogen_core.folder import PuzzleFolder
    from phyrogen_core.registry import get_generator
    from solver.pipelines.generation import generate_here
    from solver.planning.problem import verify_certificate

    puzzle = generate_here(generator, 8401, get_generator(generator).parse_params(overrides))
    folder = write_puzzle(puzzle, tmp_path)
    result = import_urdf(PuzzleFolder(folder, puzzle.name).urdf)
    assert result.notes == ()
    assert sorted((o.name, o.motion, o.limits) for o in result.puzzle.objects) == \
        sorted((o.name, o.motion, o.limits) for o in puzzle.objects)
    assert result.puzzle.goal.target == puzzle.goal.target
    assert result.puzzle.goal.values == pytest.approx(dict(puzzle.goal.values), abs=1e-9)
    assert result.puzzle.joint_order == puzzle.joint_order
    assert verify_certificate(result.puzzle.planning_chain, puzzle.certificate, result.puzzle.goal) == []


@pytest.mark.parametrize("option", ["--budget=0", "--budget=1.5", "--goal=nan", "--goal=1,,2", "--goal=left",
                                    "--seed=-1"])
def test_bad_options_are_one_line_exit_2_and_nothing_written(tmp_path, capsys, option):
    path = door_urdf(tmp_path)
    out = tmp_path / "out"
    code = main(["import", str(path), "--out", str(out), "--target", "hinge", option])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and option.split("=")[0] in err, err
    assert not out.exists()

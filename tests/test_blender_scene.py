"""Chain -> Blender -> chain, and URDF exported from the scene (bpy wheel)."""

from __future__ import annotations

import math

import pytest
from blender_support import every_shape_puzzle, private_blender_home

private_blender_home()
bpy = pytest.importorskip("bpy", reason="the bpy wheel is not installed (pip install -e .[blender])")

from blender_addon import annotations as keys  # noqa: E402
from blender_addon.export import export_collection  # noqa: E402
from blender_addon.phobos import phobostype  # noqa: E402
from blender_addon.scene import build_chain, build_puzzle, build_puzzle_folder, read_chain  # noqa: E402
from phyrogen_core.chain import Role  # noqa: E402
from phyrogen_core.export import chain_to_urdf, read_puzzle_dir, write_puzzle  # noqa: E402
from phyrogen_core.registry import all_generators  # noqa: E402

pytestmark = pytest.mark.blender


@pytest.fixture(autouse=True)
def empty_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    yield


def test_round_trip_is_lossless_for_every_shape_and_motion():
    puzzle = every_shape_puzzle()
    built = build_puzzle(puzzle)
    assert read_chain(built.collection) == puzzle.chain


def test_scene_carries_phobos_annotations():
    puzzle = every_shape_puzzle()
    built = build_puzzle(puzzle)
    root = built.links["base_link"]
    assert root.type == "ARMATURE" and root.phobostype == "link" and root[keys.MODEL_NAME] == puzzle.name
    slider = built.links["obj_00"]
    assert slider[keys.JOINT_TYPE] == "prismatic"
    assert list(slider[keys.JOINT_AXIS]) == [0.6, 0.8, 0.0]
    assert (slider[keys.JOINT_LOWER], slider[keys.JOINT_UPPER]) == (0.0, 1.0)
    assert len(slider.data.bones) == 1
    kinds = {(phobostype(o), o.get(keys.GEOMETRY_TYPE)) for o in built.collection.all_objects}
    assert {("visual", "box"), ("visual", "cylinder"), ("visual", "mesh"), ("collision", "box"),
            ("collision", "mesh"), ("inertial", None)} <= kinds
    for obj in built.collection.all_objects:
        if phobostype(obj) == "visual":
            material = obj.active_material
            bsdf = material.node_tree.nodes["Principled BSDF"]
            assert tuple(bsdf.inputs["Base Color"].default_value) == pytest.approx(tuple(material.diffuse_color))


def test_goal_marker_is_translucent_green_without_collision():
    built = build_puzzle(every_shape_puzzle())
    goal = built.links["goal"]
    assert goal[keys.ROLE] == Role.GOAL_MARKER.value
    children = [o for o in built.collection.all_objects if o.parent is goal]
    assert not [o for o in children if phobostype(o) == "collision"]
    visuals = [o for o in children if phobostype(o) == "visual"]
    assert visuals
    for obj in visuals:
        r, g, b, a = obj.active_material.diffuse_color
        assert g > 0.9 and r < 0.1 and b < 0.1 and a < 0.5


def test_edited_scene_is_exported_with_the_edit():
    puzzle = every_shape_puzzle()
    built = build_puzzle(puzzle)
    wall = built.links["fixed_00_wall"]
    wall.location.x += 0.5
    wall.rotation_euler.z = math.pi / 4
    chain = read_chain(built.collection)
    origin = chain.joint("fixed_00_wall").origin
    assert origin.xyz[0] == pytest.approx(5.5, abs=1e-6)
    assert origin.rpy[2] == pytest.approx(math.pi / 4, abs=1e-6)
    assert chain.joint("obj_00") == puzzle.chain.joint("obj_00")


def test_exported_urdf_equals_core_urdf(tmp_path):
    puzzle = every_shape_puzzle()
    built = build_puzzle(puzzle)
    urdf_path = export_collection(built.collection, tmp_path / "exported")
    text, meshes = chain_to_urdf(puzzle.chain)
    assert urdf_path.read_text() == text
    assert {p.name: p.read_text() for p in (tmp_path / "exported" / "meshes").iterdir()} == meshes


def test_two_puzzles_in_one_file_keep_their_names():
    puzzle = every_shape_puzzle()
    first = build_chain(puzzle.chain)
    second = build_chain(puzzle.chain)
    assert second.links["obj_00"].name != "obj_00"  # Blender renamed the object ...
    assert read_chain(first.collection) == read_chain(second.collection) == puzzle.chain  # ... not the link


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    """One puzzle folder per paper generator (seed 1), generated on first use."""
    from solver.pipelines.generation import generate_puzzle

    root = tmp_path_factory.mktemp("generated")
    cache = {}

    def get(generator):
        if generator not in cache:
            puzzle = generate_puzzle(generator, 1)
            cache[generator] = (puzzle, write_puzzle(puzzle, root))
        return cache[generator]

    return get


@pytest.mark.slow
@pytest.mark.parametrize("generator", list(all_generators()))
def test_round_trip_and_urdf_equality_for_every_generator(generator, generated, tmp_path):
    puzzle, folder = generated(generator)
    built = build_puzzle(puzzle)
    assert read_chain(built.collection) == puzzle.chain
    urdf_path = export_collection(built.collection, tmp_path / "exported")
    assert urdf_path.read_text() == (folder / "urdf" / f"{puzzle.name}.urdf").read_text()
    assert (tmp_path / "exported" / "puzzle.json").read_text() == (folder / "puzzle.json").read_text()
    # A scene built from the folder reads back to the chain the folder holds.
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert read_chain(build_puzzle_folder(folder).collection) == read_puzzle_dir(folder).chain

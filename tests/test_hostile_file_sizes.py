"""Hostile input, sizes read from files: every one has a stated bound, checked up front.

The command line bounds its numbers (``tests/test_hostile_sizes.py``); a file's sizes are
bounded in one place, :mod:`phyrogen_core.sizes`: links, joints and shapes of a URDF, vertices
of a prism mesh, triangles of an imported mesh, states of a certificate (the file's own size by
``MAX_FILE_BYTES``). The reported cases: a URDF of 30,000 static boxes (``check`` 296 CPU s,
``export --format mjcf`` over 320), a 200,000-gon prism (``replan`` asked for 298 GiB), a
200,000-state certificate (``manipulate`` past 696 CPU s, ``render`` past 806). Past a bound
the file is bad input, refused before the work that grows with it, in one line naming the
file and the bound; at the bound it is read (the negative control beside each refusal).

Work is bounded by counts: the refusals happen before the chain is built (a link built fails
the test), and the MJCF writer's contact exclusions count their link lookups.
"""

from __future__ import annotations

import contextlib
import io
import itertools
import math
import struct
from pathlib import Path

import numpy as np
import pytest
from hostile_support import (
    assert_cli_rejects,
    copy_folder,
    edit_json,
    format_error,
    hostile_puzzle,
    mesh_files,
    urdf_file,
    written,  # noqa: F401 (fixture)
)

import phyrogen_core.export.mjcf as mjcf
from phyrogen.cli import main
from phyrogen_core.chain import Geometry, Joint, JointType, KinematicChain, Link, Role
from phyrogen_core.export import read_puzzle_dir
from phyrogen_core.export.obj import read_prism_piece
from phyrogen_core.geometry import Box, Pose
from phyrogen_core.mesh_files import MeshFormatError, read_triangles
from phyrogen_core.sizes import (
    MAX_CERTIFICATE_STATES,
    MAX_LINKS,
    MAX_MESH_TRIANGLES,
    MAX_PRISM_VERTICES,
    MAX_SHAPES,
)
from phyrogen_core.urdf_import import UrdfImportError, import_urdf


def cli(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def static_boxes(count: int, shapes_each: int = 1) -> str:
    """``count`` static links, each a small box on the floor fixed to the base, far from the puzzle."""
    box = '<geometry><box size="0.01 0.01 0.01"/></geometry>'
    body = f'<collision>{box}</collision>' * shapes_each
    return "".join(f'<link name="static_{i:05d}">{body}</link>'
                   f'<joint name="static_{i:05d}" type="fixed"><parent link="base_link"/>'
                   f'<child link="static_{i:05d}"/><origin xyz="{50 + i * 0.02} 50 0" rpy="0 0 0"/></joint>'
                   for i in range(count))


def grow_urdf(folder: Path, text: str) -> Path:
    urdf = urdf_file(folder)
    original = urdf.read_text()
    urdf.write_text(original.replace("</robot>", text + "</robot>"))
    return urdf


def links_of(folder: Path) -> int:
    return urdf_file(folder).read_text().count("<link ")


@pytest.fixture
def nothing_built(monkeypatch):
    """Up front: building the first link of a refused URDF fails the test."""
    from phyrogen_core.export import reader

    def built(*args, **kwargs):
        raise AssertionError("a link was built from a URDF past its bounds")

    monkeypatch.setattr(reader._UrdfReader, "link", built)


# -- links and shapes of a puzzle folder's URDF --------------------------------------------
@pytest.mark.parametrize("command", [["check"], ["export", "--format", "mjcf"], ["replan"]])
def test_a_urdf_past_the_link_bound_is_refused_before_any_link_is_built(command, written, tmp_path,  # noqa: F811
                                                                         nothing_built):
    folder = copy_folder(written, tmp_path / "puzzle")
    urdf = grow_urdf(folder, static_boxes(MAX_LINKS + 1 - links_of(folder)))
    code, out, err = cli([command[0], str(folder), *command[1:]])
    assert (code, out) == (2, ""), (code, out, err)
    assert err.count("\n") == 1 and str(urdf) in err and f"{MAX_LINKS + 1} links" in err, err
    assert f"more than the {MAX_LINKS} accepted" in err
    assert not (folder / "mjcf").exists()


def test_a_urdf_at_the_link_bound_is_read(written, tmp_path):  # noqa: F811
    folder = copy_folder(written, tmp_path / "puzzle")
    grow_urdf(folder, static_boxes(MAX_LINKS - links_of(folder)))
    assert len(read_puzzle_dir(folder).chain.links) == MAX_LINKS


def test_a_urdf_past_the_shape_bound_is_refused(written, tmp_path, nothing_built):  # noqa: F811
    folder = copy_folder(written, tmp_path / "puzzle")
    grow_urdf(folder, static_boxes(1, MAX_SHAPES + 1))
    assert_cli_rejects(folder, f"more than the {MAX_SHAPES} accepted", "shapes")


def test_import_refuses_a_urdf_past_the_link_bound_before_reading_a_mesh(tmp_path):
    links = "".join(f'<link name="l{i}"/>' for i in range(MAX_LINKS + 1))
    path = tmp_path / "many.urdf"
    path.write_text(f'<robot name="many">{links}<link name="x"><visual><geometry><mesh filename="absent.stl"/>'
                    "</geometry></visual></link></robot>")
    with pytest.raises(UrdfImportError) as caught:
        import_urdf(path)
    message = str(caught.value)
    assert "\n" not in message and str(path) in message and f"more than the {MAX_LINKS} accepted" in message
    # The control: one link fewer than the bound gets past it, to the missing mesh.
    path.write_text(path.read_text().replace('<link name="l0"/><link name="l1"/>', ""))
    with pytest.raises(UrdfImportError, match="absent.stl"):
        import_urdf(path)


# -- MJCF: the contact exclusions are linear in the links -------------------------------------
def chain_of(groups: list[int]) -> KinematicChain:
    """A base and one static link per entry of ``groups``, the entry naming its object; each link
    holds a collision box, so that every pair of one object's links is excluded."""
    box = Geometry(Box((0.1, 0.1, 0.1)))
    links = [Link("base_link", (), (), Role.BASE)]
    joints = []
    for i, group in enumerate(groups):
        links.append(Link(f"l{i}", (box,), (box,), Role.STATIC, f"object_{group}"))
        joints.append(Joint(f"j{i}", JointType.FIXED, "base_link", f"l{i}", Pose((float(i), 0.0, 0.0))))
    return KinematicChain(tuple(links), tuple(joints), "base_link", "groups")


def quadratic_exclusions(chain: KinematicChain) -> list[str]:
    """The writer's rule as it was (every pair of links compared): the reference for the lines."""
    links = [link for link in chain.links if link.collisions and link.role is not Role.GOAL_MARKER]
    return [f'    <exclude body1="{a.name}" body2="{b.name}"/>' for a, b in itertools.combinations(links, 2)
            if mjcf.object_of_link(a) == mjcf.object_of_link(b)]


@pytest.mark.parametrize("groups", [[0, 1, 0, 2, 1, 0], [3] * 5, list(range(6)), [0, 0, 1, 1, 0, 2, 2, 2, 1]])
def test_the_exclusions_are_the_same_lines_in_the_same_order(groups):
    chain = chain_of(groups)
    lines = mjcf._Writer(chain).exclude_lines()
    assert lines == quadratic_exclusions(chain)
    assert len(lines) == sum(math.comb(groups.count(g), 2) for g in set(groups))


def test_the_exclusions_look_at_each_link_a_bounded_number_of_times(monkeypatch):
    chain = chain_of(list(range(3000)))  # 30,000 static boxes were the reported case; each its own object
    calls = 0
    original = mjcf.object_of_link

    def counted(link):
        nonlocal calls
        calls += 1
        return original(link)

    monkeypatch.setattr(mjcf, "object_of_link", counted)
    assert mjcf._Writer(chain).exclude_lines() == []
    assert calls <= 2 * len(chain.links), calls  # every pair: 4.5 million


# -- prism meshes of a puzzle folder -----------------------------------------------------------
def regular_prism_obj(corners: int, radius: float = 0.3, height: float = 0.3) -> str:
    ring = [(radius * math.cos(2 * math.pi * k / corners), radius * math.sin(2 * math.pi * k / corners))
            for k in range(corners)]
    lines = [f"v {x!r} {y!r} {z!r}" for z in (-height / 2, height / 2) for x, y in ring]
    return "\n".join(lines) + "\n"


def test_a_prism_mesh_past_the_vertex_bound_is_refused(written, tmp_path):  # noqa: F811
    folder = copy_folder(written, tmp_path / "puzzle")
    mesh = mesh_files(folder)[0]
    mesh.write_text(regular_prism_obj(MAX_PRISM_VERTICES // 2 + 1))
    assert_cli_rejects(folder, mesh.name, f"{MAX_PRISM_VERTICES + 2} vertices",
                       f"more than the {MAX_PRISM_VERTICES} accepted")


def test_a_prism_mesh_at_the_vertex_bound_is_read():
    piece, height = read_prism_piece(regular_prism_obj(MAX_PRISM_VERTICES // 2))
    assert len(piece) == MAX_PRISM_VERTICES // 2 and math.isclose(height, 0.3)


# -- triangles of an imported mesh -----------------------------------------------------------
def binary_stl(count: int) -> bytes:
    record = np.zeros(count, dtype=[("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
    record["corners"] = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    return b"test".ljust(80, b" ") + struct.pack("<I", count) + record.tobytes()


def test_an_imported_mesh_past_the_triangle_bound_is_refused():
    with pytest.raises(MeshFormatError) as caught:
        read_triangles(binary_stl(MAX_MESH_TRIANGLES + 1), "big.stl", ".stl")
    assert f"{MAX_MESH_TRIANGLES + 1} triangles" in str(caught.value) and "big.stl" in str(caught.value)
    assert read_triangles(binary_stl(MAX_MESH_TRIANGLES), "big.stl", ".stl").shape == (MAX_MESH_TRIANGLES, 3, 3)


# -- certificate states -------------------------------------------------------------------------
def lengthen_certificate(folder: Path, states: int) -> None:
    def change(data):
        start, end = data["certificate"][0], data["certificate"][-1]
        data["certificate"] = [start] * (states - 1) + [end]

    edit_json(folder, change)


def test_a_certificate_past_the_state_bound_is_refused(written, tmp_path):  # noqa: F811
    folder = copy_folder(written, tmp_path / "puzzle")
    lengthen_certificate(folder, MAX_CERTIFICATE_STATES + 1)
    message = format_error(lambda: read_puzzle_dir(folder))
    assert "puzzle.json" in message and f"{MAX_CERTIFICATE_STATES + 1} states" in message
    assert f"more than the {MAX_CERTIFICATE_STATES} accepted" in message


def test_a_certificate_at_the_state_bound_is_read_and_checked(written, tmp_path):  # noqa: F811
    folder = copy_folder(written, tmp_path / "puzzle")
    lengthen_certificate(folder, MAX_CERTIFICATE_STATES)
    assert len(read_puzzle_dir(folder).certificate) == MAX_CERTIFICATE_STATES
    code, out, err = cli(["check", str(folder)])
    assert (code, err) == (0, "") and "certificate valid" in out, (code, out, err)


@pytest.fixture
def no_simulation(monkeypatch):
    import blender_addon.rendering
    import manipulation.batch

    def started(*args, **kwargs):
        raise AssertionError("work started before the input was checked")

    monkeypatch.setattr(manipulation.batch, "execute_puzzle", started)
    monkeypatch.setattr(blender_addon.rendering, "_run_workers", started)


@pytest.mark.parametrize("command", ["manipulate", "render"])
def test_manipulate_and_render_refuse_a_certificate_past_the_bound(command, tmp_path, no_simulation):
    root = tmp_path / "puzzles"
    from phyrogen_core.export import write_puzzle

    folder = write_puzzle(hostile_puzzle(), root)
    lengthen_certificate(folder, 200_000)  # the reported case
    argv = ["manipulate", str(root), "--out", str(tmp_path / "runs")] if command == "manipulate" else \
        ["render", "--out", str(root), "--no-animation"]
    code, out, err = cli([*argv, "--quiet"])
    assert (code, out) == (2, ""), (code, out, err)
    assert err.count("\n") == 1 and "200000 states" in err and "puzzle.json" in err, err
    assert not (tmp_path / "runs").exists()


def write_solution(folder: Path, states: int) -> Path:
    """``solutions/la_rrt_best.json`` whose path idles at the start, ``states`` states in all."""
    import json

    data = json.loads((folder / "puzzle.json").read_text())
    start, end = data["certificate"][0], data["certificate"][-1]
    path = folder / "solutions" / "la_rrt_best.json"
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps({"format": "phyrogen-solution", "format_version": 1, "puzzle": data["name"],
                                "planner": "la_rrt", "joint_order": data["joint_order"],
                                "path": [start] * (states - 1) + [end]}))
    return path


def test_manipulate_refuses_a_solution_file_past_the_state_bound(tmp_path, no_simulation):
    """The benchmark's solution is executed like the certificate, and bounded like it: one of
    200,000 states ran ``manipulate`` past 120 s; at the bound it is read (the control)."""
    from manipulation.solution import load_solution
    from phyrogen_core.export import write_puzzle

    folder = write_puzzle(hostile_puzzle(), tmp_path / "puzzles")
    solution = write_solution(folder, MAX_CERTIFICATE_STATES + 1)
    code, out, err = cli(["manipulate", str(folder), "--out", str(tmp_path / "runs"), "--quiet"])
    assert (code, out) == (2, ""), (code, out, err)
    assert err.count("\n") == 1 and str(solution) in err and f"{MAX_CERTIFICATE_STATES + 1} states" in err, err
    assert not (tmp_path / "runs").exists()
    write_solution(folder, MAX_CERTIFICATE_STATES)
    loaded = read_puzzle_dir(folder)
    assert len(load_solution(folder, loaded.joint_order, loaded.certificate).path) == MAX_CERTIFICATE_STATES


# -- dataset sweeps -------------------------------------------------------------------------------
def test_a_dataset_sweep_past_a_stated_bound_is_refused_whatever_the_seeds(tmp_path, monkeypatch):
    import solver.pipelines.dataset.build as build

    def started(*args, **kwargs):
        raise AssertionError("the dataset started for a sweep past a bound")

    monkeypatch.setattr(build, "build_dataset", started)
    out = tmp_path / "data"
    code, stdout, err = cli(["dataset", "--generator", "grid_world", "--count", "10", "--set", "n_objects=1:1000",
                             "--out", str(out), "--quiet"])
    assert (code, stdout) == (2, ""), (code, stdout, err)
    assert err.count("\n") == 1 and "n_objects" in err and "1..25" in err, err
    assert not out.exists()


def test_a_dataset_sweep_within_the_bound_is_accepted():
    from solver.pipelines.dataset import make_request

    request = make_request(["grid_world"], [(1, 10)], ["n_objects=1:25"])
    assert request.period == 25
    assert request.parameters("grid_world", 24).n_objects == 25

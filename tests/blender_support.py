"""Shared set-up for the Blender tests: a private Blender configuration and sample puzzles."""

from __future__ import annotations

import contextlib
import fcntl
import os
import shutil
import sys
import tempfile
import types
from pathlib import Path

from phyrogen_core.chain import BLACK, GREEN, RED, Geometry, Role
from phyrogen_core.geometry import Box, Cylinder, Pose, slot_disc
from phyrogen_core.objects import Motion, PuzzleObject
from phyrogen_core.puzzle import Goal, Puzzle


@contextlib.contextmanager
def wheel_cache_lock():
    """Held while scripts/build_addon.py runs: on a fresh clone it downloads into build/wheels, and
    two builds at once (test files on parallel pytest-xdist workers) would each read the other's
    half-written wheels."""
    path = Path(__file__).resolve().parents[1] / "build" / "wheels.lock"
    path.parent.mkdir(exist_ok=True)
    with path.open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        yield


def private_blender_home() -> None:
    """Keep Blender from writing under the home folder (must run before ``import bpy``)."""
    home = tempfile.mkdtemp(prefix="phyrogen-blender-test-")
    os.environ.setdefault("BLENDER_USER_CONFIG", os.path.join(home, "config"))
    os.environ.setdefault("BLENDER_USER_RESOURCES", os.path.join(home, "resources"))


def every_shape_puzzle() -> Puzzle:
    """A small puzzle using every shape, motion and role, with awkward numbers."""
    disc = slot_disc(1.5, 1.0)
    return Puzzle(
        (
            PuzzleObject("obj_00", Motion.PRISMATIC, Pose.planar(0.1, 0.2, 0.3, 0.7),
                         (Geometry(Box((1.6, 0.2, 0.2)), color=GREEN),),
                         (Geometry(Box((1.6, 0.2, 0.2)), color=GREEN),), Role.TARGET, ((0.0, 1.0),),
                         (0.6, 0.8, 0.0)),
            PuzzleObject("obj_01", Motion.REVOLUTE, Pose.planar(2, 0, 0.5, -2.9),
                         (Geometry(disc, color=RED), Geometry(Cylinder(0.1, 1.1), Pose((0, 0.3, 0.6)), BLACK, "hinge")),
                         (Geometry(disc, color=RED),), Role.BLOCKER, ((-3.14, 3.14),)),
            PuzzleObject("obj_02", Motion.SE2, Pose.planar(-2, 1 / 3, 0.25, 1.0),
                         (Geometry(Box((0.375, 0.5, 0.5)), color=(0.1, 0.2, 0.3, 1.0)),),
                         (Geometry(Box((0.375, 0.5, 0.5)), color=RED),), Role.BLOCKER,
                         ((-1, 1), (-2, 0.5), (-3.14, 3.14))),
            PuzzleObject("fixed_00_wall", Motion.FIXED, Pose.planar(5, 5, 0.25, 0.1),
                         (Geometry(Box((2, 0.1, 0.5))),), (Geometry(Box((2, 0.1, 0.5))),), Role.STATIC),
        ),
        Goal("obj_00", {"obj_00": 1.0}),
        "every_shape",
        1,
    )


def tool(name: str) -> str | None:
    return shutil.which(name)


def blender_environment(tmp_path: Path) -> dict[str, str]:
    """The environment for a Blender subprocess with an empty user folder under ``tmp_path``
    that runs PhyRoGen's work in this virtual environment."""
    environment = dict(os.environ)
    environment["BLENDER_USER_CONFIG"] = str(tmp_path / "config")
    environment["BLENDER_USER_SCRIPTS"] = str(tmp_path / "scripts")
    environment["BLENDER_USER_RESOURCES"] = str(tmp_path / "resources")
    environment["PHYROGEN_VENV"] = str(Path(sys.prefix))
    return environment


class FakeLayout:
    """Records what a panel draws (``("prop", name)``, ``("operator", idname)``, ``("label", text)``),
    standing in for Blender's UILayout so that drawing can be tested without a window."""

    def __init__(self, log: list):
        self.log = log
        self.scale_y = 1.0

    def prop(self, data, name, **_):
        self.log.append(("prop", name))

    def operator(self, idname, **_):
        self.log.append(("operator", idname))
        return types.SimpleNamespace()

    def label(self, text="", **_):
        self.log.append(("label", text))

    def row(self, **_):
        return self

    column = row
    split = row

    def template_list(self, list_type, *_, **__):
        self.log.append(("list", list_type))

    def box(self):
        return self


def pybullet_model(urdf: Path) -> dict:
    """What PyBullet loads from ``urdf`` (fixed base): per joint its type, child, limits, axis, frame and
    child's mass, and the base's mass."""
    import pybullet

    client = pybullet.connect(pybullet.DIRECT)
    try:
        # Fixed base, as the project loads its puzzles: Phobos's base weighs 1e-10 kg, and without
        # useFixedBase PyBullet would let it fall, where our massless base stays put.
        body = pybullet.loadURDF(str(urdf), useFixedBase=True, physicsClientId=client)
        joints = {}
        for index in range(pybullet.getNumJoints(body, physicsClientId=client)):
            info = pybullet.getJointInfo(body, index, physicsClientId=client)
            joints[info[1].decode()] = {
                "type": info[2], "child": info[12].decode(), "limits": (info[8], info[9]), "axis": info[13],
                "frame": (*info[14], *info[15]),
                "mass": pybullet.getDynamicsInfo(body, index, physicsClientId=client)[0]}
        base_mass = pybullet.getDynamicsInfo(body, -1, physicsClientId=client)[0]
    finally:
        pybullet.disconnect(client)
    return {"joints": joints, "base_mass": base_mass}

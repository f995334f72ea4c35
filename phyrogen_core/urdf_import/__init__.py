"""Importing a planar articulated puzzle made elsewhere (a URDF file) as a PhyRoGen puzzle.

:func:`import_urdf` reads the URDF (:mod:`.urdf_model`; meshes from
binary or ASCII STL and OBJ), finds its objects from the link tree
(:mod:`.objects`: static scenery, movable objects with what is fixed to
them, SE(2) objects through helper links), turns every shape into vertical
prisms (:mod:`.shapes`, :mod:`.footprint`) and reads the goal from a
``goal`` link or from given joint values (:mod:`.goal`). The result is an
ordinary :class:`~phyrogen_core.puzzle.Puzzle` of generator
:data:`GENERATOR`, written by the same exporter as generated puzzles, so
that every tool reads it; the solver certifies it
(``solver.pipelines.importing``). ``docs/import.md`` is the user's guide.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from ..chain import Role
from ..export.reader import goal_problems, start_state
from ..folder_layout import name_problem
from ..provenance import Imported, ImportedJoint, Provenance
from ..puzzle import Goal, Puzzle
from .goal import GoalChoice, goal_from_pose, goal_from_values
from .objects import GOAL_LINK, ImportedObject, JointMap, scene_objects
from .urdf_model import UrdfImportError, read_urdf_model

GENERATOR = "imported"
"""The generator name of every imported puzzle: its folder is ``<out>/imported/<name>/``."""

__all__ = ["GENERATOR", "ImportedObject", "ImportedPuzzle", "JointMap", "UrdfImport", "UrdfImportError",
           "import_urdf"]


@dataclass(frozen=True)
class ImportedPuzzle(Puzzle):
    """A puzzle named after its source (a generated one is named ``<generator>_<seed>``)."""

    title: str = GENERATOR

    @property
    def name(self) -> str:
        return self.title


@dataclass(frozen=True)
class UrdfImport:
    """An imported puzzle (not certified yet), its objects' URDF origins, and what the import noted."""

    puzzle: ImportedPuzzle
    objects: tuple[ImportedObject, ...]
    notes: tuple[str, ...]
    goal_source: str  # "goal link" or "arguments"

    @property
    def movable(self) -> int:
        return sum(item.obj.is_movable for item in self.objects)


def import_urdf(path: str | Path, *, target: str | None = None, goal: Sequence[float] | None = None,
                name: str | None = None) -> UrdfImport:
    """The puzzle of the URDF file ``path``.

    The goal comes from ``goal`` (URDF joint values of ``target``: one for a
    joint, one per joint of an object or link) when given, else from the
    link named ``goal`` (``target`` then only picks among the objects that
    fit it). ``name`` names the puzzle (default: the URDF's robot name).
    Raises :class:`UrdfImportError` (a ValueError) naming the file and the
    problem: no goal, a shape or joint that cannot be planar, a tree that
    is no puzzle.
    """
    path = Path(path)
    model = read_urdf_model(path)
    scene = scene_objects(model)
    if not any(item.obj.is_movable for item in scene.objects):
        raise UrdfImportError(f"{path}: nothing moves: no prismatic or revolute joint moves a shape that collides")
    try:
        choice = _goal(scene, target, goal)
    except ValueError as exc:
        raise UrdfImportError(f"{path}: {exc}") from None
    objects = sorted(scene.objects, key=lambda item: item.obj.name != choice.target)  # the target first
    objects = [replace(item, obj=replace(item.obj, role=Role.TARGET)) if item.obj.name == choice.target else item
               for item in objects]
    title = name if name is not None else (re.sub(r"[^A-Za-z0-9_.\-]+", "_", model.name).strip("_.-") or path.stem)
    problem = name_problem(title)
    if problem is not None:
        raise UrdfImportError(f"puzzle name {title!r} {problem}; choose another with --name")
    notes = tuple(model.notes) + scene.notes
    # The import renames joints (a slider's door_joint becomes door_link, SE(2) chains <object>_x, _y,
    # _yaw): the map keeps the way back to the source file.
    joints = sorted((ImportedJoint(m.joint, m.urdf, float(m.sign) + 0.0, float(m.offset) + 0.0)
                     for item in objects for m in item.joints),
                    key=lambda joint: joint.joint)
    source = Imported(path.name, hashlib.sha256(path.read_bytes()).hexdigest(), model.name, tuple(joints))
    parameters = {"goal_from": choice.source, "notes": list(notes)}
    puzzle = ImportedPuzzle(tuple(item.obj for item in objects), Goal(choice.target, choice.values), GENERATOR, 0,
                            parameters, provenance=Provenance(imported=source), title=title)
    try:
        puzzle.chain  # noqa: B018 (built to check: names of links and joints must not clash)
    except ValueError as exc:
        raise UrdfImportError(f"{path}: the imported objects do not form a chain: {exc}") from None
    planning = puzzle.planning_chain
    problems = goal_problems(puzzle.goal, planning, start_state(planning))
    if problems:
        raise UrdfImportError(f"{path}: the goal ({choice.source}) is no sensible goal: {problems[0]}")
    return UrdfImport(puzzle, tuple(objects), notes, choice.source)


def _goal(scene, target: str | None, goal: Sequence[float] | None) -> GoalChoice:
    if goal is not None:
        if target is None:
            raise ValueError("--goal needs --target: the joint or object whose goal values these are")
        return goal_from_values(scene.objects, target, goal)
    if scene.goal_pose is not None:
        return goal_from_pose(scene.objects, scene.goal_pose, target)
    if target is not None:
        raise ValueError(f"no goal link (a link named {GOAL_LINK!r}): --target needs --goal with its goal values")
    raise ValueError(f"no goal link (a link named {GOAL_LINK!r} placed where the target is to go) and no --target "
                     "and --goal: nothing says what solves the puzzle")

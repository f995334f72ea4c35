"""``puzzle.json`` of a puzzle: the :class:`~phyrogen_core.record.PuzzleRecord` of a generated or
imported :class:`~phyrogen_core.puzzle.Puzzle`, or of a chain edited from a stored one.

Provenance (generator, parameters, seed, package versions, and for an imported
puzzle its source and certifying planner) so the puzzle can be regenerated; the
planning problem (joint order, limits, start, goal); the objects and the
dependency graph; and the solution certificate. There is no timestamp: the
same puzzle always gives the same bytes.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Mapping
from typing import Any

from ..actions import count_actions
from ..chain import KinematicChain
from ..dependencies import dependency_shape
from ..puzzle import Puzzle
from ..record import FORMAT_VERSION, DependencyGraph, JointLimit, ObjectRecord, PuzzleRecord

__all__ = ["FORMAT_VERSION", "metadata_json", "puzzle_metadata", "puzzle_record", "record_for_chain", "start_state"]


def puzzle_record(puzzle: Puzzle, versions: Mapping[str, str] | None = None, *,
                  chain: KinematicChain | None = None) -> PuzzleRecord:
    """The record of ``puzzle``.

    ``versions`` names the package versions to record; by default only
    PhyRoGen's own. ``chain`` is ``puzzle.chain`` when the caller has built it
    already (each access builds it anew). Raises ValueError when the goal or the
    certificate do not fit the puzzle's joints, or a parameter cannot be written as JSON.
    """
    chain = puzzle.chain if chain is None else chain
    joint_order = tuple(puzzle.joint_order)
    for joint_name in puzzle.goal.values:
        if joint_name not in joint_order:
            raise ValueError(f"goal joint {joint_name!r} is not an active joint; valid: {list(joint_order)}")
    for index, state in enumerate(puzzle.certificate):
        if len(state) != len(joint_order):
            raise ValueError(f"certificate state {index} has {len(state)} values, "
                             f"expected {len(joint_order)} (one per joint in {list(joint_order)})")
    shape = dependency_shape(puzzle.dependencies, puzzle.goal.target)
    return PuzzleRecord(
        name=puzzle.name,
        generator=puzzle.generator,
        seed=puzzle.seed,
        parameters=_jsonable(_parameters_dict(puzzle.parameters), "parameters"),
        joint_order=joint_order,
        joint_limits=_joint_limits(chain, joint_order),
        start=tuple(_float(v) for v in puzzle.start),
        goal=type(puzzle.goal)(puzzle.goal.target, {name: _float(v) for name, v in puzzle.goal.values.items()},
                               _float(puzzle.goal.tolerance)),
        objects=tuple(_object_record(o, puzzle.margins, puzzle.necessity) for o in puzzle.objects),
        dependency_graph=DependencyGraph(
            nodes=tuple(o.name for o in puzzle.objects if o.is_movable),  # scenery blocks nothing
            edges=tuple((str(blocker), str(blocked)) for blocker, blocked in puzzle.dependencies),
            depth=shape.depth,
            branching=shape.branching,
        ),
        certificate=tuple(tuple(_float(v) for v in state) for state in puzzle.certificate),
        certificate_actions=count_actions(puzzle.certificate, chain.factors),
        versions=dict(versions) if versions is not None else {"phyrogen": _phyrogen_version()},
        provenance=puzzle.provenance,
        difficulty=puzzle.difficulty,
    )


def puzzle_metadata(puzzle: Puzzle, versions: Mapping[str, str] | None = None) -> dict[str, Any]:
    """The JSON data of :func:`puzzle_record`."""
    return puzzle_record(puzzle, versions).to_dict()


def _joint_limits(chain: KinematicChain, joint_order: tuple[str, ...]) -> tuple[JointLimit, ...]:
    return tuple(JointLimit(name, chain.joint(name).type, _float(chain.joint(name).lower),
                            _float(chain.joint(name).upper)) for name in joint_order)


def _object_record(obj, margins: Mapping[str, float], necessity: Mapping[str, str]) -> ObjectRecord:
    margin = _float(margins[obj.name]) if obj.name in margins else None
    return ObjectRecord(obj.name, obj.motion, obj.role, tuple(obj.joint_names), margin,
                        necessity.get(obj.name) if margin is not None else None)


def metadata_json(puzzle: Puzzle, versions: Mapping[str, str] | None = None, *,
                  chain: KinematicChain | None = None) -> str:
    """The text of ``puzzle.json`` for ``puzzle`` (:meth:`PuzzleRecord.to_json`; ``chain``: see
    :func:`puzzle_record`)."""
    return puzzle_record(puzzle, versions, chain=chain).to_json()


def _phyrogen_version() -> str:
    # Imported here: the package's __init__ may one day import this module.
    from .. import __version__

    return __version__


def _parameters_dict(parameters: Any) -> Mapping[str, Any]:
    if dataclasses.is_dataclass(parameters) and not isinstance(parameters, type):
        return dataclasses.asdict(parameters)
    if isinstance(parameters, Mapping):
        return parameters
    raise TypeError(f"puzzle parameters must be a dataclass instance or a mapping, "
                    f"got {type(parameters).__name__}")


def _float(value: float) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"cannot write {value!r} to puzzle.json: only finite numbers are valid")
    return value + 0.0  # -0.0 -> 0.0


def _jsonable(value: Any, where: str) -> Any:
    """``value`` as plain JSON data (numpy scalars and arrays, enums and tuples converted)."""
    if isinstance(value, enum.Enum):
        return _jsonable(value.value, where)
    if value is None or isinstance(value, bool | str):
        return value
    if isinstance(value, int):
        return int(value)
    if isinstance(value, float):
        return _float(value)
    if hasattr(value, "tolist") and callable(value.tolist):  # numpy scalars and arrays
        return _jsonable(value.tolist(), where)
    if isinstance(value, Mapping):
        out = {}
        for key, item in value.items():
            if not isinstance(key, str):
                raise ValueError(f"{where}: key {key!r} must be a string to be written as JSON")
            out[key] = _jsonable(item, f"{where}.{key}")
        return out
    if isinstance(value, list | tuple):
        return [_jsonable(item, f"{where}[{i}]") for i, item in enumerate(value)]
    raise ValueError(f"{where}: {value!r} ({type(value).__name__}) cannot be written as JSON; "
                     "valid: numbers, strings, booleans, None, lists, mappings, enums")


def start_state(chain: KinematicChain) -> tuple[float, ...]:
    """The start state of a puzzle chain (joint order): every active joint at 0, clipped into its limits.

    It is the state the planners start from
    (:func:`solver.planning.problem.problem_for_chain`), the one generated puzzles
    and :func:`record_for_chain` write, and the one a certificate must begin at.
    """
    return tuple(max(min(0.0, j.upper), j.lower) + 0.0 for j in chain.active_joints)


def record_for_chain(stored: PuzzleRecord, chain: KinematicChain) -> PuzzleRecord:
    """The record of ``chain`` (e.g. a puzzle edited in Blender) from the record of the puzzle it was
    made from.

    Everything the URDF states is taken from ``chain``: joint order and
    limits, the start state they imply, which objects exist. The certificate and the dependency graph
    were found for the old chain, so they are kept (the certificate only
    while the joint order is unchanged, so it can be re-checked) but marked
    ``"certificate_verified": false``: ``phyrogen check`` or a new plan
    decides whether they still hold. A measured difficulty is dropped: it was measured on
    the puzzle before the edit. Raises ValueError when the goal moves a
    joint the chain no longer has.
    """
    order = tuple(chain.joint_order)
    missing = [n for n in stored.goal.values if n not in order]
    if missing:
        raise ValueError(f"the edited puzzle has no joint {missing[0]!r}, which the goal moves; "
                         f"valid goal joints: {list(order)}")
    present = {link.name for link in chain.links}  # an object's body link carries its name
    graph = stored.dependency_graph
    return dataclasses.replace(
        stored,
        joint_order=order,
        joint_limits=_joint_limits(chain, order),
        objects=tuple(o for o in stored.objects if o.name in present),
        dependency_graph=DependencyGraph(tuple(n for n in graph.nodes if n in present),
                                         tuple(e for e in graph.edges if all(n in present for n in e))),
        start=tuple(_float(v) for v in start_state(chain)),
        certificate=stored.certificate if stored.joint_order == order else (),
        certificate_verified=False,
        difficulty=None,  # measured on the puzzle before the edit
    )

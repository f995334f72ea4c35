"""``puzzle.json``: everything about a puzzle that the URDF does not say.

Provenance (generator, parameters, seed, package versions) so the puzzle can
be regenerated; the planning problem (joint order, limits, start, goal); the
objects and the dependency graph; and the solution certificate. There is no
timestamp: the same puzzle always gives the same bytes.
"""

from __future__ import annotations

import dataclasses
import enum
import json
import math
from collections.abc import Mapping
from typing import Any

from ..actions import count_actions
from ..chain import KinematicChain
from ..dependencies import dependency_shape
from ..puzzle import Puzzle

FORMAT_VERSION = 1
"""Bumped when a key changes meaning; readers check it."""


def puzzle_metadata(puzzle: Puzzle, versions: Mapping[str, str] | None = None) -> dict[str, Any]:
    """The JSON-ready description of ``puzzle``.

    ``versions`` names the package versions to record; by default only
    PhyRoGen's own. Raises ValueError when the goal or the certificate do not
    fit the puzzle's joints, or a parameter cannot be written as JSON.
    """
    chain = puzzle.chain
    joint_order = list(puzzle.joint_order)
    for joint_name in puzzle.goal.values:
        if joint_name not in joint_order:
            raise ValueError(f"goal joint {joint_name!r} is not an active joint; valid: {joint_order}")
    for index, state in enumerate(puzzle.certificate):
        if len(state) != len(joint_order):
            raise ValueError(f"certificate state {index} has {len(state)} values, "
                             f"expected {len(joint_order)} (one per joint in {joint_order})")
    shape = dependency_shape(puzzle.dependencies, puzzle.goal.target)
    return {
        "format_version": FORMAT_VERSION,
        "generator": puzzle.generator,
        "name": puzzle.name,
        "seed": puzzle.seed,
        "parameters": _jsonable(_parameters_dict(puzzle.parameters), "parameters"),
        "joint_order": joint_order,
        "joint_limits": {
            name: {"type": chain.joint(name).type.value, "lower": _float(chain.joint(name).lower),
                   "upper": _float(chain.joint(name).upper)}
            for name in joint_order
        },
        "start": [_float(v) for v in puzzle.start],
        "goal": {
            "target": puzzle.goal.target,
            "values": {name: _float(v) for name, v in puzzle.goal.values.items()},
            "tolerance": _float(puzzle.goal.tolerance),
        },
        "objects": [_object_entry(o, puzzle.margins) for o in puzzle.objects],
        "dependency_graph": {
            "nodes": [o.name for o in puzzle.objects if o.is_movable],  # scenery blocks nothing
            "edges": [[str(blocker), str(blocked)] for blocker, blocked in puzzle.dependencies],
            "depth": shape.depth,
            "branching": shape.branching,
        },
        "certificate": [[_float(v) for v in state] for state in puzzle.certificate],
        "certificate_actions": count_actions(puzzle.certificate, chain.factors),
        "versions": dict(versions) if versions is not None else {"phyrogen": _phyrogen_version()},
    }


def _object_entry(obj, margins: Mapping[str, float]) -> dict[str, Any]:
    entry = {"name": obj.name, "motion": obj.motion.value, "role": obj.role.value, "joints": list(obj.joint_names)}
    if obj.name in margins:
        entry["interlock_margin"] = _float(margins[obj.name])
    return entry


def metadata_json(puzzle: Puzzle, versions: Mapping[str, str] | None = None) -> str:
    """:func:`puzzle_metadata` as JSON text: sorted keys, indent 2, trailing newline."""
    return json.dumps(puzzle_metadata(puzzle, versions), sort_keys=True, indent=2, allow_nan=False) + "\n"


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


def metadata_for_chain(stored: Mapping[str, Any], chain: KinematicChain) -> dict[str, Any]:
    """``puzzle.json`` data for ``chain`` (e.g. a puzzle edited in Blender) from the metadata of the
    puzzle it was made from.

    Everything the URDF states is taken from ``chain``: joint order and
    limits, the start state they imply, which objects exist. The certificate and the dependency graph
    were found for the old chain, so they are kept (the certificate only
    while the joint order is unchanged, so it can be re-checked) but marked
    ``"certificate_verified": false``: ``phyrogen check`` or a new plan
    decides whether they still hold.
    """
    data = json.loads(json.dumps(dict(stored)))  # a deep copy of plain JSON data
    order = list(chain.joint_order)
    same_joints = list(data.get("joint_order", [])) == order
    data["joint_order"] = order
    data["joint_limits"] = {
        name: {"type": chain.joint(name).type.value, "lower": _float(chain.joint(name).lower),
               "upper": _float(chain.joint(name).upper)}
        for name in order
    }
    present = {link.name for link in chain.links}  # an object's body link carries its name
    data["objects"] = [o for o in data.get("objects", []) if isinstance(o, Mapping) and o.get("name") in present]
    graph = data.get("dependency_graph", {})
    data["dependency_graph"] = {
        "nodes": [n for n in graph.get("nodes", []) if n in present],
        "edges": [e for e in graph.get("edges", []) if all(n in present for n in e)],
    }
    from .reader import start_state  # the reader imports this module

    data["start"] = [_float(v) for v in start_state(chain)]
    if not same_joints:
        data["certificate"] = []
    goal = data.get("goal", {})
    missing = [n for n in goal.get("values", {}) if n not in order]
    if missing:
        raise ValueError(f"the edited puzzle has no joint {missing[0]!r}, which the goal moves; "
                         f"valid goal joints: {order}")
    data["certificate_verified"] = False
    return data

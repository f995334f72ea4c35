"""``puzzle.json`` as one typed value, :class:`PuzzleRecord`: the only code that knows its keys.

Everything the URDF does not say about a puzzle: who made it (generator,
parameters, seed, package versions, :class:`~phyrogen_core.provenance.Provenance`),
the planning problem (joint order, limits, start, goal), the objects, the
dependency graph and the solution certificate. ``docs/puzzle-format.md``
describes each key.

:meth:`PuzzleRecord.from_json` is strict: every key the format has, of its
type, every number finite (joint values within :data:`MAX_MAGNITUDE`), no
key the format does not have; a violation raises
:class:`~phyrogen_core.errors.PuzzleFormatError` naming the file and the key.
What needs the URDF to check (that ``joint_order`` and ``joint_limits`` are
the URDF's, that the goal can be reached) is the reader's
(:func:`~phyrogen_core.export.reader.read_puzzle_dir`).

Versions: a file without ``format_version`` is version 1, as is every file
written before provenance had its own key. Version 1 kept provenance in two
places (``parameters.certified_by`` and ``parameters.source`` of an imported
puzzle, ``replanned_by`` at the top level); reading moves them into
``provenance``. A record is written as version 1 while it has no provenance
(the two versions are then the same text, so a regenerated puzzle keeps its
bytes), else as version 2.

Version 3 adds ``difficulty`` (:class:`~phyrogen_core.difficulty.Difficulty`), written only when it
was measured (``phyrogen generate --difficulty``): a record without it is written exactly as before,
and a reader that knows only versions 1-2 refuses the file by its version rather than by an
unknown key.

Version 4 adds ``necessity`` to the objects that have an ``interlock_margin``: how the Maker's
verdict that the object is needed was reached (:data:`~phyrogen_core.maker.NECESSITY_KINDS`:
``geometry``, ``goal sampler`` or ``search``). Files of versions 1-3 are read with it unknown
(None); a record without it is written exactly as before.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

from .chain import JointType, Role
from .difficulty import Difficulty
from .errors import PuzzleFormatError
from .maker import NECESSITY_KINDS
from .objects import Motion
from .provenance import Imported, ImportedJoint, PlannerRun, Provenance
from .puzzle import Goal
from .sizes import CERTIFICATE_STATES

FORMAT_VERSION = 4
"""The newest ``puzzle.json`` format; bumped when a key changes meaning. Readers accept 1 to this."""
PROVENANCE_VERSION = 2
"""The first version with the ``provenance`` key (and without ``replanned_by``, ``parameters.certified_by``)."""
DIFFICULTY_VERSION = 3
"""The first version with the ``difficulty`` key."""
NECESSITY_VERSION = 4
"""The first version with the objects' ``necessity`` key."""
MAX_MAGNITUDE = 1e6
"""The largest magnitude of a number in the URDF, a mesh or a joint value of ``puzzle.json``
(metres, radians, kilograms, ...). Puzzles are table- to room-sized (the largest generated
number is below 100); the bound keeps every product the collision model forms far from overflow."""
IMPORTED_GENERATOR = "imported"
"""The generator name of imported puzzles (:data:`phyrogen_core.urdf_import.GENERATOR`): in version 1
their ``parameters.source`` was provenance."""

_KEYS = frozenset({
    "format_version", "generator", "name", "seed", "parameters", "joint_order", "joint_limits", "start", "goal",
    "objects", "dependency_graph", "certificate", "certificate_actions", "versions", "certificate_verified",
    "provenance", "difficulty",
})
_DIFFICULTY_KEYS = frozenset({"planner", "planner_version", "runs", "budget_checks", "successes", "success_rate",
                              "success_interval", "median_checks_to_first"})


@dataclass(frozen=True)
class JointLimit:
    """An active joint's type and limits, as the URDF states them."""

    joint: str
    type: JointType
    lower: float
    upper: float


@dataclass(frozen=True)
class ObjectRecord:
    """One object of the puzzle; ``interlock_margin`` is the measured margin (metres) of a movable
    object other than the target, None for the others; ``necessity`` how the verdict that it is
    needed was reached (one of :data:`~phyrogen_core.maker.NECESSITY_KINDS`; None when unknown)."""

    name: str
    motion: Motion
    role: Role
    joints: tuple[str, ...]
    interlock_margin: float | None = None
    necessity: str | None = None


@dataclass(frozen=True)
class DependencyGraph:
    """Which object blocks which (``edges`` are (blocker, blocked)), with the graph's depth and
    branching; these two are None after an edit in Blender, until a new plan."""

    nodes: tuple[str, ...]
    edges: tuple[tuple[str, str], ...]
    depth: int | None = None
    branching: int | None = None


@dataclass(frozen=True)
class PuzzleRecord:
    """The contents of one ``puzzle.json``. :meth:`to_json` is the file's exact text."""

    name: str
    generator: str
    seed: int
    parameters: Mapping[str, Any]
    joint_order: tuple[str, ...]
    joint_limits: tuple[JointLimit, ...]  # sorted by joint name
    start: tuple[float, ...]
    goal: Goal
    objects: tuple[ObjectRecord, ...]
    dependency_graph: DependencyGraph
    certificate: tuple[tuple[float, ...], ...]
    certificate_actions: int
    versions: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))
    certificate_verified: bool = True
    """False after an edit in Blender: the certificate was found for the puzzle before the edit."""
    provenance: Provenance = field(default_factory=Provenance)
    difficulty: Difficulty | None = None
    """Measured only on request (a measurement of the puzzle, not part of it: :meth:`same_puzzle` ignores it)."""

    def __post_init__(self) -> None:
        # Read-only views of copies: a record cannot change under a caller that holds it.
        object.__setattr__(self, "parameters", MappingProxyType(_copy(dict(self.parameters))))
        object.__setattr__(self, "versions", MappingProxyType(dict(self.versions)))
        object.__setattr__(self, "joint_limits", tuple(sorted(self.joint_limits, key=lambda limit: limit.joint)))

    # -- what callers ask ----------------------------------------------------
    @property
    def format_version(self) -> int:
        """The version the file is written as: the oldest that holds everything in the record."""
        if any(o.necessity is not None for o in self.objects):
            return NECESSITY_VERSION
        if self.difficulty is not None:
            return DIFFICULTY_VERSION
        return PROVENANCE_VERSION if self.provenance else 1

    def limit(self, joint: str) -> JointLimit:
        for limit in self.joint_limits:
            if limit.joint == joint:
                return limit
        raise KeyError(joint)

    @property
    def margins(self) -> dict[str, float]:
        """Object name -> measured interlock margin, for the objects that have one."""
        return {o.name: o.interlock_margin for o in self.objects if o.interlock_margin is not None}

    @property
    def necessity(self) -> dict[str, str]:
        """Object name -> how its necessity was shown, for the objects whose record says."""
        return {o.name: o.necessity for o in self.objects if o.necessity is not None}

    def same_puzzle(self, other: PuzzleRecord) -> bool:
        """Whether ``other`` describes the same puzzle, made by any package versions and whether or not
        its difficulty was measured (renders and solutions of the one hold for the other)."""
        return replace(self, versions={}, difficulty=None) == replace(other, versions={}, difficulty=None)

    # -- text ----------------------------------------------------------------
    def to_json(self) -> str:
        """The text of ``puzzle.json``: sorted keys, indent 2, trailing newline; no timestamp, so the
        same puzzle always gives the same bytes."""
        return json.dumps(self.to_dict(), sort_keys=True, indent=2, allow_nan=False) + "\n"

    @classmethod
    def from_json(cls, text: str | bytes, source: str = "puzzle.json") -> PuzzleRecord:
        """The record in the text of a ``puzzle.json``; raises PuzzleFormatError naming ``source`` and the key."""
        try:
            data = json.loads(text)
        except RecursionError:
            raise PuzzleFormatError(f"{source}: malformed JSON: nested too deeply") from None
        except ValueError as exc:
            raise PuzzleFormatError(f"{source}: malformed JSON: {str(exc).splitlines()[0]}") from None
        return cls.from_dict(data, source)

    def to_dict(self) -> dict[str, Any]:
        """The JSON data of ``puzzle.json``."""
        data: dict[str, Any] = {
            "format_version": self.format_version,
            "generator": self.generator,
            "name": self.name,
            "seed": self.seed,
            "parameters": _copy(dict(self.parameters)),
            "joint_order": list(self.joint_order),
            "joint_limits": {limit.joint: {"type": limit.type.value, "lower": limit.lower, "upper": limit.upper}
                             for limit in self.joint_limits},
            "start": list(self.start),
            "goal": {"target": self.goal.target, "values": dict(self.goal.values), "tolerance": self.goal.tolerance},
            "objects": [_object_dict(o) for o in self.objects],
            "dependency_graph": _graph_dict(self.dependency_graph),
            "certificate": [list(state) for state in self.certificate],
            "certificate_actions": self.certificate_actions,
            "versions": dict(self.versions),
        }
        if not self.certificate_verified:
            data["certificate_verified"] = False
        if self.provenance:
            data["provenance"] = _provenance_dict(self.provenance)
        if self.difficulty is not None:
            data["difficulty"] = _difficulty_dict(self.difficulty)
        return data

    @classmethod
    def from_dict(cls, data: object, source: str = "puzzle.json") -> PuzzleRecord:
        """The record of ``puzzle.json``'s JSON data, upgraded to the newest format; strict (see the module)."""
        return _Parser(str(source)).record(data)


def folder_identity(data: object, name: object = None, generator: object = None) -> tuple[object, object, object]:
    """(name, generator, seed) as a ``puzzle.json``'s data states them; ``name`` and ``generator``
    stand in for keys it lacks, None for a seed it lacks.

    For finding folders (:meth:`~phyrogen_core.folder.PuzzleFolder.open`), which must not
    fail on a file the strict reader would refuse for another reason: the caller checks the values.
    """
    if not isinstance(data, Mapping):
        return name, generator, None
    return data.get("name", name), data.get("generator", generator), data.get("seed")


# -- writing -------------------------------------------------------------------
def _copy(value: Any) -> Any:
    """A deep copy of JSON data (mappings to dicts, tuples to lists)."""
    if isinstance(value, Mapping):
        return {key: _copy(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_copy(item) for item in value]
    return value


def _with_known(data: dict[str, Any], **optional: Any) -> dict[str, Any]:
    """``data`` with each of ``optional`` that is known (not None), in order: ``puzzle.json`` leaves
    out a value nobody measured rather than writing null."""
    data.update((key, value) for key, value in optional.items() if value is not None)
    return data


def _object_dict(obj: ObjectRecord) -> dict[str, Any]:
    return _with_known({"name": obj.name, "motion": obj.motion.value, "role": obj.role.value,
                        "joints": list(obj.joints)}, interlock_margin=obj.interlock_margin, necessity=obj.necessity)


def _graph_dict(graph: DependencyGraph) -> dict[str, Any]:
    return _with_known({"nodes": list(graph.nodes), "edges": [list(edge) for edge in graph.edges]},
                       depth=graph.depth, branching=graph.branching)


def _run_dict(run: PlannerRun | None) -> dict[str, Any] | None:
    if run is None:
        return None
    return {"planner": run.planner, "budget": run.budget, "seed": run.seed, "queries": run.queries}


def _provenance_dict(provenance: Provenance) -> dict[str, Any]:
    imported = provenance.imported
    return _with_known({}, certified=_run_dict(provenance.certified), replanned=_run_dict(provenance.replanned),
                       imported=None if imported is None else {
                           "file": imported.file, "sha256": imported.sha256, "robot": imported.robot,
                           "joints": {j.joint: {"urdf_joint": j.urdf_joint, "sign": j.sign, "offset": j.offset}
                                      for j in imported.joints}})


def _difficulty_dict(difficulty: Difficulty) -> dict[str, Any]:
    return {"planner": difficulty.planner, "planner_version": difficulty.planner_version, "runs": difficulty.runs,
            "budget_checks": difficulty.budget_checks, "successes": difficulty.successes,
            "success_rate": difficulty.success_rate,
            "success_interval": [difficulty.success_low, difficulty.success_high],
            "median_checks_to_first": difficulty.median_checks_to_first}


# -- reading -------------------------------------------------------------------
class _Parser:
    """One strict parse; holds the source for error messages."""

    def __init__(self, source: str) -> None:
        self.source = source

    def error(self, message: str) -> PuzzleFormatError:
        return PuzzleFormatError(f"{self.source}: {message}")

    def record(self, data: object) -> PuzzleRecord:
        if not isinstance(data, dict):
            raise self.error(f"must hold a JSON object, got {type(data).__name__}")
        data = self.upgraded(data)
        name = self.field(data, "name", str)
        joint_order = tuple(self.strings(data, "joint_order"))
        objects = self.objects(self.field(data, "objects", list))
        start = self.state(data.get("start"), len(joint_order), "start")
        states = self.field(data, "certificate", list)
        too_long = CERTIFICATE_STATES.problem(len(states))  # before any state is read
        if too_long is not None:
            raise self.error(f"certificate {too_long}")
        certificate = tuple(self.state(state, len(joint_order), f"certificate[{i}]") for i, state in enumerate(states))
        goal = self.goal(self.field(data, "goal", dict), joint_order)
        names = [o.name for o in objects]
        if goal.target not in names:
            raise self.error(f"goal.target {goal.target!r} is not one of the objects {sorted(names)}")
        verified = data.get("certificate_verified", True)
        if not isinstance(verified, bool):
            raise self.error(f"certificate_verified must be a bool, got {_show(verified)}")
        versions = self.field(data, "versions", dict)
        for key, value in versions.items():
            if not isinstance(value, str):
                raise self.error(f"versions.{key} must be a str, got {_show(value)}")
        parameters = self.field(data, "parameters", dict)
        self.finite(parameters, "parameters")
        # After the known keys: a misspelt key is reported as the key it should have been.
        unknown = sorted(set(data) - _KEYS)
        if unknown:
            raise self.error(f"unknown key {unknown[0]!r}; valid: {sorted(_KEYS)}")
        return PuzzleRecord(
            name=name,
            generator=self.field(data, "generator", str),
            seed=self.integer(data, "seed"),
            parameters=parameters,
            joint_order=joint_order,
            joint_limits=self.joint_limits(self.field(data, "joint_limits", dict)),
            start=start,
            goal=goal,
            objects=objects,
            dependency_graph=self.graph(self.field(data, "dependency_graph", dict)),
            certificate=certificate,
            certificate_actions=self.integer(data, "certificate_actions", low=0),
            versions=versions,
            certificate_verified=verified,
            provenance=self.provenance(data.get("provenance", {})),
            difficulty=None if "difficulty" not in data else self.difficulty(data["difficulty"]),
        )

    def upgraded(self, data: dict[str, Any]) -> dict[str, Any]:
        """``data`` in the newest format (a copy when it had to change)."""
        version = data.get("format_version", 1)
        if not isinstance(version, int) or isinstance(version, bool) or not 1 <= version <= FORMAT_VERSION:
            raise self.error(f"format_version {version!r} is not supported; valid: 1 to {FORMAT_VERSION}")
        if "difficulty" in data and version < DIFFICULTY_VERSION:
            raise self.error(f"difficulty is a key of format_version {DIFFICULTY_VERSION}; this file is version "
                             f"{version}")
        if version < NECESSITY_VERSION:
            entries = data.get("objects")
            if isinstance(entries, list) and any(isinstance(e, dict) and "necessity" in e for e in entries):
                raise self.error(f"objects[].necessity is a key of format_version {NECESSITY_VERSION}; this file is "
                                 f"version {version}")
        if version >= PROVENANCE_VERSION:
            return data
        if "provenance" in data:
            raise self.error(f"provenance is a key of format_version {PROVENANCE_VERSION}; "
                             f"this file is version {version}")
        data = dict(data)
        provenance: dict[str, Any] = {}
        if "replanned_by" in data:
            provenance["replanned"] = data.pop("replanned_by")
        parameters = data.get("parameters")
        if isinstance(parameters, dict):
            parameters = dict(parameters)
            if "certified_by" in parameters:
                provenance["certified"] = parameters.pop("certified_by")
            if data.get("generator") == IMPORTED_GENERATOR and "source" in parameters:
                provenance["imported"] = {**parameters.pop("source"), "joints": {}} \
                    if isinstance(parameters["source"], dict) else parameters.pop("source")
            data["parameters"] = parameters
        if provenance:
            data["provenance"] = provenance
        return data

    # -- parts -------------------------------------------------------------
    def objects(self, entries: list[Any]) -> tuple[ObjectRecord, ...]:
        out = []
        for index, entry in enumerate(entries):
            where = f"objects[{index}]"
            if not isinstance(entry, dict):
                raise self.error(f"{where} must be an object with name, motion, role")
            self.known(entry, {"name", "motion", "role", "joints", "interlock_margin", "necessity"}, where)
            margin = entry.get("interlock_margin")
            necessity = entry.get("necessity")
            if necessity is not None and necessity not in NECESSITY_KINDS:
                raise self.error(f"{where}.necessity {_show(necessity)} is not valid; valid: {list(NECESSITY_KINDS)}")
            if necessity is not None and margin is None:
                raise self.error(f"{where}.necessity without {where}.interlock_margin: only a needed object "
                                 "has a verdict")
            out.append(ObjectRecord(
                name=self.field(entry, "name", str, where),
                motion=self.enum(Motion, self.field(entry, "motion", str, where), f"{where}.motion"),
                role=self.enum(Role, self.field(entry, "role", str, where), f"{where}.role"),
                joints=tuple(self.strings(entry, "joints", where)),
                interlock_margin=None if margin is None else self.number(margin, f"{where}.interlock_margin"),
                necessity=necessity,
            ))
        return tuple(out)

    def joint_limits(self, limits: dict[str, Any]) -> tuple[JointLimit, ...]:
        out = []
        for name, entry in limits.items():
            label = f"joint_limits.{name}"
            if not isinstance(entry, dict):
                raise self.error(f"{label} must be an object with type, lower, upper")
            self.known(entry, {"type", "lower", "upper"}, label)
            kind = self.enum(JointType, self.field(entry, "type", str, label), f"{label}.type")
            lower, upper = (self.number(entry.get(key), f"{label}.{key}") for key in ("lower", "upper"))
            out.append(JointLimit(name, kind, lower, upper))
        return tuple(out)

    def goal(self, goal: dict[str, Any], joint_order: Sequence[str]) -> Goal:
        self.known(goal, {"target", "values", "tolerance"}, "goal")
        target = self.field(goal, "target", str, "goal")
        values = self.field(goal, "values", dict, "goal")
        for joint_name in values:
            if joint_name not in joint_order:
                raise self.error(f"goal joint {joint_name!r} is not in joint_order {list(joint_order)}")
        tolerance = self.number(goal.get("tolerance"), "goal.tolerance")
        return Goal(target, {k: self.number(v, f"goal.values.{k}") for k, v in values.items()}, tolerance)

    def graph(self, graph: dict[str, Any]) -> DependencyGraph:
        self.known(graph, {"nodes", "edges", "depth", "branching"}, "dependency_graph")
        edges = self.field(graph, "edges", list, "dependency_graph")
        for index, edge in enumerate(edges):
            if not (isinstance(edge, list) and len(edge) == 2 and all(isinstance(n, str) for n in edge)):
                raise self.error(f"dependency_graph.edges[{index}] must be [blocker, blocked] (two names), "
                                 f"got {_show(edge)}")
        shape = {key: None if key not in graph else self.integer(graph, key, "dependency_graph", low=0)
                 for key in ("depth", "branching")}
        return DependencyGraph(tuple(self.strings(graph, "nodes", "dependency_graph")),
                               tuple((a, b) for a, b in edges), shape["depth"], shape["branching"])

    def provenance(self, data: object) -> Provenance:
        if not isinstance(data, dict):
            raise self.error(f"provenance must be a dict, got {_show(data)}")
        self.known(data, {"certified", "replanned", "imported"}, "provenance")
        runs = {key: None if key not in data else self.run(data[key], f"provenance.{key}")
                for key in ("certified", "replanned")}
        imported = None
        if "imported" in data:
            entry = data["imported"]
            where = "provenance.imported"
            if not isinstance(entry, dict):
                raise self.error(f"{where} must be a dict, got {_show(entry)}")
            self.known(entry, {"file", "sha256", "robot", "joints"}, where)
            joints = []
            for joint, item in self.field(entry, "joints", dict, where).items():
                label = f"{where}.joints.{joint}"
                if not isinstance(item, dict):
                    raise self.error(f"{label} must be a dict with urdf_joint, sign, offset")
                self.known(item, {"urdf_joint", "sign", "offset"}, label)
                joints.append(ImportedJoint(joint, self.field(item, "urdf_joint", str, label),
                                            self.number(item.get("sign"), f"{label}.sign"),
                                            self.number(item.get("offset"), f"{label}.offset")))
            imported = Imported(self.field(entry, "file", str, where), self.field(entry, "sha256", str, where),
                                self.field(entry, "robot", str, where),
                                tuple(sorted(joints, key=lambda j: j.joint)))
        return Provenance(runs["certified"], runs["replanned"], imported)

    def difficulty(self, data: object) -> Difficulty:
        where = "difficulty"
        if not isinstance(data, dict):
            raise self.error(f"{where} must be a dict, got {_show(data)}")
        self.known(data, set(_DIFFICULTY_KEYS), where)
        interval = self.field(data, "success_interval", list, where)
        if len(interval) != 2:
            raise self.error(f"{where}.success_interval must be [low, high], got {_show(interval)}")
        if "median_checks_to_first" not in data:
            raise self.error(f"missing key '{where}.median_checks_to_first'")
        median = data["median_checks_to_first"]
        if median is not None and (isinstance(median, bool) or not isinstance(median, int | float)
                                   or not 0 <= median < math.inf):
            raise self.error(f"{where}.median_checks_to_first must be a finite number of checks or null, "
                             f"got {_show(median)}")
        runs, successes = self.integer(data, "runs", where, low=1), self.integer(data, "successes", where, low=0)
        rate = self.number(data.get("success_rate"), f"{where}.success_rate")
        if successes > runs or rate != successes / runs:
            raise self.error(f"{where}: success_rate {rate!r} with {successes} successes of {runs} runs "
                             "does not add up")
        try:
            return Difficulty(self.field(data, "planner", str, where), self.field(data, "planner_version", str, where),
                              runs, self.integer(data, "budget_checks", where, low=1), successes,
                              *(self.number(v, f"{where}.success_interval") for v in interval),
                              None if median is None else float(median))
        except ValueError as exc:
            raise self.error(str(exc)) from None

    def run(self, data: object, where: str) -> PlannerRun:
        if not isinstance(data, dict):
            raise self.error(f"{where} must be a dict with planner, budget, seed, queries, got {_show(data)}")
        self.known(data, {"planner", "budget", "seed", "queries"}, where)
        return PlannerRun(self.field(data, "planner", str, where), self.integer(data, "budget", where, low=0),
                          self.integer(data, "seed", where), self.integer(data, "queries", where, low=0))

    # -- primitives --------------------------------------------------------
    def known(self, mapping: Mapping[str, Any], keys: set[str], where: str) -> None:
        unknown = sorted(set(mapping) - keys)
        if unknown:
            raise self.error(f"unknown key {where}.{unknown[0]}; valid: {sorted(keys)}")

    def field(self, mapping: Mapping[str, Any], key: str, kind: type, where: str = "") -> Any:
        label = f"{where}.{key}" if where else key
        if key not in mapping:
            raise self.error(f"missing key {label!r}")
        value = mapping[key]
        if not isinstance(value, kind) or (kind is not bool and isinstance(value, bool)):
            raise self.error(f"{label} must be a {kind.__name__}, got {_show(value)}")
        return value

    def integer(self, mapping: Mapping[str, Any], key: str, where: str = "", low: int | None = None) -> int:
        value = self.field(mapping, key, int, where)
        if low is not None and value < low:
            raise self.error(f"{where + '.' if where else ''}{key} = {value!r} must be at least {low}")
        return value

    def strings(self, mapping: Mapping[str, Any], key: str, where: str = "") -> list[str]:
        values = self.field(mapping, key, list, where)
        if not all(isinstance(v, str) for v in values):
            label = f"{where}.{key}" if where else key
            raise self.error(f"{label} must be a list of strings, got {_show(values)}")
        return values

    def number(self, value: Any, label: str) -> float:
        """A finite number within :data:`MAX_MAGNITUDE`."""
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.error(f"{label} must be a number, got {_show(value)}")
        if not -MAX_MAGNITUDE <= value <= MAX_MAGNITUDE:  # also false for NaN
            raise self.error(f"{label} = {value!r} must be a finite number within +-{MAX_MAGNITUDE:g}")
        return float(value)

    def state(self, value: Any, size: int, label: str) -> tuple[float, ...]:
        if not isinstance(value, list) or len(value) != size:
            raise self.error(f"{label} must be a list of {size} numbers (one per joint), got {_show(value)}")
        return tuple(self.number(v, f"{label}[{i}]") for i, v in enumerate(value))

    def finite(self, value: Any, label: str) -> None:
        """Every number in the JSON data ``value`` is finite (a record may come from Python, not a file)."""
        if isinstance(value, float) and not math.isfinite(value):
            raise self.error(f"{label} is {value!r}; every number in the file must be finite")
        if isinstance(value, dict):
            for key, item in value.items():
                if not isinstance(key, str):
                    raise self.error(f"{label}: key {key!r} must be a string")
                self.finite(item, f"{label}.{key}")
        elif isinstance(value, list):
            for index, item in enumerate(value):
                self.finite(item, f"{label}[{index}]")

    def enum(self, kind, value: str, label: str):
        try:
            return kind(value)
        except ValueError:
            valid = [member.value for member in kind]
            raise self.error(f"{label} {_show(value)} is not valid; valid: {valid}") from None


def _show(value: Any, width: int = 80) -> str:
    """``repr(value)``, cut to ``width`` characters: messages stay one short line whatever a file holds."""
    text = repr(value)
    return text if len(text) <= width else text[:width - 3] + "..."

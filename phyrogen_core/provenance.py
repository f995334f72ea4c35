"""Where a puzzle's certificate and geometry came from, when not from a generator alone.

A generated puzzle has none of these: its generator, parameters and seed say
everything. An imported puzzle was read from a URDF file and certified by a
planner; any puzzle may have been re-planned later. ``puzzle.json`` keeps
them under one key, ``provenance`` (:mod:`phyrogen_core.record`).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PlannerRun:
    """A planner's run that found the certificate: its name, collision-query budget, RNG seed and
    the queries it spent (budgets are counted in queries, not seconds, so the run can be repeated)."""

    planner: str
    budget: int
    seed: int
    queries: int


@dataclass(frozen=True)
class ImportedJoint:
    """How the puzzle's joint ``joint`` maps to the source URDF's joint ``urdf_joint``:
    ``value = sign * urdf_value - offset``."""

    joint: str
    urdf_joint: str
    sign: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class Imported:
    """The URDF file an imported puzzle was read from.

    ``joints`` maps each joint of the puzzle to the source joint it was made
    from (sorted by puzzle joint), since the import renames them: a slider's
    ``door_joint`` becomes ``door_link``, an SE(2) chain's joints
    ``<object>_x``, ``_y``, ``_yaw``. It is empty for puzzles imported before
    the map was recorded.
    """

    file: str
    sha256: str
    robot: str
    joints: tuple[ImportedJoint, ...] = ()


@dataclass(frozen=True)
class Provenance:
    """Who made the certificate and from what: ``certified`` (the planner that certified an
    imported puzzle), ``replanned`` (the last ``phyrogen replan`` or panel Re-plan; the folder's
    earlier renders and solutions went to ``stale/<n>/`` then), ``imported`` (the source URDF)."""

    certified: PlannerRun | None = None
    replanned: PlannerRun | None = None
    imported: Imported | None = None

    def __bool__(self) -> bool:
        return any(v is not None for v in (self.certified, self.replanned, self.imported))

"""The audit: exported puzzles re-checked independently of the Maker.

The Maker certifies what it builds with its own checks; the audit asks the
same questions of the exported folder, harder, and with a second referee:

1. **The certificate holds.** Our checker
   (:func:`~solver.planning.problem.verify_certificate`: start, limits, collisions at
   2 mm, goal), then a replay by an independent :class:`Referee` (PyBullet,
   :mod:`manipulation.replay`, injected by the caller: this layer does not
   import PyBullet) on the exported URDF; the deepest penetration between
   two objects must stay within the referee's tolerance.
2. **Every object is necessary.** For each movable object except the target,
   both of the Maker's judges try to solve the puzzle with that object fixed
   and every shape shrunk by the puzzle's ``interlock_margin``, each with a
   budget far larger than the Maker's: LA-RRT with pushes
   (:func:`solver.validation.judge.attempt_fixed`, :data:`DEFAULT_BUDGET`
   queries) and the second judge, the paper's LA-RRT with goal states from
   its own goal sampler (:func:`solver.validation.judge.attempt_second`,
   :func:`second_budget` checks, goal sampling included). An object that
   EITHER judge solves the puzzle without is superfluous, and so is one that the
   Maker's staged try solves where both failed
   (:func:`solver.validation.judge.attempt_staged`: blockers moved aside one by
   one, then the target to its goal); the path is kept and
   replayed by the referee, judged twice: at the exact geometry and at the
   shrunk geometry it was planned for. Each object's record carries the
   second judge's goal accounting: a necessary object whose fixing left no
   valid goal state found is told apart from one with goal states and no path.

Determinism: budgets are counted in collision queries and each attempt's
rng is seeded from the puzzle's and the object's names
(:func:`attempt_seed`), so the same folder gets the same verdicts and paths
on any machine, in any order, on any number of workers; a larger budget only
extends the same search.
"""

from __future__ import annotations

import json
import os
import stat
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from phyrogen_core.actions import count_actions
from phyrogen_core.chain import KinematicChain
from phyrogen_core.folder import (
    MAX_FILE_BYTES,
    OutputError,
    PuzzleFolder,
    PuzzleFormatError,
    require_writable_dir,
    write_file_atomic,
)
from phyrogen_core.generators.kit import MAX_INTERLOCK_MARGIN
from phyrogen_core.seeding import stable_seed
from solver.parallel.pool import fresh_process_pool
from solver.planning.goal_sampling import GoalAccount
from solver.validation.judge import (
    FIRST_JUDGE,
    JUDGE_BUDGET,
    NO_GOAL_STATE,
    NO_PATH,
    SECOND_JUDGE,
    attempt_fixed,
    attempt_second,
    attempt_staged,
)

BUDGET_FACTOR = 25
"""The audit's budget per attempt, as a multiple of the Maker's :data:`~solver.validation.judge.JUDGE_BUDGET`."""
DEFAULT_BUDGET = BUDGET_FACTOR * JUDGE_BUDGET
"""Collision queries one attempt may spend by default (100 000: about 4 to 12 s per object on
the paper's puzzles, on one core; docs/audit.md)."""
MAX_BUDGET = 100 * DEFAULT_BUDGET
"""The largest ``--budget``: ten million queries, half an hour or more per object."""
DEFAULT_MARGIN = 0.01
"""The ``interlock_margin`` of a puzzle whose ``puzzle.json`` names none (the generators' default)."""
REPORT_JSON = "audit.json"
REPORT_MARKDOWN = "audit.md"
REPORT_FORMAT = "phyrogen-audit"
"""The ``format`` key of ``audit.json``: an existing file without it is not the audit's to overwrite."""
MARKDOWN_MARKER = "<!-- phyrogen audit report: rewritten by every `phyrogen audit --out` into this folder -->"
"""The first line of ``audit.md``; likewise."""
_PRELOAD = ["numpy", "phyrogen_core", "phyrogen_core.export", "solver.collision.kernels", "solver.planning.la_rrt",
            "solver.validation.judge", "solver.pipelines.audit", "solver.pipelines._server_warmup"]
"""What the server of the audit's worker processes imports before it forks them; the last one loads the compiled
kernels there, once, instead of in every worker."""


# -- the referee ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Replay:
    """A path replayed by a referee: the deepest penetration between links of two objects."""

    depth: float  # metres, >= 0
    states: int  # states replayed (the path densified at the referee's resolution)
    state: int = -1  # index of the deepest state among them; -1 when nothing penetrates
    links: tuple[str, ...] = ()  # the two links that penetrate deepest
    problem: str | None = None  # why the path was not replayed


class Referee(Protocol):
    """An independent collision checker that replays paths on a puzzle's URDF file."""

    name: str
    resolution: float  # metres any collision point moves between replayed states
    tolerance: float  # metres of penetration that still count as touching

    def replay(self, urdf: str | Path, chain: KinematicChain, path: Sequence[Sequence[float]]) -> Replay: ...


# -- what is audited --------------------------------------------------------------------------
@dataclass(frozen=True)
class PuzzleToAudit:
    """One puzzle folder, read and checked before any work starts."""

    folder: str
    name: str
    generator: str
    seed: int
    margin: float  # metres every shape is shrunk by in the attempts (the puzzle's interlock_margin)
    movable: int  # movable objects
    attempted: tuple[str, ...]  # the movable objects other than the target, in joint order
    actions: int  # actions of the stored certificate
    joint_order: tuple[str, ...]
    edited: bool = False  # an edited puzzle: its certificate was found before the edit


def plan_audit(folders: Sequence[PuzzleFolder]) -> list[PuzzleToAudit]:
    """Read every folder strictly (:func:`~phyrogen_core.export.read_puzzle_dir`) and its margin.

    Raises :class:`~phyrogen_core.folder.PuzzleFormatError` (a ValueError, one line naming the
    file) on the first broken folder, before any attempt runs.
    """
    from phyrogen_core.export import read_puzzle_dir

    out = []
    for folder in folders:
        loaded = read_puzzle_dir(folder.path)
        record = loaded.record
        movable = loaded.chain.object_names
        out.append(PuzzleToAudit(
            str(folder.path), folder.name, record.generator, record.seed,
            interlock_margin(record.parameters, folder.metadata), len(movable),
            tuple(name for name in movable if name != loaded.goal.target),
            count_actions(loaded.certificate, loaded.chain.factors), loaded.joint_order,
            not record.certificate_verified))
    return out


def interlock_margin(parameters: Mapping[str, Any], source: str | Path) -> float:
    """The generator parameter ``interlock_margin`` of a puzzle (:data:`DEFAULT_MARGIN` when absent):
    metres in [0, :data:`~phyrogen_core.generators.kit.MAX_INTERLOCK_MARGIN`], as the generators
    accept. A larger one would shrink the 0.1 m walls to nothing and find every object superfluous."""
    value = parameters.get("interlock_margin", DEFAULT_MARGIN)
    if isinstance(value, bool) or not isinstance(value, int | float) or not 0 <= value <= MAX_INTERLOCK_MARGIN:
        raise PuzzleFormatError(f"{source}: parameters.interlock_margin = {value!r} must be a number of metres "
                                f"in [0, {MAX_INTERLOCK_MARGIN}]")
    return float(value)


def attempt_seed(puzzle: str, obj: str) -> int:
    """The seed of the attempt with object ``obj`` of puzzle ``puzzle`` fixed."""
    return stable_seed("audit", puzzle, obj)


def second_attempt_seed(puzzle: str, obj: str) -> int:
    """The seed of the second judge's attempt with object ``obj`` of puzzle ``puzzle`` fixed."""
    return stable_seed("audit", puzzle, obj, SECOND_JUDGE)


def second_budget(budget: int) -> int:
    """The second judge's checks per attempt for a first-judge ``budget`` of queries: as many checks
    as the first judge has queries (100 000 by default, 50x the Maker's second judge, whose budget
    was halved to keep generation cheap; the audit keeps the larger one), so ``--budget`` scales both."""
    return budget


# -- results ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CertificateAudit:
    """The stored certificate, checked by our model and replayed by the referee."""

    problems: tuple[str, ...] = ()  # what our checker finds wrong
    replay: Replay | None = None
    tolerance: float = 0.0  # the referee's
    error: str | None = None  # the check crashed

    @property
    def replay_ok(self) -> bool:
        return self.replay is not None and self.replay.problem is None and self.replay.depth <= self.tolerance

    @property
    def ok(self) -> bool:
        return self.error is None and not self.problems and self.replay_ok


@dataclass(frozen=True)
class ObjectAudit:
    """One attempt to solve the puzzle with ``name`` fixed; ``superfluous`` when it succeeded."""

    name: str
    seed: int
    budget: int
    shrink: float
    queries: int = 0
    superfluous: bool = False
    path: tuple[tuple[float, ...], ...] = ()  # chain joint order, ``name`` at its start pose
    replay: Replay | None = None  # the path replayed (superfluous objects only)
    exact_threshold: float = 0.0  # the referee's tolerance: the path holds for the exported shapes
    robust_threshold: float = 0.0  # plus 2 x shrink: the path holds for the shapes it was planned with
    error: str | None = None
    solved_by: tuple[str, ...] = ()  # the judges that solved it (the path is the first one's)
    second_budget: int = 0
    second_checks: int = 0  # the second judge's collision checks, goal sampling included
    second_goals: GoalAccount | None = None  # the second judge's goal sampling

    @property
    def necessity(self) -> str:
        """Why the object counts as necessary (:data:`~solver.validation.judge.NO_GOAL_STATE`: the second
        judge found no valid goal state with it fixed; :data:`~solver.validation.judge.NO_PATH`: it
        found some, and no judge a path), or "superfluous"."""
        if self.superfluous:
            return "superfluous"
        return NO_GOAL_STATE if self.second_goals is not None and self.second_goals.states == 0 else NO_PATH

    @property
    def exact_ok(self) -> bool | None:
        """Whether the found path holds at the exported geometry (None: not replayed)."""
        return None if not self._replayed else self.replay.depth <= self.exact_threshold

    @property
    def robust_ok(self) -> bool | None:
        """Whether it holds at the geometry it was planned for, every shape shrunk by ``shrink``."""
        return None if not self._replayed else self.replay.depth <= self.robust_threshold

    @property
    def _replayed(self) -> bool:
        return self.replay is not None and self.replay.problem is None

    @property
    def ok(self) -> bool:
        return self.error is None and not self.superfluous


@dataclass(frozen=True)
class PuzzleAudit:
    """Everything the audit found about one puzzle; ``ok`` when it passes."""

    puzzle: PuzzleToAudit
    certificate: CertificateAudit
    objects: tuple[ObjectAudit, ...]

    @property
    def superfluous(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.objects if o.superfluous)

    @property
    def queries(self) -> int:
        return sum(o.queries for o in self.objects)

    @property
    def second_checks(self) -> int:
        return sum(o.second_checks for o in self.objects)

    @property
    def ok(self) -> bool:
        return self.certificate.ok and all(o.ok for o in self.objects)

    def failures(self) -> list[str]:
        """One line per failure, naming the object or the certificate."""
        name, cert = self.puzzle.name, self.certificate
        # An edited puzzle keeps its old certificate, marked as not verified for it (the Blender panel's Export).
        edited = " (found for the puzzle before it was edited)" if self.puzzle.edited else ""
        out = []
        if cert.error is not None:
            out.append(f"{name}: the certificate check crashed: {cert.error}")
        out += [f"{name}: certificate{edited}: {problem}" for problem in cert.problems]
        if cert.replay is not None and cert.replay.problem is not None:
            out.append(f"{name}: certificate replay: {cert.replay.problem}")
        elif cert.replay is not None and not cert.replay_ok:
            out.append(f"{name}: the certificate{edited} penetrates {_mm(cert.replay.depth)} in the replay "
                       f"({_where(cert.replay)}), above the {_mm(cert.tolerance)} threshold")
        for o in self.objects:
            if o.error is not None:
                out.append(f"{name}: the attempt with {o.name} fixed crashed: {o.error}")
            elif o.superfluous:
                out.append(f"{name}: {o.name} is superfluous: solved with it fixed, shapes shrunk by "
                           f"{o.shrink:g} m, by {' and '.join(o.solved_by)} (first judge {o.queries} queries, "
                           f"second {o.second_checks} checks; {len(o.path)} states); {_verdict(o)}")
        return out


def _mm(metres: float) -> str:
    return f"{metres * 1000:.2f} mm"


def _where(replay: Replay) -> str:
    links = " and ".join(replay.links) or "no links"
    return f"{links}, replayed state {replay.state} of {replay.states}"


def _verdict(o: ObjectAudit) -> str:
    if o.replay is None:
        return "the path was not replayed"
    if o.replay.problem is not None:
        return f"the path was not replayed: {o.replay.problem}"
    exact = "holds" if o.exact_ok else "fails"
    robust = "holds" if o.robust_ok else "fails"
    return (f"replayed, the path penetrates {_mm(o.replay.depth)} ({_where(o.replay)}): it {exact} at the exact "
            f"geometry (<= {_mm(o.exact_threshold)}) and {robust} at the shrunk one (<= {_mm(o.robust_threshold)})")


# -- running -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Task:
    index: int  # of the puzzle in the plan
    puzzle: PuzzleToAudit
    obj: str | None  # None: the certificate
    budget: int
    referee: Referee


def _run_task(task: _Task) -> tuple[int, str | None, CertificateAudit | ObjectAudit]:
    """One worker's job: the certificate of a puzzle, or one object's attempt."""
    from phyrogen_core.export import read_puzzle_dir

    puzzle, referee = task.puzzle, task.referee
    try:
        loaded = read_puzzle_dir(puzzle.folder)
        urdf = PuzzleFolder(Path(puzzle.folder), puzzle.name).urdf
        if task.obj is None:
            return task.index, None, audit_certificate(loaded.chain, loaded.goal, loaded.start, loaded.certificate,
                                                       urdf, referee)
        return task.index, task.obj, audit_object(loaded.chain, loaded.goal, task.obj, puzzle.name, puzzle.margin,
                                                  task.budget, urdf, referee)
    except Exception as exc:  # a crash is a failed check, reported with the rest
        return task.index, task.obj, _crashed(task, f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=4)}")


def _crashed(task: _Task, error: str) -> CertificateAudit | ObjectAudit:
    if task.obj is None:
        return CertificateAudit(tolerance=task.referee.tolerance, error=error)
    return ObjectAudit(task.obj, attempt_seed(task.puzzle.name, task.obj), task.budget, task.puzzle.margin,
                       error=error, second_budget=second_budget(task.budget))


def _lost(task: _Task, how: str) -> tuple[int, str | None, CertificateAudit | ObjectAudit]:
    return task.index, task.obj, _crashed(task, f"the worker process ended ({how}) before it reported")


def audit_certificate(chain: KinematicChain, goal, start, certificate, urdf: str | Path,
                      referee: Referee) -> CertificateAudit:
    """Our checker's problems with ``certificate``, and its replay by ``referee`` on ``urdf``."""
    from solver.planning.problem import verify_certificate

    problems = tuple(verify_certificate(chain, certificate, goal, start=start))
    return CertificateAudit(problems, referee.replay(urdf, chain, certificate), referee.tolerance)


def audit_object(chain: KinematicChain, goal, obj: str, puzzle: str, margin: float, budget: int,
                 urdf: str | Path, referee: Referee) -> ObjectAudit:
    """Both judges try to solve the puzzle with ``obj`` fixed, shapes shrunk by ``margin`` (the second
    with :func:`second_budget` checks, always, so every object has its goal accounting), and the staged
    try where neither did; replay a found path (the first judge's when both found one)."""
    seed = attempt_seed(puzzle, obj)
    first = attempt_fixed(chain, goal, [obj], margin, budget, np.random.default_rng(seed))
    checks = second_budget(budget)
    second = attempt_second(chain, goal, [obj], margin, checks, second_attempt_seed(puzzle, obj))
    solved_by = tuple(a.judge for a in (first, second) if a.solved)
    path = first.path if first.solved else second.path
    if not solved_by:  # the Maker's staged try (plain moves the searches can miss): no rng, a few ms
        staged = attempt_staged(chain, goal, [obj], margin)
        if staged.solved:
            solved_by, path = (staged.judge,), staged.path
    replay = referee.replay(urdf, chain, path) if solved_by else None
    return ObjectAudit(obj, seed, budget, margin, first.queries, bool(solved_by), path, replay,
                       referee.tolerance, referee.tolerance + 2.0 * margin, None, solved_by, checks, second.queries,
                       second.goals)


def check_budget(budget: object) -> int:
    if isinstance(budget, bool) or not isinstance(budget, int) or not 1 <= budget <= MAX_BUDGET:
        raise ValueError(f"budget must be a whole number of collision queries in 1..{MAX_BUDGET}, got {budget!r}")
    return budget


def run_audit(puzzles: Sequence[PuzzleToAudit], referee: Referee, budget: int = DEFAULT_BUDGET, workers: int = 2,
              on_task_done: Callable[[], None] | None = None) -> Iterator[PuzzleAudit]:
    """Audit ``puzzles``, each check in a fresh worker process; yields each puzzle's audit in
    the order of ``puzzles`` as soon as its checks (and those of every puzzle before it) are done.

    Leaving the loop early (an exception, Ctrl-C) stops the running workers.
    """
    check_budget(budget)
    tasks = [_Task(i, p, obj, budget, referee) for i, p in enumerate(puzzles) for obj in (None, *p.attempted)]
    done: list[dict[str | None, Any]] = [{} for _ in puzzles]
    emitted = 0
    # Checks finish in any order (imap_unordered keeps every worker busy); puzzles are reported in order.
    with fresh_process_pool(workers, len(tasks), [*_PRELOAD, type(referee).__module__]) as pool:
        for index, obj, result in pool.imap_unordered(_run_task, tasks, on_lost=_lost):
            done[index][obj] = result
            if on_task_done is not None:
                on_task_done()
            while emitted < len(puzzles) and len(done[emitted]) == 1 + len(puzzles[emitted].attempted):
                puzzle, results = puzzles[emitted], done[emitted]
                yield PuzzleAudit(puzzle, results[None], tuple(results[name] for name in puzzle.attempted))
                done[emitted] = {}
                emitted += 1


def task_count(puzzles: Sequence[PuzzleToAudit]) -> int:
    """Checks :func:`run_audit` runs: one certificate and one attempt per attempted object, per puzzle."""
    return sum(1 + len(p.attempted) for p in puzzles)


# -- reports -------------------------------------------------------------------------------------
TABLE_HEADER = (f"{'generator':18s} {'seed':>5s} {'objects':>7s} {'actions':>7s} {'deepest [mm]':>12s} "
                f"{'replay':>6s} {'tried':>5s} {'queries':>9s}  superfluous / result")


def table_row(audit: PuzzleAudit) -> str:
    """One line of the audit's table: the columns of :data:`TABLE_HEADER`."""
    p, cert = audit.puzzle, audit.certificate
    depth = f"{cert.replay.depth * 1000:12.3f}" if cert.replay is not None and cert.replay.problem is None else \
        f"{'-':>12s}"
    result = "ok" if audit.ok else "FAILED" + (f": {', '.join(audit.superfluous)}" if audit.superfluous else "")
    return (f"{p.generator:18s} {p.seed:5d} {p.movable:7d} {p.actions:7d} {depth} "
            f"{'ok' if cert.replay_ok else 'FAIL':>6s} {len(p.attempted):5d} {audit.queries:9d}  {result}")


@dataclass(frozen=True)
class AuditSettings:
    """What decided the verdicts, stated in every report."""

    budget: int
    referee: str
    resolution: float  # metres between replayed states
    tolerance: float  # metres of penetration the referee counts as touching


def report_data(audits: Sequence[PuzzleAudit], settings: AuditSettings, total: int | None = None
                ) -> dict[str, Any]:
    """``audit.json``'s content: plain JSON data, with no clock or machine in it (the same folder
    gives the same bytes). ``total``: the puzzles the audit set out to check, when it was cut
    short (``complete`` is then false)."""
    total = len(audits) if total is None else total
    return {
        "format": REPORT_FORMAT,
        "format_version": 2,  # 2: the second judge and the goal accounting
        "complete": len(audits) == total,
        "puzzles_total": total,
        "settings": {**asdict(settings), "budget_factor_of_maker": settings.budget / JUDGE_BUDGET,
                     "judges": [FIRST_JUDGE, SECOND_JUDGE], "second_budget": second_budget(settings.budget),
                     "exact_threshold": settings.tolerance,
                     "robust_threshold": "exact_threshold + 2 x the puzzle's interlock_margin"},
        "failed": sum(not a.ok for a in audits),
        "puzzles": [_puzzle_data(a) for a in audits],
    }


def _puzzle_data(audit: PuzzleAudit) -> dict[str, Any]:
    p, cert = audit.puzzle, audit.certificate
    return {
        "folder": p.folder, "name": p.name, "generator": p.generator, "seed": p.seed,
        "interlock_margin": p.margin, "movable_objects": p.movable, "certificate_actions": p.actions,
        "certificate_edited": p.edited, "joint_order": list(p.joint_order), "ok": audit.ok,
        "failures": audit.failures(), "superfluous": list(audit.superfluous), "queries": audit.queries,
        "second_checks": audit.second_checks,
        "certificate": {"problems": list(cert.problems), "replay": _replay_data(cert.replay),
                        "replay_ok": cert.replay_ok, "error": cert.error},
        "objects": [{"name": o.name, "seed": o.seed, "budget": o.budget, "shrink": o.shrink, "queries": o.queries,
                     "superfluous": o.superfluous, "path": [list(s) for s in o.path],
                     "replay": _replay_data(o.replay), "exact_ok": o.exact_ok, "robust_ok": o.robust_ok,
                     "exact_threshold": o.exact_threshold, "robust_threshold": o.robust_threshold,
                     "error": o.error, "solved_by": list(o.solved_by), "necessity": o.necessity,
                     "second_judge": {"budget": o.second_budget, "checks": o.second_checks,
                                      "goals": None if o.second_goals is None else asdict(o.second_goals)}}
                    for o in audit.objects],
    }


def _replay_data(replay: Replay | None) -> dict[str, Any] | None:
    if replay is None:
        return None
    return {"deepest_penetration": replay.depth, "states": replay.states, "deepest_state": replay.state,
            "links": list(replay.links), "problem": replay.problem}


def report_markdown(audits: Sequence[PuzzleAudit], settings: AuditSettings, total: int | None = None) -> str:
    """``audit.md``: the settings, the table, and every failure in a line."""
    failed = [a for a in audits if not a.ok]
    total = len(audits) if total is None else total
    cut = f"**Incomplete: the audit stopped after {len(audits)} of {total} puzzles.** " if len(audits) < total else ""
    lines = [
        MARKDOWN_MARKER, "", "# Puzzle audit", "",
        f"{cut}{len(audits) - len(failed)} of {len(audits)} puzzles pass. Each object is tried by two judges: "
        f"{FIRST_JUDGE} with {settings.budget} collision queries ({settings.budget / JUDGE_BUDGET:g} x the Maker's "
        f"judge) and {SECOND_JUDGE} with {second_budget(settings.budget)} checks, goal sampling included; an object "
        "either one solves the puzzle without is superfluous. A necessary object is counted under 'no goal state' "
        "when the second judge found no valid goal state with it fixed, else under 'no path'. Paths are replayed in "
        f"{settings.referee} every {settings.resolution * 1000:g} mm. A certificate may penetrate at most "
        f"{_mm(settings.tolerance)}; a path found with an object fixed is judged at the exact geometry (the same "
        f"{_mm(settings.tolerance)}) and at the geometry it was planned for (plus 2 x the puzzle's "
        "interlock margin). Found paths are in `audit.json`.", "",
        "| generator | seed | movable objects | certificate actions | deepest replay penetration [mm] | replay ok "
        "| objects attempted | superfluous objects | necessary: no goal state / no path | queries "
        "| second judge checks | result |",
        "|---|---:|---:|---:|---:|---|---:|---|---|---:|---:|---|",
    ]
    for a in audits:
        p, cert = a.puzzle, a.certificate
        depth = f"{cert.replay.depth * 1000:.3f}" if cert.replay is not None and cert.replay.problem is None else "-"
        lines.append(f"| {p.generator} | {p.seed} | {p.movable} | {p.actions} | {depth} | "
                     f"{'yes' if cert.replay_ok else 'no'} | {len(p.attempted)} | {', '.join(a.superfluous) or '-'} "
                     f"| {_necessity_counts(a)} | {a.queries} | {a.second_checks} | {'ok' if a.ok else 'FAILED'} |")
    if failed:
        lines += ["", "## Failures", ""]
        lines += [f"- {line.splitlines()[0]}" for a in failed for line in a.failures()]
    return "\n".join(lines) + "\n"


def _necessity_counts(audit: PuzzleAudit) -> str:
    reasons = [o.necessity for o in audit.objects if o.error is None]
    return f"{reasons.count(NO_GOAL_STATE)} / {reasons.count(NO_PATH)}"


def check_report_folder(out: str | Path) -> Path:
    """Check, before any work, that the reports can be written into ``out`` without replacing a
    file the audit did not write: ``audit.json`` and ``audit.md`` there must be absent or an
    earlier audit's. Raises :class:`~phyrogen_core.folder.OutputError`; creates nothing."""
    out = require_writable_dir(out, "audit output folder")
    for name, ours in ((REPORT_JSON, _is_report_json), (REPORT_MARKDOWN, _is_report_markdown)):
        path = out / name
        if not os.path.lexists(path):
            continue
        try:
            info = os.stat(path)
            mine = stat.S_ISREG(info.st_mode) and info.st_size <= MAX_FILE_BYTES and ours(path)
        except (OSError, UnicodeDecodeError, ValueError):
            mine = False
        if not mine:
            raise OutputError(f"{path} exists and was not written by phyrogen audit; choose another --out, or move "
                              "the file away")
    return out


def _is_report_json(path: Path) -> bool:
    data = json.loads(path.read_text(encoding="utf-8"))
    return isinstance(data, dict) and data.get("format") == REPORT_FORMAT


def _is_report_markdown(path: Path) -> bool:
    with open(path, encoding="utf-8") as handle:
        return handle.readline().rstrip("\n") == MARKDOWN_MARKER


def write_reports(out: str | Path, audits: Sequence[PuzzleAudit], settings: AuditSettings,
                  total: int | None = None) -> tuple[Path, Path]:
    """Write ``audit.json`` and ``audit.md`` into ``out``, each atomically (``total`` as in
    :func:`report_data`)."""
    out = Path(out)
    text = json.dumps(report_data(audits, settings, total), indent=2, sort_keys=True, allow_nan=False) + "\n"
    markdown = report_markdown(audits, settings, total)
    return (write_file_atomic(out / REPORT_JSON, text.encode("utf-8")),
            write_file_atomic(out / REPORT_MARKDOWN, markdown.encode("utf-8")))

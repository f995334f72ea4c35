"""The benchmark planners by name, behind one interface: the :class:`Planner` plug-in shape.

A planner is a :class:`Planner` subclass declaring its settings (name, title, version, parameters),
registered with the :func:`planner` decorator and declared in a package's ``phyrogen.planners``
entry points; the built-ins (:mod:`solver.planning.builtin_planners`) are declared so in PhyRoGen's
own ``pyproject.toml``, and the registry loads every declared entry the first time it is read
(:func:`load_planner_modules`). A trial planner (in a test or a notebook) is a class decorated the
same way, registered into :func:`registry_copy`.

``get_planner(name).plan(problem, time_limit, seed)`` -> :class:`~solver.planning.anytime.PlanResult`
(best path, action cost, first-solution time, cost over time, collision checks and CPU time spent).
Every planner scores paths with :func:`phyrogen_core.actions.count_actions`, runs until its time
limit (all are anytime), or until a budget of collision checks is spent (``budget_checks``, a motion
charged by its length in resolution steps: the time limit is then only a backstop, and the same seed
and budget give the same result on any machine) or of CPU seconds (``budget_cpu``, machine-dependent), or,
with ``until_first``, until its first solution that holds at fine resolution, and takes its goal
states from the shared goal sampler (:mod:`solver.planning.goal_sampling`) seeded with ``goal_seed``:
the benchmark gives every planner of a run the same one. Planners marked ``uses_ompl_rng`` draw
from OMPL's global RNG too: run each of their runs in a fresh process that seeded it with the run's
seed (:func:`solver.planning.ompl_setup.seed_ompl`), as :mod:`solver.benchmark.runner` does.

The registry feeds the benchmark (jobs, logs, journal keys, plots), the command line's
``benchmark --planners`` (its choices and help) and the docs' tables (a test compares them).
The audit and the Maker's necessity judge do not choose a planner by name: they run
:func:`solver.planning.la_rrt.la_rrt_within` with the judge's own settings
(:mod:`solver.validation.judge`), which must not change with the benchmark's entries.

The built-in entries (:mod:`solver.planning.builtin_planners`), in the order of logs, tables and plots:

- ``la_rrt`` "LA-RRT": the paper's LA-RRT (:data:`solver.planning.la_rrt.PAPER_SETTINGS`);
- ``la_rrt_push`` "LA-RRT+push (ours)": our LA-RRT with blocker pushes and the
  other additions of :mod:`solver.planning.la_rrt` (:data:`solver.planning.la_rrt.PUSH_SETTINGS`);
- ``rrt_star`` "RRT*", ``lbt_rrt`` "LBT-RRT", ``bit_star`` "BIT*";
- outside ``--planners all`` (group "ablations", :data:`GROUPS`): ``la_rrt_segment_check``
  "LA-RRT, original segment check" and ``la_rrt_fixed_order`` "LA-RRT, fixed factor order", the
  paper's LA-RRT with one of its two behaviour changes switched back to the original's.

Each entry has a ``version``: the benchmark journal keys runs by it, so a run
recorded before a planner's code or settings changed is run again, not
reused. Bump the code part by hand when a planner's code changes; its
settings and the goal sampler's are digested into it.

This module imports nothing heavy (the command line builds its parser from it): plan code and
settings are imported when a planner runs or a version is first asked for.
docs/adding-a-planner.md walks through adding a planner.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import importlib.util
import re
import sys
from collections.abc import Callable, Iterator, MutableMapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, ClassVar

from phyrogen_core.plugins import PLANNER_GROUP, GroupLoader, Plugin
from phyrogen_core.seeding import stable_seed

if TYPE_CHECKING:
    from solver.planning.anytime import PlanResult
    from solver.planning.problem import Problem

PlanFunction = Callable[..., "PlanResult"]
"""``plan(problem, time_limit, seed, progress_interval, until_first, goal_seed, budget_checks=None,
budget_cpu=None)`` (``budget_cpu`` is passed only when set: a plan function without it runs every
benchmark but those budgeted in CPU seconds)."""

NAME_PATTERN = re.compile(r"[a-z][a-z0-9_]{0,39}")
"""A planner's name: what ``--planners`` takes, the journal's key and a log-safe word."""


@dataclass(frozen=True)
class PlannerSpec:
    name: str  # registry id, e.g. "la_rrt"
    title: str  # the name in logs and plots, e.g. "LA-RRT"
    plan_function: PlanFunction
    uses_ompl_rng: bool
    code_version: str = "1"  # bumped by hand whenever the planner's code changes
    settings: Callable[[], object] | None = field(default=None, repr=False)
    """Returns the planner's frozen settings, whose repr is digested into :attr:`version`."""
    saves_solution: bool = False  # its best path per puzzle is saved for the manipulation stage
    summary: str = ""  # one line for ``--help`` and the docs: what it is and what it optimizes
    source: tuple[str, str | None] | None = None
    """(module, file) that registered it, so that a fresh worker process can load it; None: built in."""
    group: str | None = None
    """None: one of ``--planners all``; else the name of a set it is run with (:data:`GROUPS`),
    besides by its own name."""

    @cached_property
    def version(self) -> str:
        """The code version, a digest of the settings and the goal sampler's tag: changes whenever
        the planner's code or settings do (see the module docstring)."""
        return _version(self.code_version, None if self.settings is None else self.settings())

    def plan(self, problem: Problem, time_limit: float, seed: int, progress_interval: float = 0.1,
             until_first: bool = False, goal_seed: int | None = None,
             budget_checks: int | None = None, budget_cpu: float | None = None) -> PlanResult:
        """Run for ``time_limit`` seconds, or ``budget_checks`` collision checks or ``budget_cpu`` CPU
        seconds with the time limit as a backstop (or until the first solution when ``until_first``);
        ``seed`` drives the planner's own random draws, ``goal_seed`` the shared goal sampler (default:
        from ``seed``). The result's ``end`` says which ended the run (``solved``: at its first solution)."""
        from dataclasses import replace

        from solver.planning.anytime import check_run_limits, count_checks
        from solver.planning.goal_sampling import default_goal_seed

        check_run_limits(time_limit, budget_checks, budget_cpu)
        if not progress_interval > 0:
            raise ValueError(f"progress_interval must be positive seconds, got {progress_interval!r}")
        goal_seed = default_goal_seed(seed) if goal_seed is None else goal_seed
        # Counted here, so that every registered planner spends a check budget in the same units:
        # a motion costs its length in resolution steps.
        extra = {} if budget_cpu is None else {"budget_cpu": float(budget_cpu)}  # older plan functions lack it
        result = self.plan_function(count_checks(problem, by_length=True), time_limit, seed, progress_interval,
                                    bool(until_first), goal_seed, budget_checks=budget_checks, **extra)
        return replace(result, end="solved") if until_first and result.solved else result


def _version(code: str, settings: object = None) -> str:
    """``code`` (bumped by hand), a digest of ``settings`` (a frozen dataclass) and the goal sampler's tag."""
    from solver.planning.goal_sampling import DEFAULT_GOAL_SETTINGS

    parts = [code]
    if settings is not None:
        parts.append(hashlib.sha256(repr(settings).encode()).hexdigest()[:8])
    parts.append(DEFAULT_GOAL_SETTINGS.tag)
    return "/".join(parts)


class _Planners(MutableMapping[str, PlannerSpec]):
    """The registered planners by name, in registration order. Reading it first loads the
    ``phyrogen.planners`` entry points (:func:`load_planner_modules`), so it is never seen without
    the built-ins; registering does not, so that the modules being loaded can register meanwhile."""

    def __init__(self) -> None:
        self._specs: dict[str, PlannerSpec] = {}

    def _ready(self) -> dict[str, PlannerSpec]:
        load_planner_modules()
        return self._specs

    def __getitem__(self, name: str) -> PlannerSpec:
        return self._ready()[name]

    def __setitem__(self, name: str, spec: PlannerSpec) -> None:
        self._specs[name] = spec

    def __delitem__(self, name: str) -> None:
        del self._specs[name]

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._ready()))

    def __len__(self) -> int:
        return len(self._ready())

    def __repr__(self) -> str:
        return f"PLANNERS({list(self._specs)})"


PLANNERS: MutableMapping[str, PlannerSpec] = _Planners()
"""Every registered planner, in registration order: the built-ins of PhyRoGen's own
``phyrogen.planners`` entry points (the paper's four with our LA-RRT variant after the paper's,
then the ablations), then other packages' plug-ins, then any registered with :func:`planner` since."""

LA_RRT_PLANNERS = ("la_rrt", "la_rrt_push")
"""The built-in entries whose best path is saved into the puzzle folder (the manipulation stage's
input); :func:`solution_planners` lists every registered one."""

GROUPS: dict[str, str] = {
    "ablations": "the paper's LA-RRT with one of its behaviour changes switched back to the original's",
}
"""Named sets of planners outside ``--planners all`` (:attr:`PlannerSpec.group`), and what each holds."""

class Planner:
    """The base of a benchmark planner: its declared settings as class attributes, :meth:`plan` as its
    code. Decorate the class with :func:`planner` to register it, and declare it in your package's
    ``phyrogen.planners`` entry points (``name = "module:Class"``), as the built-ins are in PhyRoGen's
    own ``pyproject.toml`` (docs/adding-a-planner.md).

    ``name``: what ``--planners`` takes and the journal's key (lower-case letters, digits, ``_``);
    ``title``: the name in logs, plots and tables; ``version``: the code version, bumped by hand
    when the code changes (:attr:`PlannerSpec.version` adds a digest of :meth:`settings` and the goal
    sampler's tag); ``uses_ompl_rng``: it draws from OMPL's global RNG; ``saves_solution``: its best
    path per puzzle is saved for the manipulation stage; ``summary``: one line for ``--help`` and the
    docs; ``group``: None for ``--planners all``, else a name of :data:`GROUPS`.
    """

    name: ClassVar[str]
    title: ClassVar[str]
    version: ClassVar[str]
    uses_ompl_rng: ClassVar[bool] = False
    saves_solution: ClassVar[bool] = False
    summary: ClassVar[str] = ""
    group: ClassVar[str | None] = None

    def settings(self) -> object | None:
        """The planner's parameters: a frozen dataclass (digested into its version), or None."""
        return None

    def plan(self, problem: Problem, time_limit: float, seed: int, progress_interval: float, until_first: bool,
             goal_seed: int, budget_checks: int | None = None, budget_cpu: float | None = None) -> PlanResult:
        """One run: a :class:`~solver.planning.anytime.PlanResult`. Build its recorder with
        ``AnytimeRecorder(title, problem, time_limit, progress_interval, budget_checks, budget_cpu)`` on the
        problem it is given (its collision checks are counted) and stop when the recorder expires;
        :func:`solver.planning.ompl_planners.ompl_plan_function` makes a plan function from any
        ``ompl.geometric`` planner. Register in a module, not a script run as ``__main__``: a benchmark
        runs each run in a fresh process, which loads the registering module (by name, else from its
        file) to find the planner."""
        raise NotImplementedError


def planner(cls: type[Planner]) -> type[Planner]:
    """Class decorator: register a :class:`Planner` subclass under its ``name``; returns the class,
    with its registry entry as ``cls.spec``. Raises ValueError for a bad or taken name or title, an
    empty version or an unknown group."""
    if not (isinstance(cls, type) and issubclass(cls, Planner)):
        raise ValueError(f"@planner decorates a subclass of solver.planning.registry.Planner, got {cls!r}")
    missing = [a for a in ("name", "title", "version") if not hasattr(cls, a)]
    if missing or cls.plan is Planner.plan:
        raise ValueError(f"planner class {cls.__qualname__} must declare {', '.join(missing or ['a plan method'])}")
    instance = cls()
    settings = None if cls.settings is Planner.settings else instance.settings
    module = sys.modules.get(cls.__module__)
    cls.spec = _add(cls.name, cls.title, instance.plan, cls.version, cls.uses_ompl_rng, settings, cls.saves_solution,
                    cls.summary, cls.group, (cls.__module__, getattr(module, "__file__", None)))
    return cls


def _add(name: str, title: str, plan: PlanFunction, version: str, uses_ompl_rng: bool,
         settings: Callable[[], object] | None, saves_solution: bool, summary: str, group: str | None,
         source: tuple[str, str | None] | None) -> PlannerSpec:
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name) or name == "all":
        raise ValueError(f"planner name must be 1-40 lower-case letters, digits or _, starting with a letter, "
                         f"and not 'all'; got {name!r}")
    if name in PLANNERS:
        raise ValueError(f"planner {name!r} is registered already (as {PLANNERS[name].title!r}); choose another name")
    if not isinstance(title, str) or not title.strip() or title != title.strip() or "\n" in title:
        raise ValueError(f"planner title must be one line of text without leading or trailing blanks, got {title!r}")
    taken = next((spec.name for spec in PLANNERS.values() if spec.title == title), None)
    if taken is not None:
        raise ValueError(f"planner title {title!r} is taken by {taken!r}; logs and plots tell planners apart by it")
    if not callable(plan):
        raise ValueError(f"plan must be a function, got {plan!r}")
    if not isinstance(version, str) or not version or any(c.isspace() for c in version):
        raise ValueError(f"version must be a non-empty word (bump it when the code changes), got {version!r}")
    if group is not None and group not in GROUPS:
        raise ValueError(f"planner group must be None (one of 'all') or one of {', '.join(GROUPS)}; got {group!r}")
    spec = PlannerSpec(name, title, plan, bool(uses_ompl_rng), version, settings, bool(saves_solution), summary,
                       source, group)
    PLANNERS[name] = spec
    return spec


@contextlib.contextmanager
def registry_copy() -> Iterator[MutableMapping[str, PlannerSpec]]:
    """Register into a copy of the registry for the duration (tests, experiments); the registry is
    as it was afterwards."""
    saved = dict(PLANNERS)
    try:
        yield PLANNERS
    finally:
        PLANNERS.clear()
        PLANNERS.update(saved)


def _registers_planner(plugin: Plugin) -> bool:
    spec = PLANNERS._specs.get(plugin.name)
    return spec is not None and getattr(plugin.loaded, "spec", None) is spec


load_planner_modules = GroupLoader(PLANNER_GROUP, "planner", _registers_planner,
                                   "name a Planner subclass decorated with @planner whose name is {name}")
"""Load every planner declared in the ``phyrogen.planners`` entry-point group, once: the built-ins
(declared in PhyRoGen's own ``pyproject.toml``) first, then other packages' plug-ins
(:mod:`phyrogen_core.plugins`). PluginError (a ValueError) names an entry that does not load or
registers no planner of its name."""


def load_planner_source(name: str, source: tuple[str, str | None] | None) -> None:
    """In a fresh process: load the module that registered ``name`` (by name, else from its file)."""
    load_planner_modules()
    if name in PLANNERS or source is None:
        return
    module, file = source
    if module not in sys.modules:
        try:
            importlib.import_module(module)
        except ImportError:
            if file is None:
                raise
            spec = importlib.util.spec_from_file_location(module, file)
            loaded = importlib.util.module_from_spec(spec)
            sys.modules[module] = loaded  # dataclasses and type hints look their module up by name
            spec.loader.exec_module(loaded)


def planner_names() -> tuple[str, ...]:
    load_planner_modules()
    return tuple(PLANNERS)


def default_planners() -> tuple[str, ...]:
    """What ``--planners all`` runs: every registered planner outside a group (:data:`GROUPS`)."""
    load_planner_modules()
    return tuple(name for name, spec in PLANNERS.items() if spec.group is None)


def select_planners(text: str) -> list[str]:
    """``--planners``: "all", a group name (:data:`GROUPS`) or planner names, comma-separated, in
    any mix ("all,ablations"); each planner once, in registry order. ValueError names an unknown one."""
    load_planner_modules()
    chosen: set[str] = set()
    for word in (w.strip() for w in text.split(",")):
        if word == "all":
            chosen.update(default_planners())
        elif word in GROUPS:
            chosen.update(name for name, spec in PLANNERS.items() if spec.group == word)
        elif word in PLANNERS:
            chosen.add(word)
        else:
            raise ValueError(f"unknown planner {word!r} (known: all, {', '.join(GROUPS)}, {', '.join(PLANNERS)})")
    return [name for name in PLANNERS if name in chosen]


def solution_planners() -> tuple[str, ...]:
    """The registered planners whose best path per puzzle the benchmark saves."""
    load_planner_modules()
    return tuple(name for name, spec in PLANNERS.items() if spec.saves_solution)


def describe_planners() -> str:
    """Every registered planner described for people (``phyrogen list``): its name (what ``--planners``
    takes), title, version (the benchmark journal's key: it imports each planner's settings), the
    group of one outside ``--planners all``, and its summary."""
    load_planner_modules()
    lines = ["planners (phyrogen benchmark --planners NAME,...; the journal keys each run by name and version):"]
    for spec in PLANNERS.values():
        group = "" if spec.group is None else f"; group {spec.group}, not in 'all'"
        lines.append(f"  {spec.name}: {spec.title} (version {spec.version}{group})")
        if spec.summary:
            lines.append(f"      {spec.summary}")
    return "\n".join(lines)


def get_planner(name: str) -> PlannerSpec:
    load_planner_modules()
    try:
        return PLANNERS[name]
    except KeyError:
        raise ValueError(f"unknown planner {name!r}; valid: {', '.join(PLANNERS)}") from None


def plan(name: str, problem: Problem, time_limit: float, seed: int, progress_interval: float = 0.1,
         until_first: bool = False, goal_seed: int | None = None, budget_checks: int | None = None) -> PlanResult:
    """Run the planner registered as ``name``."""
    return get_planner(name).plan(problem, time_limit, seed, progress_interval, until_first, goal_seed,
                                  budget_checks)


def run_seed(planner: str, puzzle: str, run: int, base_seed: int = 0) -> int:
    """The seed of run ``run`` of ``planner`` on ``puzzle``: stable across machines, orders and processes."""
    return stable_seed("run", base_seed, planner, puzzle, run)

"""The registry of generators by name: feeds the CLI, the tests, the benchmark and the Blender panel.

A generator is registered with everything that is known about it: its
parameters (a frozen dataclass whose fields say what they mean, see
:func:`parameter`), whether it is one of the paper's six and in which row of
Table I, and its benchmark time limit in every profile. Generators are
plug-ins: each is a ``build`` function decorated with :func:`register` and
declared in the ``phyrogen.generators`` entry-point group of its package, the
built-in six in PhyRoGen's own ``pyproject.toml`` like any other package's
(:mod:`phyrogen_core.plugins`). They are loaded the first time the registry is
asked for anything, so it is never seen empty; this module imports no
generator. ``docs/adding-a-generator.md`` walks through adding one.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import reprlib
import textwrap
import typing
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from numbers import Integral, Real
from typing import Any

from .maker import MakerInput
from .plugins import GENERATOR_GROUP, GroupLoader, Plugin

BENCHMARK_PROFILES = ("paper", "quick")
"""The benchmark profiles (``solver.benchmark.runner``) every generator gives a time limit for:
``paper`` the paper's protocol, ``quick`` a short run of the same planners."""

MAX_SEED = 2**63 - 1
"""The largest seed (numpy's seeding takes any non-negative integer; this keeps names and logs bounded)."""


def merge_seed_spans(spans: list[tuple[int, int]]) -> tuple[tuple[int, int], ...]:
    """Inclusive (low, high) seed spans, sorted and merged where they overlap or touch."""
    merged: list[list[int]] = []
    for low, high in sorted(spans):
        if merged and low <= merged[-1][1] + 1:
            merged[-1][1] = max(merged[-1][1], high)
        else:
            merged.append([low, high])
    return tuple((low, high) for low, high in merged)


Build = Callable[[int, Any], MakerInput]
"""``build(seed, params)``: a generator's input tuple to the Maker."""


MAX_INTEGER = 2**63 - 1
"""The largest magnitude of an integer parameter: numpy, OMPL and SQLite hold no larger integer,
and no generator has a use for one (its ``validate`` sets the real range)."""


class ParameterError(ValueError):
    """A generator parameter is unknown or has a bad value."""


def parameter(default: Any, doc: str, *, difficulty: bool = False) -> Any:
    """A field of a generator's parameter dataclass: its default, what it means, and
    whether it is one of the generator's difficulty knobs.

    ``n_objects: int = parameter(0, "how many sliders; 0: Seed + 1, as in the paper", difficulty=True)``
    """
    return field(default=default, metadata={"doc": doc, "difficulty": difficulty})


@dataclass(frozen=True)
class GeneratorSpec:
    """A registered generator.

    ``build(seed, params)`` returns the generator's input tuple to the Maker.
    ``params`` is a frozen dataclass type whose fields (with defaults, each
    made with :func:`parameter`) are the generator's parameters; its
    ``validate(seed)`` method, when present, raises :class:`ParameterError`
    for infeasible settings. ``paper_row`` is the generator's row in the
    paper's Table I (1-6), None for a generator the paper does not have.
    ``time_limits`` gives the benchmark's seconds per run in every profile of
    :data:`BENCHMARK_PROFILES`. ``scene_scale`` is the physical scale of the
    generator's puzzles: the metres a puzzle metre becomes where a robot
    handles it (docs/manipulation/README.md#physical-scale).
    """

    name: str
    title: str
    build: Build
    params: type
    doc: str = ""
    paper_row: int | None = None
    time_limits: Mapping[str, float] = field(default_factory=dict)
    scene_scale: float = 1.0
    version: str = "1"
    """Bumped by hand when the generator's puzzles change for the same seed and parameters."""

    def __post_init__(self) -> None:
        if not dataclasses.is_dataclass(self.params):
            raise ValueError(f"generator {self.name!r}: params must be a dataclass, got {self.params!r}")
        for f in dataclasses.fields(self.params):
            if f.default is dataclasses.MISSING:
                raise ValueError(f"generator {self.name!r}: parameter {f.name!r} needs a default")
        undocumented = [f.name for f in dataclasses.fields(self.params) if not str(f.metadata.get("doc", "")).strip()]
        if undocumented:
            raise ValueError(
                f"generator {self.name!r}: parameters {', '.join(undocumented)} have no doc; declare them as "
                f"`name: type = parameter(default, \"what it means\")`"
            )
        if set(self.time_limits) != set(BENCHMARK_PROFILES) or not all(v > 0 for v in self.time_limits.values()):
            raise ValueError(
                f"generator {self.name!r}: time_limits must give positive seconds for exactly the profiles "
                f"{', '.join(BENCHMARK_PROFILES)}, got {dict(self.time_limits)}"
            )
        if self.paper_row is not None and not 1 <= self.paper_row <= 6:
            raise ValueError(f"generator {self.name!r}: paper_row must be a row of Table I (1-6), got {self.paper_row}")
        if not (math.isfinite(self.scene_scale) and self.scene_scale > 0):
            raise ValueError(f"generator {self.name!r}: scene_scale must be a positive number, "
                             f"got {self.scene_scale!r}")
        if not isinstance(self.version, str) or not self.version or any(c.isspace() for c in self.version):
            raise ValueError(f"generator {self.name!r}: version must be a non-empty word, got {self.version!r}")

    @property
    def paper(self) -> bool:
        """Whether this is one of the paper's six generators."""
        return self.paper_row is not None

    @property
    def summary(self) -> str:
        """The first line of the generator's docstring, without a leading ``Title:``."""
        first = self.doc.splitlines()[0] if self.doc else self.title
        text = first.removeprefix(f"{self.title}: ")
        return text[:1].upper() + text[1:]

    def default_params(self) -> Any:
        return self.params()

    def parameter_docs(self) -> dict[str, str]:
        """What each parameter means, by name, in declaration order."""
        return {f.name: f.metadata["doc"] for f in dataclasses.fields(self.params)}

    def difficulty_parameters(self) -> tuple[str, ...]:
        """The parameters that control how hard the puzzles are."""
        return tuple(f.name for f in dataclasses.fields(self.params) if f.metadata.get("difficulty"))

    def time_limit(self, profile: str) -> float:
        """Benchmark seconds per run of this generator's puzzles in ``profile``."""
        try:
            return float(self.time_limits[profile])
        except KeyError:
            raise ValueError(f"unknown benchmark profile {profile!r}; valid: {', '.join(BENCHMARK_PROFILES)}") from None

    def describe(self) -> str:
        """A few lines for people: title, summary, benchmark limits, and every parameter with
        its default and meaning (``*`` marks the difficulty knobs)."""
        where = f"paper Table I, row {self.paper_row}" if self.paper else "not in the paper"
        limits = ", ".join(f"{self.time_limit(p):g} s ({p})" for p in BENCHMARK_PROFILES)
        lines = [f"{self.name}: {self.title} ({where})", f"    {self.summary}",
                 f"    benchmark time limit per run: {limits}",
                 "    parameters (* = difficulty knob):"]
        defaults = self.default_params()
        knobs = set(self.difficulty_parameters())
        entries = [(f"{'*' if name in knobs else ' '} {name}={getattr(defaults, name)!r}", doc)
                   for name, doc in self.parameter_docs().items()]
        width = max((len(entry) for entry, _ in entries), default=0)
        for entry, doc in entries:
            lines += textwrap.wrap(doc, 100, initial_indent=f"      {entry:{width}s}  ",
                                   subsequent_indent=" " * (width + 8))
        return "\n".join(lines)

    def parse_params(self, overrides: Mapping[str, str | int | float | bool]) -> Any:
        """Parameters from ``key=value`` overrides, each converted to its field's type."""
        fields = {f.name: f for f in dataclasses.fields(self.params)}
        hints = typing.get_type_hints(self.params)
        values: dict[str, Any] = {}
        for key, raw in overrides.items():
            if key not in fields:
                valid = ", ".join(sorted(fields)) or "none"
                raise ParameterError(f"generator {self.name!r} has no parameter {key!r} (valid: {valid})")
            values[key] = _convert(self.name, key, raw, hints[key])
        return self.params(**values)

    def check(self, seed: int, params: Any) -> None:
        """Raise :class:`ParameterError` unless ``params`` (an instance of :attr:`params`) can be
        generated with ``seed``: every field of its declared type and finite (the rule
        :meth:`parse_params` applies to text), then the generator's own ``validate(seed)``."""
        if not isinstance(seed, int) or isinstance(seed, bool) or seed < 1:
            raise ParameterError(f"seed must be a positive integer, got {seed!r}")
        if not isinstance(params, self.params):
            raise ParameterError(f"generator {self.name!r}: parameters must be a {self.params.__name__}, "
                                 f"got {type(params).__name__}")
        hints = typing.get_type_hints(self.params)
        for f in dataclasses.fields(self.params):
            _check_value(self.name, f.name, getattr(params, f.name), hints[f.name])
        validate = getattr(params, "validate", None)
        if validate is not None:
            try:
                validate(seed)
            except ParameterError as exc:
                # With --generator all the reader must see which generator refused.
                if str(exc).startswith("generator "):
                    raise
                raise ParameterError(f"generator {self.name!r}: {exc}") from None


def _convert(generator: str, key: str, raw: Any, kind: Any) -> Any:
    try:
        if kind is bool:
            if isinstance(raw, bool):
                return raw
            text = str(raw).lower()
            if text not in ("true", "false", "1", "0", "yes", "no"):
                raise ValueError
            return text in ("true", "1", "yes")
        if kind is int:
            if isinstance(raw, float) and not raw.is_integer():
                raise ValueError
            value = int(str(raw)) if not isinstance(raw, int | float) else int(raw)
        elif kind is float:
            value = float(raw)
        else:
            return kind(raw)
    except (TypeError, ValueError, OverflowError):
        name = getattr(kind, "__name__", str(kind))
        raise ParameterError(f"generator {generator!r}: parameter {key!r} must be {name}, got {_show(raw)}") from None
    _check_value(generator, key, value, kind, raw)
    return value


_SHOW = reprlib.Repr()
_SHOW.maxstring = _SHOW.maxlong = _SHOW.maxother = 40


def _show(value: Any) -> str:
    """``repr(value)``, shortened: a message stays one readable line whatever was passed."""
    return _SHOW.repr(value)


def _check_value(generator: str, key: str, value: Any, kind: Any, shown: Any = None) -> None:
    """Refuse a value of the wrong type, a float that is not finite and an integer beyond
    :data:`MAX_INTEGER`, for every parameter of every generator: each ``validate`` can then
    compare numbers without NaN slipping through (``nan <= 0`` is False)."""
    shown = _show(value if shown is None else shown)
    where = f"generator {generator!r}: parameter {key!r}"
    if kind is bool:
        if not isinstance(value, bool):
            raise ParameterError(f"{where} must be bool, got {shown}")
    elif kind is int:
        if isinstance(value, bool) or not isinstance(value, Integral):
            raise ParameterError(f"{where} must be int, got {shown}")
        if not -MAX_INTEGER <= value <= MAX_INTEGER:
            raise ParameterError(f"{where} must be an integer within +-{MAX_INTEGER}, got {shown}")
    elif kind is float:
        if isinstance(value, bool) or not isinstance(value, Real):
            raise ParameterError(f"{where} must be float, got {shown}")
        if not math.isfinite(value):
            raise ParameterError(f"{where} must be a finite number, got {shown}")


class Registry:
    """Generators by name. Listed in a fixed order: the paper's six in Table I order,
    then any others by name."""

    def __init__(self, specs: Mapping[str, GeneratorSpec] | None = None):
        self._specs: dict[str, GeneratorSpec] = dict(specs or {})

    def add(self, spec: GeneratorSpec) -> GeneratorSpec:
        if spec.name in self._specs:
            raise ValueError(f"generator {spec.name!r} registered twice")
        taken = {s.paper_row: s.name for s in self._specs.values() if s.paper}
        if spec.paper and spec.paper_row in taken:
            raise ValueError(f"generator {spec.name!r}: paper row {spec.paper_row} is {taken[spec.paper_row]!r}'s")
        self._specs[spec.name] = spec
        return spec

    def copy(self) -> Registry:
        return Registry(self._specs)

    def all(self) -> dict[str, GeneratorSpec]:
        ordered = sorted(self._specs.values(),
                         key=lambda s: (s.paper_row is None, s.paper_row or 0, s.name))
        return {spec.name: spec for spec in ordered}

    def get(self, name: str) -> GeneratorSpec:
        if name not in self._specs:
            raise ParameterError(f"unknown generator {name!r} (known: {', '.join(self.all())})")
        return self._specs[name]

    def paper_generators(self) -> tuple[str, ...]:
        return tuple(name for name, spec in self.all().items() if spec.paper)

    def time_limits(self, profile: str) -> dict[str, float]:
        return {name: spec.time_limit(profile) for name, spec in self.all().items()}

    def describe(self) -> str:
        return "\n\n".join(spec.describe() for spec in self.all().values())


_BUILTIN = Registry()
_current = _BUILTIN


def register(name: str, title: str, params: type, *, time_limits: Mapping[str, float],
             paper_row: int | None = None, scene_scale: float = 1.0, version: str = "1") -> Callable[[Build], Build]:
    """Decorator: register ``build(seed, params) -> MakerInput`` under ``name``.

    ``time_limits``: benchmark seconds per run for every profile in
    :data:`BENCHMARK_PROFILES`; ``paper_row``: the row in the paper's Table I,
    for the paper's six only; ``scene_scale``: the physical scale (metres per
    puzzle metre) where a robot handles the puzzles; ``version``: bump it by hand when the
    puzzles for a seed change. A package outside PhyRoGen declares the decorated function in its
    ``phyrogen.generators`` entry points (docs/adding-a-generator.md). The docstring of ``build`` is the generator's
    documentation (sections Mechanism, Randomization, Goal, Difficulty
    parameters, Departures).
    """

    def wrap(build: Build) -> Build:
        _current.add(GeneratorSpec(name, title, build, params, (build.__doc__ or "").strip(), paper_row,
                                   dict(time_limits), scene_scale, version))
        return build

    return wrap


def _registers_generator(plugin: Plugin) -> bool:
    spec = _current.all().get(plugin.name)
    return spec is not None and spec.build is plugin.loaded


load_generator_plugins = GroupLoader(GENERATOR_GROUP, "generator", _registers_generator,
                                     "decorate the function it names with @register({name}, ...)")
"""Load every generator declared in the ``phyrogen.generators`` entry-point group, once: the built-in
six (declared in PhyRoGen's own ``pyproject.toml``) and any other package's (:mod:`phyrogen_core.plugins`).
PluginError names an entry that does not load or registers no generator of its name."""


def _load_builtin() -> None:
    load_generator_plugins()


def registry() -> Registry:
    """The registry in use: the built-in generators (and any registered since)."""
    _load_builtin()
    return _current


@contextlib.contextmanager
def registry_copy() -> Iterator[Registry]:
    """Within the block, the registry in use is a copy of the current one: generators
    registered inside (e.g. by loading a module that calls :func:`register`) are gone
    afterwards. For tests and for trying a generator out without adding it for good."""
    global _current
    previous = registry()
    _current = previous.copy()
    try:
        yield _current
    finally:
        _current = previous


def all_generators() -> dict[str, GeneratorSpec]:
    """Every registered generator by name: the paper's six in Table I order, then others by name."""
    return registry().all()


def get_generator(name: str) -> GeneratorSpec:
    return registry().get(name)


def paper_generators() -> tuple[str, ...]:
    """The paper's six generators in Table I order: simple_slider, continuous_space,
    grid_world, lockbox_random, move_n_times, rooms."""
    return registry().paper_generators()


def benchmark_time_limits(profile: str) -> dict[str, float]:
    """Benchmark seconds per run in ``profile`` for every registered generator."""
    return registry().time_limits(profile)


def describe_generators() -> str:
    """Every registered generator described for people (``phyrogen list``): title, where it
    comes from, benchmark limits, and each parameter's default and meaning."""
    return registry().describe()

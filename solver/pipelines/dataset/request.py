"""A dataset request: which puzzles a dataset holds, in which order, and in which shard.

A dataset is a flat, indexed list of entries. Entry ``i`` (0-based) is one
(generator, seed, parameters) triple: generators in the order given, and
for each generator every requested seed in increasing order. Shard ``k``
holds entries ``k * shard_size`` up to ``(k + 1) * shard_size - 1``.

**Parameter sweeps.** ``--set key=value`` fixes a parameter for every entry;
``--set key=LOW:HIGH[:STEP]`` (integers, or floats with a STEP) or
``--set key=A,B,C`` sweeps it. The parameters of an entry depend only on
its seed, never on its position in the request, so that seed 9150 is the
same puzzle in a request of 100 seeds and in one of 10,000:

- ``cross`` (the default): the combinations are the Cartesian product of
  the swept values, the first ``--set`` varying slowest; seed ``s`` gets
  combination ``s mod K`` (``K`` combinations). Any ``K`` consecutive seeds
  hold every combination once.
- ``zip``: every swept parameter cycles on its own; seed ``s`` gets value
  ``s mod n`` of a parameter with ``n`` values.

Every seed appears exactly once per generator.
"""

from __future__ import annotations

import bisect
import dataclasses
import json
import math
import typing
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from phyrogen_core.registry import MAX_SEED, get_generator, merge_seed_spans

if TYPE_CHECKING:  # at run time only where a request measures difficulty: it imports the planners
    from solver.benchmark.difficulty import DifficultySettings

FORMAT_VERSION = 1
"""The version of ``dataset.json`` and of the manifest's columns; bumped when one changes meaning."""
DEFAULT_SHARD_SIZE = 1000
"""Puzzle folders per shard. A thousand keeps each shard's directory listing fast on any file system
(and in a file browser), makes a shard the unit of resuming (one manifest part per shard) and of
transfer (a shard of Grid World puzzles of 3 to 8 boxes is about 27 MB, one ``tar`` or ``rsync`` away),
and keeps the number of shards of a million-puzzle dataset at a thousand."""
MAX_SHARD_SIZE = 100_000
MAX_ENTRIES = 10_000_000
"""The most puzzles one request may ask for: ten thousand shards of a thousand. A larger request is
almost certainly a typo (and a run of months); make several datasets instead."""
MAX_SHARDS = 100_000
"""The most shards: shard folders are numbered with five digits (``shard-00000`` .. ``shard-99999``)."""
MAX_SWEEP_VALUES = 10_000
"""The most values one swept parameter may take."""
MAX_PERIOD = 10_000
"""The most distinct parameter combinations of a request (the period of the seed-to-parameters rule)."""
CHECK_EVERY_ENTRY_UP_TO = 10_000
"""Requests of at most this many seeds are checked seed by seed before any work; larger ones at both
ends of each seed range for every combination (sizes that depend on the seed only grow with it)."""
SWEEP_MODES = ("cross", "zip")


class DatasetError(ValueError):
    """A dataset request or a dataset folder that cannot be used; the message names the value."""


@dataclass(frozen=True)
class Sweep:
    """One swept parameter and its values (typed: int, float or bool), in the order given."""

    key: str
    values: tuple[Any, ...]


@dataclass(frozen=True)
class Entry:
    """One puzzle of a dataset."""

    index: int
    generator: str
    seed: int
    params: Any  # the generator's parameter dataclass

    @property
    def name(self) -> str:
        return f"{self.generator}_{self.seed}"

    @property
    def parameters_json(self) -> str:
        return parameters_json(self.params)


def parameters_json(params: Any) -> str:
    """A parameter dataclass as compact JSON text with sorted keys (the manifest's ``parameters``)."""
    return json.dumps(dataclasses.asdict(params), sort_keys=True, separators=(",", ":"), allow_nan=False)


@dataclass(frozen=True)
class DatasetRequest:
    """What a dataset holds; see the module docstring for the order and the sweep rule.

    Make one with :func:`make_request`, which checks everything; the
    constructor trusts its arguments.
    """

    generators: tuple[str, ...]
    seeds: tuple[tuple[int, int], ...]  # inclusive (low, high) spans, sorted and disjoint
    fixed: tuple[tuple[str, Any], ...] = ()  # typed values, sorted by key
    sweeps: tuple[Sweep, ...] = ()
    sweep_mode: str = "cross"
    shard_size: int = DEFAULT_SHARD_SIZE
    mjcf: bool = False  # each puzzle's MJCF written beside its URDF (``mjcf/<name>.xml``)
    difficulty: DifficultySettings | None = None  # each puzzle's difficulty measured into its puzzle.json

    # -- size and order -------------------------------------------------------------
    @property
    def seeds_per_generator(self) -> int:
        return sum(high - low + 1 for low, high in self.seeds)

    @property
    def size(self) -> int:
        """How many entries (puzzles, failed ones included) the dataset has."""
        return self.seeds_per_generator * len(self.generators)

    @property
    def shard_count(self) -> int:
        return -(-self.size // self.shard_size)

    def shard_entries(self, shard: int) -> range:
        """The indices of shard ``shard``'s entries."""
        return range(shard * self.shard_size, min(self.size, (shard + 1) * self.shard_size))

    def shard_of(self, index: int) -> int:
        return index // self.shard_size

    def seed_at(self, position: int) -> int:
        """The ``position``-th requested seed (0-based), in increasing order."""
        starts = self._span_starts()
        span = bisect.bisect_right(starts, position) - 1
        return self.seeds[span][0] + position - starts[span]

    def _span_starts(self) -> list[int]:
        starts, total = [], 0
        for low, high in self.seeds:
            starts.append(total)
            total += high - low + 1
        return starts

    def entry(self, index: int) -> Entry:
        if not 0 <= index < self.size:
            raise IndexError(f"entry {index} is outside the dataset's {self.size} entries")
        generator = self.generators[index // self.seeds_per_generator]
        seed = self.seed_at(index % self.seeds_per_generator)
        return Entry(index, generator, seed, self.parameters(generator, seed))

    def entries(self, indices: range | None = None) -> Iterator[Entry]:
        for index in range(self.size) if indices is None else indices:
            yield self.entry(index)

    # -- parameters ------------------------------------------------------------------
    @property
    def period(self) -> int:
        """After how many seeds the parameter combinations repeat (1 without sweeps)."""
        lengths = [len(s.values) for s in self.sweeps]
        if not lengths:
            return 1
        return math.prod(lengths) if self.sweep_mode == "cross" else math.lcm(*lengths)

    def combination(self, seed: int) -> dict[str, Any]:
        """The swept parameters' values for ``seed`` (see the module docstring)."""
        if self.sweep_mode == "zip":
            return {s.key: s.values[seed % len(s.values)] for s in self.sweeps}
        rest = seed % self.period
        out: dict[str, Any] = {}
        for sweep in reversed(self.sweeps):  # the last --set varies fastest
            rest, position = divmod(rest, len(sweep.values))
            out[sweep.key] = sweep.values[position]
        return {s.key: out[s.key] for s in self.sweeps}

    def parameters(self, generator: str, seed: int) -> Any:
        """The parameter dataclass of ``generator``'s puzzle ``seed`` in this dataset."""
        return get_generator(generator).params(**dict(self.fixed), **self.combination(seed))

    # -- dataset.json ----------------------------------------------------------------
    def to_json(self) -> dict[str, Any]:
        """The request as stored in ``dataset.json`` (and compared when a dataset is resumed)."""
        return {
            "format_version": FORMAT_VERSION,
            "generators": list(self.generators),
            "seeds": [[low, high] for low, high in self.seeds],
            "set": dict(self.fixed),
            "sweeps": [{"key": s.key, "values": list(s.values)} for s in self.sweeps],
            "sweep_mode": self.sweep_mode,
            "shard_size": self.shard_size,
            "mjcf": self.mjcf,
            "entries": self.size,
            "shards": self.shard_count,
            # Only when asked: a request without it keeps the dataset.json it always had.
            **({} if self.difficulty is None else {"difficulty": _difficulty_json(self.difficulty)}),
        }

    def check_feasible(self) -> None:
        """Raise :class:`~phyrogen_core.registry.ParameterError` unless every entry can be generated
        (each generator's ``check(seed, params)``): an infeasible size is refused before any work."""
        first = self.seeds[0][0]
        for generator in self.generators:
            spec = get_generator(generator)
            # Every value a sweep names, whether or not these seeds reach it: ``n_objects=1:1000``
            # asks for 1000 objects, past the stated bound, even when --count 10 never gets there.
            # Seeds first .. first + period - 1 meet every combination, in both sweep modes.
            for offset in range(self.period if self.sweeps else 0):
                spec.check(first, self.parameters(generator, first + offset))
            for seed in self._seeds_to_check():
                spec.check(seed, self.parameters(generator, seed))

    def _seeds_to_check(self) -> Iterator[int]:
        if self.seeds_per_generator <= CHECK_EVERY_ENTRY_UP_TO:
            for low, high in self.seeds:
                yield from range(low, high + 1)
            return
        period = self.period
        for low, high in self.seeds:
            for first in range(low, low + min(period, high - low + 1)):
                yield first  # the first seed of one combination in this range, then its last
                last = high - (high - first) % period
                if last != first:
                    yield last


def make_request(generators: Sequence[str], seeds: Sequence[tuple[int, int]] | Sequence[range],
                 settings: Sequence[str] = (), sweep_mode: str = "cross",
                 shard_size: int = DEFAULT_SHARD_SIZE, mjcf: bool = False,
                 difficulty: DifficultySettings | None = None) -> DatasetRequest:
    """A checked :class:`DatasetRequest`.

    ``seeds``: inclusive (low, high) spans or ranges; ``settings``: ``key=value`` texts as given
    to ``--set`` (see the module docstring for sweeps). Raises :class:`DatasetError` or
    :class:`~phyrogen_core.registry.ParameterError` (both ValueErrors, one line naming the bad
    value) for an unknown generator, a bad setting, too many entries, or a size some entry's
    generator cannot make.
    """
    names = tuple(generators)
    if not names:
        raise DatasetError("no generator given")
    if len(set(names)) != len(names):
        raise DatasetError(f"generator listed twice: {', '.join(names)}")
    for name in names:
        get_generator(name)  # ParameterError: unknown generator (known: ...)
    spans = _spans(seeds)
    if sweep_mode not in SWEEP_MODES:
        raise DatasetError(f"unknown sweep mode {sweep_mode!r} (valid: {', '.join(SWEEP_MODES)})")
    if isinstance(shard_size, bool) or not isinstance(shard_size, int) or not 1 <= shard_size <= MAX_SHARD_SIZE:
        raise DatasetError(f"shard size must be a whole number in 1..{MAX_SHARD_SIZE}, got {shard_size!r}")
    if settings and len(names) > 1:
        raise DatasetError("--set applies to one generator; name it with --generator")
    fixed, sweeps = _parse_settings(names[0], settings) if settings else ((), ())
    request = DatasetRequest(names, spans, fixed, sweeps, sweep_mode if len(sweeps) > 1 else "cross", shard_size,
                             bool(mjcf), difficulty)
    if request.size > MAX_ENTRIES:
        raise DatasetError(f"{request.size} puzzles requested; a dataset holds at most {MAX_ENTRIES:,} "
                           "(make several datasets)")
    if request.shard_count > MAX_SHARDS:
        raise DatasetError(f"{request.shard_count} shards of {shard_size}; at most {MAX_SHARDS} "
                           "(choose a larger --shard-size)")
    if request.period > MAX_PERIOD:
        raise DatasetError(f"the sweeps make {request.period} parameter combinations; at most {MAX_PERIOD}")
    request.check_feasible()
    return request


def _spans(seeds: Sequence[tuple[int, int]] | Sequence[range]) -> tuple[tuple[int, int], ...]:
    spans = []
    for item in seeds:
        if isinstance(item, range):
            if item.step != 1 or not item:
                raise DatasetError(f"seed range {item!r} must be non-empty with step 1")
            low, high = item[0], item[-1]
        else:
            low, high = item
        for value in (low, high):
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= MAX_SEED:
                raise DatasetError(f"seeds must be whole numbers in 1..{MAX_SEED}, got {value!r}")
        if high < low:
            raise DatasetError(f"seed range {low}-{high} is empty")
        spans.append((low, high))
    if not spans:
        raise DatasetError("no seeds given")
    return merge_seed_spans(spans)


def _parse_settings(generator: str, settings: Sequence[str]) -> tuple[tuple[tuple[str, Any], ...], tuple[Sweep, ...]]:
    spec = get_generator(generator)
    fixed: dict[str, Any] = {}
    sweeps: list[Sweep] = []
    seen: set[str] = set()
    for item in settings:
        key, sep, text = item.partition("=")
        key, text = key.strip(), text.strip()
        if not sep or not key or not text:
            raise DatasetError(f"bad --set {item!r}: expected KEY=VALUE, KEY=LOW:HIGH[:STEP] or KEY=A,B,C")
        if key in seen:
            raise DatasetError(f"--set {key} given twice")
        seen.add(key)
        texts = _sweep_texts(spec, key, text) if (":" in text or "," in text) else None
        if texts is None:
            fixed[key] = getattr(spec.parse_params({key: text}), key)
            continue
        values = tuple(getattr(spec.parse_params({key: t}), key) for t in texts)
        if len(set(values)) != len(values):
            raise DatasetError(f"bad --set {key}={text}: a value is listed twice")
        sweeps.append(Sweep(key, values))
    single = [s for s in sweeps if len(s.values) == 1]
    for sweep in single:  # "key=3," or "key=3:3": one value is a fixed setting
        fixed[sweep.key] = sweep.values[0]
    return tuple(sorted(fixed.items())), tuple(s for s in sweeps if len(s.values) > 1)


def _sweep_texts(spec, key: str, text: str) -> list[str]:
    hints = typing.get_type_hints(spec.params)
    if key not in hints:
        spec.parse_params({key: ""})  # ParameterError: no parameter KEY (valid: ...)
    kind = hints[key]
    if "," in text:
        if ":" in text:
            raise DatasetError(f"bad --set {key}={text}: give a range LOW:HIGH[:STEP] or a list A,B,C, not both")
        texts = [t.strip() for t in text.split(",")]
        if not all(texts):
            raise DatasetError(f"bad --set {key}={text}: an empty value in the list")
        if len(texts) > MAX_SWEEP_VALUES:
            raise DatasetError(f"bad --set {key}={text[:40]}...: {len(texts)} values; at most {MAX_SWEEP_VALUES}")
        return texts
    parts = [t.strip() for t in text.split(":")]
    if len(parts) not in (2, 3) or not all(parts):
        raise DatasetError(f"bad --set {key}={text}: a range is LOW:HIGH or LOW:HIGH:STEP")
    where = f"bad --set {key}={text}"
    if kind is int:
        try:
            low, high, step = (int(p) for p in (*parts, "1")[:3])
        except ValueError:
            raise DatasetError(f"{where}: {key} is an integer parameter; LOW, HIGH and STEP must be whole "
                               "numbers") from None
        if step <= 0 or high < low:
            raise DatasetError(f"{where}: needs LOW <= HIGH and STEP > 0")
        count = (high - low) // step + 1
        if count > MAX_SWEEP_VALUES:
            raise DatasetError(f"{where}: {count} values; at most {MAX_SWEEP_VALUES}")
        return [str(low + k * step) for k in range(count)]
    if kind is float:
        if len(parts) != 3:
            raise DatasetError(f"{where}: {key} is a float parameter; give LOW:HIGH:STEP or a list A,B,C")
        try:
            low, high, step = (float(p) for p in parts)
        except ValueError:
            raise DatasetError(f"{where}: LOW, HIGH and STEP must be numbers") from None
        if not all(math.isfinite(v) for v in (low, high, step)):
            raise DatasetError(f"{where}: LOW, HIGH and STEP must be finite numbers")
        if step <= 0 or high < low:
            raise DatasetError(f"{where}: needs LOW <= HIGH and STEP > 0")
        count = math.floor((high - low) / step + 1e-9) + 1
        if count > MAX_SWEEP_VALUES:
            raise DatasetError(f"{where}: {count} values; at most {MAX_SWEEP_VALUES}")
        return [repr(round(low + k * step, 12)) for k in range(count)]
    raise DatasetError(f"{where}: ranges are for integer and float parameters; list the values: A,B")


def request_difference(stored: Mapping[str, Any], request: DatasetRequest) -> str | None:
    """How the request stored in a ``dataset.json`` differs from ``request`` (None: the same)."""
    wanted = request.to_json()
    for key in (*wanted, "difficulty"):  # (difficulty: also when only the stored request has it)
        if stored.get(key) != wanted.get(key):
            return f"{key} {_short(stored.get(key))} there, {_short(wanted.get(key))} now"
    return None


def _difficulty_json(settings: DifficultySettings) -> dict[str, Any]:
    return {"planner": settings.planner, "runs": settings.runs, "budget_checks": settings.budget_checks}


def _short(value: Any) -> str:
    text = json.dumps(value, sort_keys=True)
    return text if len(text) <= 80 else text[:77] + "..."


def _difficulty_settings(data: Mapping[str, Any] | None) -> DifficultySettings | None:
    if data is None:
        return None
    from solver.benchmark.difficulty import DifficultySettings

    return DifficultySettings(int(data["runs"]), int(data["budget_checks"]), str(data["planner"]))


def load_request(data: Mapping[str, Any]) -> DatasetRequest:
    """A request from the data of a ``dataset.json`` (for reading a dataset; not re-checked)."""
    try:
        if data.get("format_version") != FORMAT_VERSION:
            raise DatasetError(f"dataset.json has format_version {data.get('format_version')!r}; "
                               f"this version reads {FORMAT_VERSION}")
        return DatasetRequest(tuple(data["generators"]), tuple((int(a), int(b)) for a, b in data["seeds"]),
                              tuple(sorted(data["set"].items())),
                              tuple(Sweep(s["key"], tuple(s["values"])) for s in data["sweeps"]),
                              data["sweep_mode"], int(data["shard_size"]), bool(data.get("mjcf", False)),
                              _difficulty_settings(data.get("difficulty")))
    except (KeyError, TypeError, AttributeError, ValueError) as exc:
        if isinstance(exc, DatasetError):
            raise
        raise DatasetError(f"dataset.json is malformed: {type(exc).__name__}: {exc}") from None

"""Plug-ins found through package entry points: the one way planners and generators are added.

A package declares its planners in the entry-point group ``phyrogen.planners`` and its generators in
``phyrogen.generators`` (``[project.entry-points."phyrogen.planners"]`` in its ``pyproject.toml``), each
entry ``name = "module:object"``; PhyRoGen's own built-ins are declared the same way in its own
``pyproject.toml``. Loading an entry imports its module, whose decorator registers the object; the
registry then checks that the object is registered under the entry's name. PhyRoGen's own entries
load first, then every other package's, each by package and entry name, so that the order of logs
and tables does not follow the order of ``sys.path`` (the built-in planners register in the order of
their one module, :mod:`solver.planning.builtin_planners`, whichever of its entries loads first).

An entry that cannot be loaded (a missing module, a misspelled object, an error while importing)
is :class:`PluginError`: one line naming the entry and its package.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata

PLANNER_GROUP = "phyrogen.planners"
GENERATOR_GROUP = "phyrogen.generators"
OWN_DISTRIBUTION = "phyrogen"


class PluginError(ValueError):
    """A plug-in's entry point cannot be loaded, or does not register what it names."""


@dataclass(frozen=True)
class Plugin:
    """One loaded entry point: its name, the object it names, and where it was declared."""

    name: str
    value: str  # "module:object", as declared
    distribution: str
    loaded: object

    def where(self) -> str:
        return f"entry point {self.name!r} ({self.value}) of package {self.distribution!r}"


def _distribution(entry: metadata.EntryPoint) -> str:
    dist = getattr(entry, "dist", None)
    if dist is None:
        return OWN_DISTRIBUTION  # read from the checkout
    # A distribution's name is read from its METADATA file, parsed again on every access (about 0.4 ms):
    # once per distribution object here, which every entry of that package shares.
    name = _NAMES.get(id(dist))
    if name is None or name[0] is not dist:
        name = _NAMES[id(dist)] = (dist, dist.name)
    return name[1]


_NAMES: dict[int, tuple[object, str]] = {}
"""Distribution names by object (the object kept, so that an id is never taken for a new object's)."""


def _declared_in_checkout(group: str) -> list[metadata.EntryPoint]:
    """PhyRoGen's own entries read from the ``pyproject.toml`` of the checkout this module lies in: for
    a checkout put on ``sys.path`` without being installed (no package metadata), e.g. inside a
    Blender that finds no environment; the same declarations, so the same built-ins."""
    import tomllib
    from pathlib import Path

    pyproject = Path(__file__).resolve().parent.parent / "pyproject.toml"
    try:
        project = tomllib.loads(pyproject.read_text(encoding="utf-8"))["project"]
    except (OSError, ValueError, KeyError):
        return []
    if project.get("name") != OWN_DISTRIBUTION:
        return []
    table = project.get("entry-points", {}).get(group, {})
    return [metadata.EntryPoint(name, value, group) for name, value in table.items()]


def entry_points(group: str) -> list[metadata.EntryPoint]:
    """The group's entry points: PhyRoGen's own first, then others, by package and name.
    A name declared twice is kept once, the first; PhyRoGen's own are never shadowed. Without
    PhyRoGen's package metadata, its own are read from its checkout's ``pyproject.toml``."""
    found = list(metadata.entry_points(group=group))
    own = sorted((e for e in found if _distribution(e) == OWN_DISTRIBUTION), key=lambda e: e.name)
    if not own:
        own = sorted(_declared_in_checkout(group), key=lambda e: e.name)
    others = sorted((e for e in found if _distribution(e) != OWN_DISTRIBUTION),
                    key=lambda e: (_distribution(e), e.name))
    seen: set[str] = set()
    unique = []
    for entry in own + others:
        if entry.name not in seen:
            seen.add(entry.name)
            unique.append(entry)
    return unique


def load_group(group: str) -> list[Plugin]:
    """Import every entry point of ``group`` (see :func:`entry_points`); PluginError names the first
    that fails. Raises PluginError, too, when PhyRoGen itself declares none (neither its package
    metadata nor its checkout's ``pyproject.toml``): its built-ins would silently be absent."""
    entries = entry_points(group)
    if not any(_distribution(e) == OWN_DISTRIBUTION for e in entries):
        raise PluginError(f"no {group!r} entry points of package {OWN_DISTRIBUTION!r} are found: its built-ins "
                          f"are declared there; install it (pip install -e . --no-deps)")
    plugins = []
    for entry in entries:
        plugin = Plugin(entry.name, entry.value, _distribution(entry), None)
        try:
            loaded = entry.load()
        except Exception as exc:  # any failure of someone else's import is reported as theirs, in one line
            message = str(exc).splitlines()[0] if str(exc) else ""
            raise PluginError(f"{group}: {plugin.where()} cannot be loaded: {type(exc).__name__}: {message}") from None
        plugins.append(Plugin(entry.name, entry.value, plugin.distribution, loaded))
    return plugins


class GroupLoader:
    """Loads a group's entry points the first time it is called (again after a failure, so that every
    command reports it). ``registers(plugin)``: whether the loaded entry registered what it names;
    else PluginError says ``registers no {kind} named ...`` and ``hint`` (with ``{name}``)."""

    def __init__(self, group: str, kind: str, registers: Callable[[Plugin], bool], hint: str) -> None:
        self.group, self.kind, self.registers, self.hint = group, kind, registers, hint
        self.loaded = False

    def __call__(self) -> None:
        if self.loaded:
            return
        self.loaded = True  # before importing: the modules' decorators register meanwhile, and read the registry
        try:
            for plugin in load_group(self.group):
                if not self.registers(plugin):
                    raise PluginError(f"{self.group}: {plugin.where()} registers no {self.kind} named "
                                      f"{plugin.name!r}; {self.hint.format(name=repr(plugin.name))}")
        except PluginError:
            self.loaded = False
            raise

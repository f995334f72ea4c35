"""The registry of generators by name: feeds the CLI, the tests and the Blender panel."""

from __future__ import annotations

import dataclasses
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from .maker import MakerInput


class ParameterError(ValueError):
    """A generator parameter is unknown or has a bad value."""


@dataclass(frozen=True)
class GeneratorSpec:
    """A registered generator.

    ``build(seed, params)`` returns the generator's input tuple to the Maker.
    ``params`` is a frozen dataclass type whose fields (with defaults) are the
    generator's parameters; its ``validate(seed)`` method, when present,
    raises :class:`ParameterError` for infeasible settings.
    """

    name: str
    title: str
    build: Callable[[int, Any], MakerInput]
    params: type
    doc: str = ""

    def default_params(self) -> Any:
        return self.params()

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
        if not isinstance(seed, int) or isinstance(seed, bool) or seed < 1:
            raise ParameterError(f"seed must be a positive integer, got {seed!r}")
        validate = getattr(params, "validate", None)
        if validate is not None:
            validate(seed)


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
            return int(str(raw)) if not isinstance(raw, int | float) else int(raw)
        if kind is float:
            return float(raw)
        return kind(raw)
    except (TypeError, ValueError):
        name = getattr(kind, "__name__", str(kind))
        raise ParameterError(f"generator {generator!r}: parameter {key!r} must be {name}, got {raw!r}") from None


_REGISTRY: dict[str, GeneratorSpec] = {}


def register(name: str, title: str, params: type) -> Callable[[Callable[[int, Any], MakerInput]], Callable]:
    """Decorator: register ``build(seed, params) -> MakerInput`` under ``name``."""

    def wrap(build: Callable[[int, Any], MakerInput]) -> Callable[[int, Any], MakerInput]:
        if name in _REGISTRY:
            raise ValueError(f"generator {name!r} registered twice")
        _REGISTRY[name] = GeneratorSpec(name, title, build, params, (build.__doc__ or "").strip())
        return build

    return wrap


def _load_builtin() -> None:
    from . import generators  # noqa: F401  (registers the six paper generators)


def all_generators() -> dict[str, GeneratorSpec]:
    _load_builtin()
    return dict(_REGISTRY)


def get_generator(name: str) -> GeneratorSpec:
    registry = all_generators()
    if name not in registry:
        raise ParameterError(f"unknown generator {name!r} (known: {', '.join(registry)})")
    return registry[name]

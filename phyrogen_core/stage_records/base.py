"""Records with one strict reader: frozen dataclasses whose field types are checked wherever a record is made.

A record checks its fields as it is made, from Python or from data (:meth:`Record.from_dict`), so a
request built by hand and one read from JSON are refused for the same reasons, each with one line
naming the record and the field. The types a field may have: ``str``, ``int``, :data:`Count` (a whole
number, 0 or more), ``float`` (finite; an ``int`` is taken as a float), ``bool`` (never a number),
a ``Literal`` of strings, ``X | None``, ``tuple[X, ...]``, another :class:`Record`, and
:data:`JsonObject` (an open JSON document of another format, its numbers finite). Data may hold
exactly the record's keys: an unknown key is refused as a missing one is.

A request or result of a stage is versioned: its dict also holds the stage's name and the record's
:attr:`~StageRecord.VERSION`, and a result the exit code the command line gives it. A stage's record is
declared as ``class CheckResult(StageResult, stage="check")`` with its fields: the base makes every such
class (and every shared base of fields) a frozen dataclass, a result's fields keyword-only.
"""

from __future__ import annotations

import copy
import functools
import json
import math
import types
import typing
from collections.abc import Mapping
from contextvars import ContextVar
from dataclasses import dataclass, fields
from typing import Any, ClassVar, Literal, NewType, TypeVar, dataclass_transform

Count = NewType("Count", int)
"""A whole number, 0 or more."""
JsonObject = NewType("JsonObject", dict)
"""An open JSON object: another format's document carried whole (its keys are that format's business);
its keys are strings and its numbers finite."""

_R = TypeVar("_R", bound="Record")
_LABEL: ContextVar[str | None] = ContextVar("record_label", default=None)
"""The label of the record :meth:`Record.from_dict` is making (its place in the data), for its errors."""


class RecordError(ValueError):
    """A record that its reader refuses; the message is one line naming the record and the field."""


class Record:
    """Base of a frozen dataclass record: fields checked as it is made, :meth:`to_dict`, :meth:`from_dict`."""

    def __post_init__(self) -> None:
        label = _LABEL.get() or type(self).__name__
        _LABEL.set(None)  # a nested record made in a check below labels itself
        hints = _hints(type(self))
        for field in fields(self):
            value = read_value(getattr(self, field.name), hints[field.name], label, field.name)
            object.__setattr__(self, field.name, value)  # normalised: a list read as a tuple, 3 as 3.0
        problem = self.problem()
        if problem:
            raise RecordError(f"{label}: {problem}")

    def problem(self) -> str | None:
        """What is wrong with the record beyond its fields' types (a rule between fields); None when nothing."""
        return None

    def to_dict(self) -> dict[str, Any]:
        return {field.name: _plain(getattr(self, field.name)) for field in fields(self)}

    @classmethod
    def from_dict(cls: type[_R], data: object, label: str | None = None) -> _R:
        """The record of ``data`` (a dict with exactly its keys); :class:`RecordError` when it is not one."""
        label = label or cls.__name__
        if not isinstance(data, dict):
            raise RecordError(f"{label}: expected an object, got {_kind(data)}")
        names = [field.name for field in fields(cls)]
        for name in names:
            if name not in data:
                raise RecordError(f"{label}: missing key {name!r}")
        unknown = sorted(str(key) for key in data if key not in names)
        if unknown:
            raise RecordError(f"{label}: unknown key {unknown[0]!r} (the record's keys: {', '.join(names)})")
        hints = _hints(cls)
        values = {name: read_value(data[name], hints[name], label, name) for name in names}
        token = _LABEL.set(label)
        try:
            return cls(**values)
        finally:
            _LABEL.reset(token)


class StageRecord(Record):
    """A stage's request or result: its data also holds the stage's name (under :attr:`ENVELOPE`) and
    :attr:`VERSION`; a reader refuses another stage's record and another version.

    A subclass is made a frozen dataclass as it is declared (a result's fields keyword-only, as
    :attr:`KEYWORD_ONLY` says), with the stage's name given as the ``stage`` keyword of its class
    statement; a shared base of fields has none."""

    STAGE: ClassVar[str]
    VERSION: ClassVar[int] = 1
    ENVELOPE: ClassVar[str]
    """The key that names the stage: ``request`` for a request, ``command`` for a result."""
    KEYWORD_ONLY: ClassVar[bool] = False

    def __init_subclass__(cls, stage: str | None = None, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if stage is not None:
            cls.STAGE = stage
        if "ENVELOPE" not in cls.__dict__:  # StageRequest and StageResult themselves hold no fields
            dataclass(frozen=True, kw_only=cls.KEYWORD_ONLY)(cls)

    def envelope(self) -> dict[str, Any]:
        return {self.ENVELOPE: self.STAGE, "version": self.VERSION}

    def to_dict(self) -> dict[str, Any]:
        return {**self.envelope(), **super().to_dict()}

    def to_json(self) -> str:
        """One line of JSON (keys sorted, no non-finite number)."""
        return json.dumps(self.to_dict(), sort_keys=True, allow_nan=False)

    @classmethod
    def label(cls) -> str:
        return f"{cls.STAGE} {cls.ENVELOPE}"

    @classmethod
    def from_dict(cls: type[_S], data: object, label: str | None = None) -> _S:
        label = label or cls.label()
        if not isinstance(data, dict):
            raise RecordError(f"{label}: expected one JSON object, got {_kind(data)}")
        data = dict(data)
        stage = data.pop(cls.ENVELOPE, None)
        if stage != cls.STAGE:
            raise RecordError(f"{label}: {cls.ENVELOPE!r} is {stage!r}, not {cls.STAGE!r}")
        if "version" not in data:
            raise RecordError(f"{label}: missing key 'version' (this reader reads version {cls.VERSION})")
        version = data.pop("version")
        if type(version) is not int or version != cls.VERSION:
            raise RecordError(f"{label}: 'version' is {_kind(version)}; this reader reads version {cls.VERSION}")
        return cls._from_body(data, label)

    @classmethod
    def _from_body(cls: type[_S], data: dict, label: str) -> _S:
        return Record.from_dict.__func__(cls, data, label)

    @classmethod
    def from_json(cls: type[_S], text: str) -> _S:
        """The record of one JSON object's text; :class:`RecordError` (one line) when it is not one: not
        text, not JSON, a non-finite number anywhere (``NaN``, ``Infinity``, ``1e400``), or not the record."""
        label = cls.label()
        if not isinstance(text, str):
            raise RecordError(f"{label}: expected JSON text, got {type(text).__name__}")
        try:
            data = json.loads(text, parse_constant=_refuse_constant, parse_float=_finite_float)
        except RecordError as exc:
            raise RecordError(f"{label}: {exc} (JSON has no such number)") from None
        except ValueError as exc:
            shown = text.strip()[-120:]
            raise RecordError(f"{label}: not JSON ({exc.msg} at character {exc.pos}; the text ends {shown!r})"
                              ) from None
        return cls.from_dict(data, label)


_S = TypeVar("_S", bound=StageRecord)


@dataclass_transform(frozen_default=True)
class StageRequest(StageRecord):
    """What a stage is asked to do; its fields may be given in order."""

    ENVELOPE = "request"


@dataclass_transform(frozen_default=True, kw_only_default=True)
class StageResult(StageRecord):
    """What a stage did; with the command line's ``--json`` it is the one JSON object on stdout, which
    also holds the command's exit code (:attr:`exit_code`, a function of the result)."""

    ENVELOPE = "command"
    KEYWORD_ONLY = True

    def done(self) -> bool:
        """Everything asked for was done (what that means is each stage's result's to say)."""
        return True

    @property
    def exit_code(self) -> int:
        """The command's exit status for this result: 0 when everything asked for was done, else 1."""
        return 0 if self.done() else 1

    def envelope(self) -> dict[str, Any]:
        return {**super().envelope(), "exit_code": self.exit_code}

    @classmethod
    def label(cls) -> str:
        return f"{cls.STAGE} --json result"

    @classmethod
    def _from_body(cls, data: dict, label: str):
        if "exit_code" not in data:
            raise RecordError(f"{label}: missing key 'exit_code'")
        code = read_value(data.pop("exit_code"), int, label, "exit_code")
        record = super()._from_body(data, label)
        if code != record.exit_code:
            raise RecordError(f"{label}: 'exit_code' is {code}, but the result is one of exit code {record.exit_code}")
        return record


# -- the fields ------------------------------------------------------------------------------------


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def read_value(value: Any, hint: Any, where: str, name: str) -> Any:
    """``value`` as a field of type ``hint``; :class:`RecordError` ``"<where>: '<name>': ..."`` when it is not."""
    label = f"{where}: {name!r}"
    origin = typing.get_origin(hint)
    if origin in (types.UnionType, typing.Union):
        if value is None:
            return None
        (inner,) = [arg for arg in typing.get_args(hint) if arg is not type(None)]
        return read_value(value, inner, where, name)
    if origin is tuple:
        if not isinstance(value, list | tuple):
            raise RecordError(f"{label}: expected a list, got {_kind(value)}")
        item = typing.get_args(hint)[0]
        return tuple(read_value(v, item, where, f"{name}[{i}]") for i, v in enumerate(value))
    if origin is Literal:
        choices = typing.get_args(hint)
        if value not in choices or not isinstance(value, str):
            raise RecordError(f"{label}: expected one of {', '.join(map(repr, choices))}, got {_kind(value)}")
        return value
    if isinstance(hint, type) and issubclass(hint, Record):
        if isinstance(value, hint):
            return value
        return hint.from_dict(value, f"{where}: {name}")
    if hint is JsonObject:
        if not isinstance(value, dict):
            raise RecordError(f"{label}: expected an object, got {_kind(value)}")
        _check_json(value, label)
        return copy.deepcopy(value)
    if hint is Count:
        value = read_value(value, int, where, name)
        if value < 0:
            raise RecordError(f"{label} is {value}, expected a count (0 or more)")
        return value
    return _scalar(value, hint, label)


def _scalar(value: Any, kind: type, label: str) -> Any:
    # JSON's true and false are Python ints too: a bool is accepted only where one is asked for.
    is_bool = isinstance(value, bool)
    if kind is float and not is_bool and isinstance(value, int | float):
        if not math.isfinite(value):
            raise RecordError(f"{label}: the non-finite number {value}")
        return float(value)
    if kind is bool and is_bool or kind in (str, int) and isinstance(value, kind) and not is_bool:
        return value
    raise RecordError(f"{label}: expected {_KIND_NAMES[kind]}, got {_kind(value)}")


def _check_json(value: Any, label: str) -> None:
    if isinstance(value, dict):
        for key, item in value.items():
            if not isinstance(key, str):
                raise RecordError(f"{label}: a key that is not a string ({key!r})")
            _check_json(item, f"{label}.{key}")
    elif isinstance(value, list | tuple):
        for index, item in enumerate(value):
            _check_json(item, f"{label}[{index}]")
    elif isinstance(value, float) and not math.isfinite(value):
        raise RecordError(f"{label}: the non-finite number {value}")
    elif value is not None and not isinstance(value, str | int | float | bool):
        raise RecordError(f"{label}: {type(value).__name__} is no JSON value")


def _plain(value: Any) -> Any:
    if isinstance(value, Record):
        return value.to_dict()
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return copy.deepcopy(value)
    return value


def _refuse_constant(name: str) -> None:
    raise RecordError(f"the non-finite number {name}")


def _finite_float(text: str) -> float:
    value = float(text)  # 1e400 is read as infinity
    if not math.isfinite(value):
        _refuse_constant(text)
    return value


_KIND_NAMES = {str: "a string", int: "an integer", float: "a number", bool: "true or false"}


def _kind(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return f"the string {value[:40]!r}"
    if isinstance(value, int | float):
        return f"the number {value}"
    if isinstance(value, Mapping):
        return "an object"
    return {list: "a list", tuple: "a list"}.get(type(value), type(value).__name__)

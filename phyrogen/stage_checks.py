"""The checks a stage's request passes before any work, one function each for the Python API
(``phyrogen/__init__.py``) and the command line (``phyrogen/commands/``)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any


def check_generation(generator: str, params: Mapping[str, Any], seeds: Iterable[int]) -> None:
    """Raise :class:`phyrogen_core.registry.ParameterError` (a ValueError) naming what is wrong with
    ``generator``'s ``params`` or with its size at any of ``seeds``; the worker would only find it after
    starting."""
    from phyrogen_core.registry import get_generator

    spec = get_generator(generator)
    parsed = spec.parse_params(params)
    for seed in seeds:
        spec.check(seed, parsed)


def certificate_problems(loaded) -> list[str]:
    """Problems with a read puzzle's (:class:`phyrogen_core.export.LoadedPuzzle`) certificate: empty when it
    is valid at fine resolution."""
    from solver.planning.problem import verify_certificate

    return verify_certificate(loaded.chain, loaded.certificate, loaded.goal, start=loaded.start)


def check_workers(workers: int) -> None:
    """Refuse a number of worker processes that ``--workers`` would refuse (the command line's type has
    refused it before; a request built in Python meets it here)."""
    from phyrogen.options import WORKERS_PER_CORE, max_workers
    from phyrogen.usage import UsageError

    if not 1 <= workers <= max_workers():
        raise UsageError(f"workers must be a whole number in 1..{max_workers()} ({WORKERS_PER_CORE} per usable "
                         f"core), got {workers}")


def check_within(name: str, value, low, high, what: str = "", *, above_low: bool = False) -> None:
    """Refuse a request's number (None: not given) outside ``low..high`` (``above_low``: above ``low``), the
    bounds the command line's option type keeps it in; a request built in Python meets them here."""
    from phyrogen.usage import UsageError

    if value is None:
        return
    if not (low < value if above_low else low <= value) or not value <= high:  # NaN fails both
        low, high = (f"{v:g}" if isinstance(v, float) else str(v) for v in (low, high))
        bound = f"above {low} and at most {high}" if above_low else f"in {low}..{high}"
        raise UsageError(f"{name} must be {bound}{what}, got {value!r}")

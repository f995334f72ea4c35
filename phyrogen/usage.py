"""What a user writes on the command line as lists (seeds, generators, ``--set``), and the error, exit 2, when
it is not what a command takes."""

from __future__ import annotations

from phyrogen_core.registry import MAX_SEED, all_generators, merge_seed_spans, paper_generators

EXIT_BAD_INPUT = 2


class UsageError(ValueError):
    pass


def parse_seeds(text: str) -> tuple[range, ...]:
    """'3', '1-4' or '1,3,5-7' -> the seeds as sorted, disjoint ranges.

    Ranges, not numbers: '1-100000000' takes no more memory than '1-4'.
    """
    spans = []
    try:
        for part in text.split(","):
            low, dash, high = part.partition("-")
            spans.append((int(low), int(high) if dash else int(low)))
            if spans[-1][1] < spans[-1][0]:
                raise ValueError
    except ValueError:
        raise UsageError(f"bad seed list {text!r} (examples: 3, 1-4, 1,3,5-7)") from None
    spans.sort()
    if spans[0][0] < 1:
        raise UsageError(f"seeds must be positive integers, got {text!r}")
    if max(high for _, high in spans) > MAX_SEED:
        raise UsageError(f"seeds must be at most {MAX_SEED}, got {text!r}")
    return tuple(range(low, high + 1) for low, high in merge_seed_spans(spans))


def parse_overrides(items: list[str]) -> dict[str, str]:
    overrides = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise UsageError(f"bad --set {item!r}: expected key=value")
        overrides[key.strip()] = value.strip()
    return overrides


def generator_names(text: str) -> list[str]:
    registry = all_generators()
    if text == "all":
        return list(paper_generators())
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:  # '' or ',': a request for nothing is a mistake, not a run that does nothing
        raise UsageError(f"no generator named in {text!r} (known: {', '.join(registry)}, or 'all')")
    for name in names:
        if name not in registry:
            raise UsageError(f"unknown generator {name!r} (known: {', '.join(registry)})")
    return names

"""The shape of a puzzle's dependency graph: how deep and how wide its blockers are layered."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass


@dataclass(frozen=True)
class DependencyShape:
    """``depth``: layers of blockers around the target (an object that blocks the target is in
    layer 1, one that blocks a layer-1 object in layer 2, ...; each object counted in its
    nearest layer, so cycles do not matter). ``branching``: the most blockers any one object
    has. A chain of n blockers has depth n and branching 1."""

    depth: int
    branching: int

    @property
    def kind(self) -> str:
        """``none`` (nothing blocks the target), ``chain`` (each object has at most one blocker)
        or ``tree`` (some object has several: the blockers fan out, as in a tree or a DAG)."""
        return "none" if self.depth == 0 else "chain" if self.branching <= 1 else "tree"


def dependency_shape(edges: Iterable[tuple[str, str]], target: str) -> DependencyShape:
    """The shape of the graph of (blocker, blocked) ``edges`` seen from ``target``."""
    blockers: dict[str, set[str]] = {}
    for blocker, blocked in edges:
        blockers.setdefault(blocked, set()).add(blocker)
    layer, seen, depth = {target}, {target}, 0
    while True:
        layer = {b for obj in layer for b in blockers.get(obj, ())} - seen
        if not layer:
            break
        seen |= layer
        depth += 1
    return DependencyShape(depth, max((len(b) for b in blockers.values()), default=0))

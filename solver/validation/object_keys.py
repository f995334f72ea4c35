"""Dicts keyed by tuples of puzzle objects (the validator's record of what it solved and checked)."""

from __future__ import annotations

from phyrogen_core.objects import PuzzleObject


class ByObjects:
    """A dict keyed by tuples of puzzle objects, compared as tuples are, each object hashed once: a
    puzzle object's own hash walks all its geometry, and the Maker asks about every prefix of a
    growing puzzle (Rooms: 10 ms a puzzle)."""

    def __init__(self) -> None:
        self._items: dict[ObjectsKey, object] = {}
        self._hashes: dict[int, tuple[PuzzleObject, int]] = {}  # id -> (the object, kept alive; its hash)

    def _key(self, objects: tuple[PuzzleObject, ...]) -> ObjectsKey:
        hashes = []
        for o in objects:
            found = self._hashes.get(id(o))
            if found is None:
                found = self._hashes[id(o)] = (o, hash(o))
            hashes.append(found[1])
        return ObjectsKey(objects, hash(tuple(hashes)))

    def __contains__(self, objects: tuple[PuzzleObject, ...]) -> bool:
        return self._key(objects) in self._items

    def __getitem__(self, objects: tuple[PuzzleObject, ...]):
        return self._items[self._key(objects)]

    def __setitem__(self, objects: tuple[PuzzleObject, ...], value) -> None:
        self._items[self._key(objects)] = value

    def get(self, objects: tuple[PuzzleObject, ...]):
        return self._items.get(self._key(objects))


class ObjectsKey:
    """A key of :class:`ByObjects`: the objects and their hash."""

    __slots__ = ("objects", "hash")

    def __init__(self, objects: tuple[PuzzleObject, ...], hash_: int):
        self.objects, self.hash = objects, hash_

    def __hash__(self) -> int:
        return self.hash

    def __eq__(self, other) -> bool:
        return isinstance(other, ObjectsKey) and self.objects == other.objects

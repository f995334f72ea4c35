"""Seeds from names and numbers: the one stable hash every random source of the project is seeded by.

A seed is SHA-256 of its parts joined by ':' (``("grid_world", 3, "maker")`` hashes
``"grid_world:3:maker"``), so it is the same on any machine, in any process and in any
order of work, unlike Python's salted ``hash``.
"""

from __future__ import annotations

import hashlib

import numpy as np

OMPL_SEED_LIMIT = 2_147_483_646
"""OMPL takes seeds in [1, 2**31 - 2]."""


def stable_hash(*parts: object) -> int:
    """A 64-bit number from SHA-256 of ``parts`` joined by ':' (the digest's first 8 bytes, little-endian)."""
    digest = hashlib.sha256(":".join(str(p) for p in parts).encode()).digest()
    return int.from_bytes(digest[:8], "little")


def stable_seed(*parts: object) -> int:
    """A seed in [1, 2**31 - 2] (OMPL's range) from :func:`stable_hash`'s low 32 bits."""
    return (stable_hash(*parts) & 0xFFFF_FFFF) % OMPL_SEED_LIMIT + 1


def stable_rng(*parts: object) -> np.random.Generator:
    """A numpy Generator seeded with :func:`stable_hash` of ``parts``."""
    return np.random.default_rng(stable_hash(*parts))

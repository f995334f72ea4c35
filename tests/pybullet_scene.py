"""PyBullet as an independent referee for our collision model, on a chain not yet exported.

The replay itself is the product's (:mod:`manipulation.replay`, used by
``phyrogen audit``); this wrapper writes the chain's URDF to a temporary
folder first, so tests can ask about chains they built in memory.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from manipulation.replay import PENETRATION_TOLERANCE, UrdfScene
from phyrogen_core.chain import KinematicChain
from phyrogen_core.export import chain_to_urdf

PENETRATION = PENETRATION_TOLERANCE
"""PyBullet reports contact with margins; deeper than this counts as a real collision."""


class PyBulletScene:
    """The chain's URDF loaded in a DIRECT PyBullet client."""

    def __init__(self, chain: KinematicChain):
        self.chain = chain
        self._dir = tempfile.TemporaryDirectory()
        root = Path(self._dir.name)
        text, meshes = chain_to_urdf(chain)
        (root / "urdf").mkdir()
        (root / "meshes").mkdir()
        for name, body in meshes.items():
            (root / "meshes" / name).write_text(body)
        urdf = root / "urdf" / f"{chain.name}.urdf"
        urdf.write_text(text)
        self.scene = UrdfScene(urdf, chain)

    def deepest_penetration(self, state) -> float:
        """Largest penetration depth (metres, >= 0) between links of different objects."""
        return self.scene.deepest_penetration(state)[0]

    def close(self) -> None:
        self.scene.close()
        self._dir.cleanup()

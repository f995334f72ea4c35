"""PyBullet as an independent referee for our collision model (tests only)."""

from __future__ import annotations

import tempfile
from pathlib import Path

import pybullet as pb

from phyrogen_core.chain import KinematicChain
from phyrogen_core.export import chain_to_urdf

PENETRATION = 1e-3
"""PyBullet reports contact with margins; deeper than this counts as a real collision."""
QUERY_DISTANCE = 0.01
"""getClosestPoints at distance 0 misses deep penetrations between multi-shape links
(seen with PyBullet 3.2.7), so we ask with a small positive distance and read the depth."""


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
        self.client = pb.connect(pb.DIRECT)
        self.body = pb.loadURDF(str(urdf), useFixedBase=True, physicsClientId=self.client)
        self.joint_index, self.link_index = {}, {chain.root: -1}
        for i in range(pb.getNumJoints(self.body, physicsClientId=self.client)):
            info = pb.getJointInfo(self.body, i, physicsClientId=self.client)
            self.joint_index[info[1].decode()] = i
            self.link_index[info[12].decode()] = i
        self.colliding_links = [name for name in self.link_index if chain.link(name).collisions]

    def set_state(self, state) -> None:
        for name, value in zip(self.chain.joint_order, state, strict=True):
            pb.resetJointState(self.body, self.joint_index[name], float(value), physicsClientId=self.client)

    def deepest_penetration(self, state) -> float:
        """Largest penetration depth (metres, >= 0) between links of different objects."""
        self.set_state(state)
        deepest = 0.0
        links = self.colliding_links
        for i, a in enumerate(links):
            for b in links[i + 1:]:
                if self.chain.link(a).object_name == self.chain.link(b).object_name:
                    continue
                points = pb.getClosestPoints(self.body, self.body, QUERY_DISTANCE, self.link_index[a],
                                             self.link_index[b],
                                             physicsClientId=self.client)
                for point in points:
                    deepest = max(deepest, -point[8])
        return deepest

    def close(self) -> None:
        pb.disconnect(self.client)
        self._dir.cleanup()

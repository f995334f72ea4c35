"""PyBullet as an independent referee: replay a path on a puzzle's URDF and measure penetration.

Our collision model (:mod:`solver.collision.model`) is a planar separating-axis
test written for this project; the certificate check and the planners all
use it. PyBullet shares none of its code: it loads the exported URDF (the
file a user gets, meshes included), and its GJK/EPA closest-point queries
measure how deep two links of different objects overlap. A path that holds
here holds for a second, unrelated implementation of the same geometry and
of the exported file.

Nothing is simulated: every state is set with ``resetJointState`` and only
distances are asked, so the replay is deterministic and needs no physics.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pybullet as pb

from phyrogen_core.chain import KinematicChain
from solver.collision.model import CollisionModel
from solver.pipelines.audit import Replay
from solver.planning.problem import FINE_RESOLUTION, MAX_CHECKED_STATES, segment_points

PENETRATION_TOLERANCE = 1e-3
"""Metres of penetration PyBullet may report between shapes that only touch: its boxes, meshes
and cylinders carry collision margins, and its EPA depths blur contact by about a millimetre
(our model counts touching as free within 1e-6 m). Deeper than this is a real overlap."""
QUERY_DISTANCE = 0.01
"""getClosestPoints at distance 0 misses deep penetrations between multi-shape links (seen with
PyBullet 3.2.7), so pairs are asked with a small positive distance and the depth is read."""
REPLAY_RESOLUTION = FINE_RESOLUTION
"""Metres any collision point moves between two replayed states: the certificate check's 2 mm."""


class UrdfScene:
    """A puzzle's URDF loaded, with its base fixed, into a DIRECT PyBullet client of its own.

    ``chain`` is the chain read from the same file (it names the joints and tells which links
    belong to which object and which links can move). Use as a context manager, or call
    :meth:`close`.
    """

    def __init__(self, urdf: str | Path, chain: KinematicChain):
        self.chain = chain
        self.client = pb.connect(pb.DIRECT)
        try:
            self.body = pb.loadURDF(str(urdf), useFixedBase=True, physicsClientId=self.client)
        except pb.error as exc:
            pb.disconnect(self.client)
            raise ValueError(f"{urdf}: PyBullet cannot load the URDF: {exc}") from None
        self.joint_index: dict[str, int] = {}
        self.link_index: dict[str, int] = {chain.root: -1}
        for i in range(pb.getNumJoints(self.body, physicsClientId=self.client)):
            info = pb.getJointInfo(self.body, i, physicsClientId=self.client)
            self.joint_index[info[1].decode()] = i
            self.link_index[info[12].decode()] = i
        missing = [n for n in chain.joint_order if n not in self.joint_index]
        if missing:
            self.close()
            raise ValueError(f"{urdf}: PyBullet finds no joint {missing[0]!r} in the URDF")
        self.links = [name for name in self.link_index if chain.link(name).collisions]
        moving = _moving_links(chain)
        owner = {name: chain.link(name).object_name or name for name in self.links}
        # The pairs our model checks: links of different objects, at least one of them able to
        # move (two pieces of scenery overlap the same way in every state; no path changes that).
        self.pairs = np.array([(a, b) for a, b in itertools.combinations(range(len(self.links)), 2)
                               if owner[self.links[a]] != owner[self.links[b]]
                               and (self.links[a] in moving or self.links[b] in moving)],
                              dtype=np.int64).reshape(-1, 2)

    def __enter__(self) -> UrdfScene:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def set_state(self, state: Sequence[float]) -> None:
        for name, value in zip(self.chain.joint_order, state, strict=True):
            pb.resetJointState(self.body, self.joint_index[name], float(value), physicsClientId=self.client)

    def deepest_penetration(self, state: Sequence[float]) -> tuple[float, tuple[str, str]]:
        """The largest penetration depth (metres, >= 0) between links of different objects at
        ``state`` (joint order), and the two links (empty when nothing penetrates)."""
        self.set_state(state)
        if not len(self.pairs):
            return 0.0, ()
        # Broad phase first: only pairs whose boxes come within the query distance are asked.
        boxes = np.array([pb.getAABB(self.body, self.link_index[name], physicsClientId=self.client)
                          for name in self.links])  # (links, 2, 3): min corner, max corner
        first, second = boxes[self.pairs[:, 0]], boxes[self.pairs[:, 1]]
        near = np.all((first[:, 0] <= second[:, 1] + QUERY_DISTANCE) & (second[:, 0] <= first[:, 1] + QUERY_DISTANCE),
                      axis=1)
        deepest, between = 0.0, ()
        for a, b in self.pairs[near]:
            link_a, link_b = self.links[a], self.links[b]
            points = pb.getClosestPoints(self.body, self.body, QUERY_DISTANCE, self.link_index[link_a],
                                         self.link_index[link_b], physicsClientId=self.client)
            for point in points:
                if -point[8] > deepest:
                    deepest, between = -point[8], (link_a, link_b)
        return deepest, between

    def close(self) -> None:
        if pb.isConnected(self.client):
            pb.disconnect(self.client)


def _moving_links(chain: KinematicChain) -> set[str]:
    """Links that an active joint moves: the child of one, and everything below it."""
    moving = {j.child for j in chain.active_joints}
    grew = True
    while grew:
        below = {j.child for j in chain.joints if j.parent in moving} - moving
        moving |= below
        grew = bool(below)
    return moving


@dataclass(frozen=True)
class PyBulletReferee:
    """Replays paths in PyBullet every ``resolution`` metres (:class:`solver.pipelines.audit.Referee`)."""

    resolution: float = REPLAY_RESOLUTION
    tolerance: float = PENETRATION_TOLERANCE
    name: str = "PyBullet"

    def replay(self, urdf: str | Path, chain: KinematicChain, path: Sequence[Sequence[float]]) -> Replay:
        """The deepest penetration along ``path`` (chain joint order), densified so that no
        collision point moves more than :attr:`resolution` between replayed states."""
        states = np.asarray(path, dtype=float).reshape(-1, len(chain.joint_order))
        if len(states) == 0:
            return Replay(0.0, 0)
        steps = CollisionModel(chain).motion_steps(self.resolution)
        counts = np.maximum(1.0, np.ceil(np.max(np.abs(np.diff(states, axis=0)) / steps, axis=1, initial=0.0)))
        total = 1 + int(counts.sum())
        if total > MAX_CHECKED_STATES:
            return Replay(0.0, 0, problem=f"needs {total} states at {self.resolution} m, more than the "
                                          f"{MAX_CHECKED_STATES} a replay may take; not replayed")
        dense = np.concatenate([states[:1], segment_points(states, steps)[0]]) if len(states) > 1 else states
        deepest, at, between = 0.0, -1, ()
        with UrdfScene(urdf, chain) as scene:
            for index, state in enumerate(dense):
                depth, pair = scene.deepest_penetration(state)
                if depth > deepest:
                    deepest, at, between = depth, index, pair
        return Replay(deepest, len(dense), at, between)

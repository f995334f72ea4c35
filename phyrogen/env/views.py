"""What an environment shows of a puzzle besides its joint vector: the raster observation, the RGB
image of ``render_mode="rgb_array"``, and the certificate's progress that the ``"guided"`` reward pays.

All three are drawn from the planning problem itself: the raster and the image from the collision
model's shapes (:mod:`solver.collision.raster`), the progress from the stored certificate.
"""

from __future__ import annotations

import numpy as np

from phyrogen.env.puzzles import RASTER_CHANNELS, Task
from solver.collision.raster import ChainRaster, frame_around

FIXED, TARGET, MOVABLE, GOAL = (RASTER_CHANNELS.index(c) for c in ("fixed", "target", "movable", "goal"))

COLOURS = {GOAL: (150, 215, 150), FIXED: (60, 60, 60), MOVABLE: (70, 110, 200), TARGET: (215, 60, 50)}
"""The image's colour of each raster channel (painted in this order over a pale background)."""
BACKGROUND = (245, 245, 240)
IMAGE_SIZE = 256
"""Pixels along each side of the ``rgb_array`` image."""
ADVANCE = 0.05
"""How near (normalised joint coordinates) a state must come to a certificate segment's end for the
guided reward's cursor to move on to the next segment."""


def goal_state(task: Task) -> np.ndarray:
    """The start state with the target's goal joints at their goal values."""
    state = task.start.copy()
    state[task.goal_index] = task.goal_value
    return state


class RasterView:
    """A task's raster of ``size`` x ``size`` cells in :data:`~phyrogen.env.puzzles.RASTER_CHANNELS`.

    The square it covers holds every shape at the start, at each state of the certificate and with the
    target at its goal (so each puzzle fills its raster; cells of different puzzles differ in size).
    What never moves (the fixed shapes, the goal) is drawn once; a state adds the movable objects."""

    def __init__(self, task: Task, size: int):
        model = task.model
        goal = goal_state(task)
        self.frame = frame_around(model, [task.start, *task.certificate, goal], size)
        self.raster = raster = ChainRaster(model, self.frame)
        target = task.source.goal.target
        is_target = np.array([o == target for o in raster.shape_objects], dtype=np.bool_)
        moves = raster.shape_moves
        self.static = np.zeros((len(RASTER_CHANNELS), size, size), dtype=np.float32)
        raster.draw(task.start, np.where(moves, -1, FIXED), self.static)
        raster.draw(goal, np.where(moves & is_target, GOAL, -1), self.static)
        self.moving = np.where(moves, np.where(is_target, TARGET, MOVABLE), -1)

    def observe(self, state: np.ndarray) -> np.ndarray:
        """The raster at ``state`` (the task's joint order), a new float32 array of 0s and 1s."""
        out = self.static.copy()
        self.raster.draw(state, self.moving, out)
        return out

    def image(self, state: np.ndarray) -> np.ndarray:
        """The raster at ``state`` in colour: (size, size, 3) uint8."""
        channels = self.observe(state) > 0
        out = np.empty((*channels.shape[1:], 3), dtype=np.uint8)
        out[:] = BACKGROUND
        for channel, colour in COLOURS.items():
            out[channels[channel]] = colour
        return out


class CertificateGuide:
    """Progress along the certificate, the potential of the ``"guided"`` reward.

    In joint coordinates normalised to [-1, 1] over the limits, the certificate is a polyline of length
    ``L`` from the start to the goal. An episode follows it with a cursor, the segment it is on (the
    first at the start): the potential is (the arc length to the state's nearest point on that segment -
    the state's distance from it) / ``L``, and the cursor moves on to the next segment once the state
    comes within :data:`ADVANCE` of the segment's end. So the start is worth 0, the certificate's end 1,
    a step earns the potential's change (an episode's guided rewards sum to 1 at the goal plus the
    potential it ends at), and a certificate that passes a state twice (a blocker moved out and back)
    pays for it in its order, once. Moving a blocker in the certificate's order is paid before the
    target can move, which the goal distance never pays."""

    def __init__(self, task: Task):
        points = (task.certificate - task.center) * task.inv_half
        keep = np.ones(len(points), dtype=np.bool_)
        keep[1:] = np.abs(np.diff(points, axis=0)).max(axis=1, initial=0.0) > 1e-12
        points = points[keep]
        if len(points) < 2:  # the start is the goal
            points = np.vstack([points[:1], points[:1] + 1e-9])
        self._center, self._scale = task.center, task.inv_half
        self._start, self._end = points[:-1], points[1:]
        self._delta = self._end - self._start
        self._length2 = (self._delta ** 2).sum(axis=1)
        self._lengths = np.sqrt(self._length2)
        self._before = np.concatenate([[0.0], np.cumsum(self._lengths)[:-1]])
        self._total = float(self._lengths.sum())
        self.segments = len(self._lengths)

    def track(self, states: np.ndarray, cursor: np.ndarray) -> np.ndarray:
        """The potential of each row of ``states`` (N, d; the task's joint order), moving each row's
        ``cursor`` (N ints, updated in place) on past the segment ends the row has reached."""
        x = (np.atleast_2d(states) - self._center) * self._scale
        last = self.segments - 1
        while True:
            near = (cursor < last) & (np.sqrt(((x - self._end[cursor]) ** 2).sum(axis=1)) <= ADVANCE)
            if not near.any():
                break
            cursor[near] += 1
        relative = x - self._start[cursor]
        delta = self._delta[cursor]
        t = np.clip((relative * delta).sum(axis=1) / self._length2[cursor], 0.0, 1.0)
        distance = np.sqrt(((relative - t[:, None] * delta) ** 2).sum(axis=1))
        return (self._before[cursor] + t * self._lengths[cursor] - distance) / self._total

    def nearest(self, state: np.ndarray) -> int:
        """The segment nearest ``state`` (the latest of equals): a cursor for a state set from outside."""
        x = (np.asarray(state, dtype=np.float64) - self._center) * self._scale
        relative = x[None, :] - self._start
        t = np.clip((relative * self._delta).sum(axis=1) / self._length2, 0.0, 1.0)
        distance = np.sqrt(((relative - t[:, None] * self._delta) ** 2).sum(axis=1))
        return int(len(distance) - 1 - np.argmin(distance[::-1]))


def raster_view(task: Task, size: int) -> RasterView:
    """The task's :class:`RasterView` of ``size`` cells, made once."""
    view = task.views.get(("raster", size))
    if view is None:
        view = task.views["raster", size] = RasterView(task, size)
    return view


def guide(task: Task) -> CertificateGuide:
    """The task's :class:`CertificateGuide`, made once."""
    made = task.views.get("guide")
    if made is None:
        made = task.views["guide"] = CertificateGuide(task)
    return made

"""Frames and video of an execution, rendered afterwards from its recording.

Rendering replays the recorded joint values in a separate, render-only
PyBullet world with the TinyRenderer (no GPU needed), so it never touches
the simulation or its timings.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pybullet as pb

from .execution import Recording, SceneSetup
from .scene import World, temporary_folder, write_scene_files

FRAME_SIZE = (480, 360)
VIDEO_SIZE = (320, 240)
VIDEO_FPS = 20
MAX_VIDEO_FRAMES = 160


def figure_indices(recording: Recording) -> list[int]:
    """Four snapshots as in the paper's Fig. 5: start, two intermediate actions, final."""
    count = len(recording.robot)
    if count == 0:
        raise ValueError("the recording is empty; nothing to render")
    actions = np.asarray(recording.action)
    last = int(actions.max())

    def middle_of(action: int) -> int:
        where = np.flatnonzero(actions == action)
        return int(where[len(where) // 2]) if where.size else count // 2

    if last >= 2:
        middle = [middle_of(last // 3), middle_of((2 * last) // 3)]
    else:
        middle = [count // 3, (2 * count) // 3]
    return [0, *middle, count - 1]


def video_indices(recording: Recording, max_frames: int = MAX_VIDEO_FRAMES) -> list[int]:
    count = len(recording.robot)
    return sorted({int(round(i)) for i in np.linspace(0, count - 1, min(count, max_frames))})


class Renderer:
    """A render-only world for one scene; use as a context manager."""

    def __init__(self, setup: SceneSetup):
        self._tmp = temporary_folder()
        files = write_scene_files(Path(self._tmp.name), setup.chain, setup.robot)
        self.world = World(files, setup.chain, setup.placement)
        # Every puzzle is scaled into the same square around the origin, so one camera frames them all.
        self.view = pb.computeViewMatrixFromYawPitchRoll((-0.3, 0.0, 0.1), 3.1, 30.0, -45.0, 0.0, 2)
        self.projection = pb.computeProjectionMatrixFOV(50.0, 4 / 3, 0.05, 20.0)

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc) -> None:
        self.world.close()
        self._tmp.cleanup()

    def image(self, recording: Recording, index: int, size: tuple[int, int]) -> np.ndarray:
        self.world.set_robot(recording.robot[index])
        self.world.set_puzzle(recording.puzzle[index])
        width, height = size
        _, _, rgba, _, _ = pb.getCameraImage(width, height, self.view, self.projection,
                                             renderer=pb.ER_TINY_RENDERER, physicsClientId=self.world.client)
        return np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]


def write_frames(renderer: Renderer, recording: Recording, folder: Path, indices: Sequence[int]) -> list[Path]:
    import imageio.v2 as imageio

    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for number, index in enumerate(indices, start=1):
        path = folder / f"frame_{number}.png"
        imageio.imwrite(path, renderer.image(recording, index, FRAME_SIZE))
        paths.append(path)
    return paths


def write_video(renderer: Renderer, recording: Recording, path: Path) -> Path:
    import imageio.v2 as imageio

    with imageio.get_writer(path, fps=VIDEO_FPS, codec="libx264", macro_block_size=8, quality=6) as writer:
        for index in video_indices(recording):
            writer.append_data(renderer.image(recording, index, VIDEO_SIZE))
    return path

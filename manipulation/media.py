"""Frames and video of an execution, rendered afterwards from its recording.

Rendering replays the recorded joint values in a separate, render-only
PyBullet world with the TinyRenderer (no GPU needed), so it never touches
the simulation or its timings.

The camera is framed on the robot and the puzzle together: from a fixed
oblique direction (:data:`CAMERA_YAW`, :data:`CAMERA_PITCH`) it aims at the
middle of the corners of the axis-aligned boxes of every link of both bodies
(collision and visual shapes), as seen across and up the image, and stands
back just far enough for all of them to fit the image, with a margin. The four
figure frames are framed each on its own moment; the video's camera is
framed on a window of moments and smoothed over time, so it
neither jumps nor loses either body.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pybullet as pb

from .execution_records import Recording, SceneSetup
from .scene import World, temporary_folder, write_scene_files

FRAME_SIZE = (640, 480)
VIDEO_SIZE = (640, 480)
VIDEO_FPS = 25
VIDEO_EVERY = 6
"""Video frames are every this many recorded snapshots (a fixed number of simulation steps apart)."""
VIDEO_WINDOW = 1.5
"""Seconds of video either side of a moment whose bounds the video's camera keeps in view."""
CAMERA_YAW = 30.0
CAMERA_PITCH = -35.0
FIELD_OF_VIEW = 50.0
"""Vertical field of view, degrees."""
MARGIN = 1.15
"""The framed box fills at most 1 / MARGIN of the image, in each direction."""
NEAR, FAR = 0.05, 30.0
GRIP_DISTANCE = 0.2
"""Metres from the tool point to the camera of a grip close-up."""
GRIP_ELEVATION = 25.0
"""Degrees above the horizontal the close-up looks down from."""


@dataclass(frozen=True)
class Camera:
    """Where the camera looks (``target``) and how far back it stands, along the fixed yaw and pitch."""

    target: tuple[float, float, float]
    distance: float


@dataclass(frozen=True)
class Picture:
    rgb: np.ndarray
    """height x width x 3, uint8."""
    segmentation: np.ndarray
    """height x width: the PyBullet body id seen at each pixel (-1: nothing)."""


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


def video_indices(recording: Recording, every: int = VIDEO_EVERY) -> list[int]:
    """Every ``every``-th snapshot (a fixed simulation-step interval), and the last one."""
    count = len(recording.robot)
    indices = list(range(0, count, every))
    if indices and indices[-1] != count - 1:
        indices.append(count - 1)
    return indices


def _axes(yaw: float = CAMERA_YAW, pitch: float = CAMERA_PITCH) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit vectors of the camera: right, up, forward (world frame), as PyBullet's yaw/pitch view has them."""
    view = np.asarray(pb.computeViewMatrixFromYawPitchRoll((0, 0, 0), 1.0, yaw, pitch, 0.0, 2)).reshape(4, 4).T
    rotation = view[:3, :3]  # world -> camera (OpenGL: x right, y up, looking along -z)
    return rotation[0], rotation[1], -rotation[2]


def _box_corners(low: np.ndarray, high: np.ndarray) -> np.ndarray:
    return np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])


def fit(points: np.ndarray, aspect: float, target: np.ndarray | None = None) -> Camera:
    """The camera aimed at ``target`` that sees every point with :data:`MARGIN`, from the fixed yaw
    and pitch. The default target centres the points' extent across and up the image."""
    points = np.asarray(points, float)
    right, up, forward = _axes()
    if target is None:
        axes = np.stack([right, up, forward])
        coords = points @ axes.T
        target = ((coords.min(axis=0) + coords.max(axis=0)) / 2) @ axes
    target = np.asarray(target, float)
    tan_v = math.tan(math.radians(FIELD_OF_VIEW) / 2) / MARGIN
    tan_h = tan_v * aspect
    relative = points - target
    # A point at depth d + p.forward is in view when |p.right| <= tan_h * depth and |p.up| <= tan_v * depth.
    needed = np.maximum(np.abs(relative @ right) / tan_h, np.abs(relative @ up) / tan_v) - relative @ forward
    return Camera(tuple(float(v) for v in target), float(max(needed.max(), 0.2)))


def smooth_cameras(point_sets: Sequence[np.ndarray], aspect: float, window: int) -> list[Camera]:
    """Cameras for a sequence of moments (each the corner points of its bodies' boxes) that move
    smoothly and still see each moment whole.

    Each moment is framed on the points of the ``window`` moments either side; the target is that
    framing's target averaged over the window, and the distance the average, over the window, of
    the largest distance needed in a window: never less than what the moment itself needs.
    """
    n = len(point_sets)
    span = [range(max(0, i - window), min(n, i + window + 1)) for i in range(n)]
    union = [np.concatenate([point_sets[j] for j in s]) for s in span]
    centres = np.array([fit(points, aspect).target for points in union])
    targets = [centres[list(s)].mean(axis=0) for s in span]
    needed = np.array([fit(points, aspect, t).distance for points, t in zip(union, targets, strict=True)])
    # needed[i] depends on targets[i]; the moving max then moving mean of the window keeps every
    # distance >= needed[i] (each max over a window holding i is).
    widest = np.array([needed[list(s)].max() for s in span])
    distances = [float(widest[list(s)].mean()) for s in span]
    return [Camera(tuple(float(v) for v in t), d) for t, d in zip(targets, distances, strict=True)]


class Renderer:
    """A render-only world for one scene; use as a context manager."""

    def __init__(self, setup: SceneSetup):
        self._tmp = temporary_folder()
        files = write_scene_files(Path(self._tmp.name), setup.chain, setup.robot)
        self.world = World(files, setup.chain, setup.placement)
        self._mesh_bounds: dict[str, tuple[np.ndarray, np.ndarray] | None] = {}

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc) -> None:
        self.world.close()
        self._tmp.cleanup()

    def pose(self, recording: Recording, index: int) -> None:
        self.world.set_robot(recording.robot[index])
        self.world.set_puzzle(recording.puzzle[index])
        if recording.fingers:
            self.world.set_fingers(recording.fingers[index])

    def corners(self, recording: Recording, index: int) -> np.ndarray:
        """The corners of the axis-aligned boxes of every link of the robot and of the puzzle at ``index``
        (collision and visual shapes), one a row."""
        self.pose(recording, index)
        c = self.world.client
        boxes = [pb.getAABB(body, link, physicsClientId=c)
                 for body in (self.world.robot, self.world.puzzle)
                 for link in range(-1, pb.getNumJoints(body, physicsClientId=c))]
        # Collision shapes miss what is only drawn (goal markers, static frames without collisions).
        for body in (self.world.robot, self.world.puzzle):
            boxes += [box for shape in pb.getVisualShapeData(body, physicsClientId=c)
                      if (box := _visual_box(body, shape, c, self._mesh_bounds)) is not None]
        return np.concatenate([_box_corners(np.asarray(lo), np.asarray(hi)) for lo, hi in boxes])

    def camera(self, recording: Recording, index: int, size: tuple[int, int]) -> Camera:
        """The camera framed on robot and puzzle at ``index`` alone."""
        return fit(self.corners(recording, index), size[0] / size[1])

    def picture(self, recording: Recording, index: int, size: tuple[int, int], camera: Camera | None = None) -> Picture:
        camera = camera or self.camera(recording, index, size)
        self.pose(recording, index)
        width, height = size
        view = pb.computeViewMatrixFromYawPitchRoll(camera.target, camera.distance, CAMERA_YAW, CAMERA_PITCH, 0.0, 2)
        projection = pb.computeProjectionMatrixFOV(FIELD_OF_VIEW, width / height, NEAR, FAR)
        _, _, rgba, _, seg = pb.getCameraImage(width, height, view, projection, renderer=pb.ER_TINY_RENDERER,
                                               physicsClientId=self.world.client)
        rgb = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]
        return Picture(rgb, np.asarray(seg).reshape(height, width))

    def image(self, recording: Recording, index: int, size: tuple[int, int]) -> np.ndarray:
        return self.picture(recording, index, size).rgb


def _visual_box(body: int, shape: tuple, client: int,
                mesh_bounds: dict[str, tuple[np.ndarray, np.ndarray] | None]) -> tuple[np.ndarray, np.ndarray] | None:
    """World axis-aligned box of one visual shape (from ``getVisualShapeData``), or None if unknown."""
    link, kind, dims, filename, position, orientation = shape[1], shape[2], shape[3], shape[4], shape[5], shape[6]
    if kind == pb.GEOM_BOX:
        low, high = -np.asarray(dims) / 2, np.asarray(dims) / 2
    elif kind == pb.GEOM_SPHERE:
        low, high = -np.full(3, dims[0]), np.full(3, dims[0])
    elif kind in (pb.GEOM_CYLINDER, pb.GEOM_CAPSULE):
        half = dims[0] / 2 + (dims[1] if kind == pb.GEOM_CAPSULE else 0.0)
        low, high = -np.array([dims[1], dims[1], half]), np.array([dims[1], dims[1], half])
    elif kind == pb.GEOM_MESH:
        name = filename.decode() if isinstance(filename, bytes) else str(filename)
        if name not in mesh_bounds:
            mesh_bounds[name] = _obj_bounds(Path(name))
        if mesh_bounds[name] is None:
            return None
        scale = np.asarray(dims)
        corners = np.array([mesh_bounds[name][0] * scale, mesh_bounds[name][1] * scale])
        low, high = corners.min(axis=0), corners.max(axis=0)
    else:
        return None
    if link == -1:
        com, com_orn = pb.getBasePositionAndOrientation(body, physicsClientId=client)
        inertial = pb.getDynamicsInfo(body, -1, physicsClientId=client)[3:5]
        frame = pb.multiplyTransforms(com, com_orn, *pb.invertTransform(*inertial))
    else:
        state = pb.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=client)
        frame = (state[4], state[5])
    centre, orn = pb.multiplyTransforms(*frame, position, orientation)
    rotation = np.asarray(pb.getMatrixFromQuaternion(orn)).reshape(3, 3)
    middle = rotation @ ((low + high) / 2) + np.asarray(centre)
    half = np.abs(rotation) @ ((high - low) / 2)
    return middle - half, middle + half


def _obj_bounds(path: Path) -> tuple[np.ndarray, np.ndarray] | None:
    """The vertex bounds of a Wavefront OBJ file (None for other formats or unreadable files)."""
    if path.suffix.lower() != ".obj" or not path.is_file():
        return None
    vertices = [line.split()[1:4] for line in path.read_text(errors="replace").splitlines() if line.startswith("v ")]
    if not vertices:
        return None
    points = np.asarray(vertices, dtype=float)
    return points.min(axis=0), points.max(axis=0)


def figure_pictures(renderer: Renderer, recording: Recording, size: tuple[int, int] = FRAME_SIZE) -> list[Picture]:
    """The four figure frames (:func:`figure_indices`), each framed on robot and puzzle at its moment."""
    return [renderer.picture(recording, index, size) for index in figure_indices(recording)]


def grip_indices(recording: Recording) -> list[int]:
    """Per action, the snapshot in the middle of its longest stretch with the handle held (actions
    without one are left out)."""
    held = np.asarray(recording.holding, dtype=bool)
    actions = np.asarray(recording.action)
    out = []
    for action in sorted(set(recording.action)):
        best: tuple[int, int] | None = None  # (length, start)
        start = None
        for i in [*np.flatnonzero(actions == action), -1]:
            if i >= 0 and held[i] and start is None:
                start = i
            elif (i < 0 or not held[i]) and start is not None:
                stretch = (i if i >= 0 else int(np.flatnonzero(actions == action)[-1]) + 1) - start
                best = max(best or (0, 0), (stretch, start))
                start = None
        if best is not None:
            out.append(best[1] + best[0] // 2)
    return out


def grip_picture(renderer: Renderer, recording: Recording, index: int, size: tuple[int, int] = FRAME_SIZE) -> Picture:
    """A close-up of the gripper at ``index``, seen across the fingers' closing direction from the
    side away from the robot, so both fingers and the handle between them show."""
    renderer.pose(recording, index)
    world = renderer.world
    position, orientation = world.tool_pose()
    axes = np.asarray(pb.getMatrixFromQuaternion(orientation)).reshape(3, 3)
    along = axes[:2, 0] / max(np.linalg.norm(axes[:2, 0]), 1e-9)  # tool x, horizontal: toward the base
    elevation = math.radians(GRIP_ELEVATION)
    eye = np.asarray(position) + GRIP_DISTANCE * np.array([-along[0] * math.cos(elevation),
                                                           -along[1] * math.cos(elevation), math.sin(elevation)])
    width, height = size
    view = pb.computeViewMatrix(eye.tolist(), list(position), [0.0, 0.0, 1.0])
    projection = pb.computeProjectionMatrixFOV(FIELD_OF_VIEW, width / height, NEAR, FAR)
    _, _, rgba, _, seg = pb.getCameraImage(width, height, view, projection, renderer=pb.ER_TINY_RENDERER,
                                           physicsClientId=world.client)
    rgb = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]
    return Picture(rgb, np.asarray(seg).reshape(height, width))


def write_grip_frames(renderer: Renderer, recording: Recording, folder: Path,
                      size: tuple[int, int] = FRAME_SIZE) -> list[Path]:
    """``folder/grip_1..n.png``: a close-up of the fingers on the handle, one per action."""
    import imageio.v2 as imageio

    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for number, index in enumerate(grip_indices(recording), start=1):
        path = folder / f"grip_{number}.png"
        imageio.imwrite(path, grip_picture(renderer, recording, index, size).rgb)
        paths.append(path)
    return paths


def write_frames(renderer: Renderer, recording: Recording, folder: Path,
                 size: tuple[int, int] = FRAME_SIZE) -> list[Path]:
    """``folder/frame_1..4.png``: the :func:`figure_pictures`."""
    import imageio.v2 as imageio

    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for number, picture in enumerate(figure_pictures(renderer, recording, size), start=1):
        path = folder / f"frame_{number}.png"
        imageio.imwrite(path, picture.rgb)
        paths.append(path)
    return paths


def video_cameras(renderer: Renderer, recording: Recording, indices: Sequence[int],
                  size: tuple[int, int] = VIDEO_SIZE) -> list[Camera]:
    """The smoothed cameras of the video frames at ``indices``."""
    points = [renderer.corners(recording, i) for i in indices]
    return smooth_cameras(points, size[0] / size[1], max(1, round(VIDEO_WINDOW * VIDEO_FPS)))


def write_video(renderer: Renderer, recording: Recording, path: Path, size: tuple[int, int] = VIDEO_SIZE) -> Path:
    import imageio.v2 as imageio

    indices = video_indices(recording)
    cameras = video_cameras(renderer, recording, indices, size)
    with imageio.get_writer(path, fps=VIDEO_FPS, codec="libx264", macro_block_size=8, quality=6,
                            ffmpeg_log_level="error") as writer:
        for index, camera in zip(indices, cameras, strict=True):
            writer.append_data(renderer.picture(recording, index, size, camera).rgb)
    return path

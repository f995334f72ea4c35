"""Rendering a puzzle scene: stage (floor, light), cameras framing the puzzle, engines.

Workbench is the fast engine, but without an OpenGL context (Mesa through
EGL on a headless machine) it aborts the whole process; callers that cannot
know beforehand render in a subprocess (see :mod:`.rendering`) and fall back
to Cycles on the CPU.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np
from mathutils import Euler, Vector

from .scene import phobostype
from .views import DEFAULT_VIEWS, GALLERY_VIEW, VIEWS, View, image_name

STAGE = "phyrogen_stage"
CYCLES_SAMPLES = 16


@dataclass(frozen=True)
class Look:
    """How a puzzle stands on its stage in Workbench (Cycles takes the floor's and the world's colours)."""

    floor_color: tuple[float, float, float, float]
    world_color: tuple[float, float, float]
    exposure: float
    light_direction: tuple[float, float, float]
    """Workbench's studio light, in the camera's frame (x right, y up, z towards the camera): shadows fall
    away from it, so each view has them on the same side."""
    shadow_intensity: float
    shadow_focus: float
    cavity: str | None
    """Workbench's cavity: 'SCREEN' (ridges and valleys darkened on screen), 'WORLD' (ambient occlusion
    by sampling), 'BOTH', or None."""
    valley_factor: float
    still_aa: str
    """Workbench's anti-aliasing of stills ('FXAA', or a sample count as text)."""


GROUND = Look(floor_color=(1.0, 1.0, 0.98, 1.0), world_color=(0.97, 0.97, 0.98), exposure=0.3,
              light_direction=(-0.35, 0.8, 0.5), shadow_intensity=0.6, shadow_focus=0.5, cavity="SCREEN",
              valley_factor=1.5, still_aa="FXAA")
"""The puzzles standing on a light floor, as in the paper's Fig. 3: a shadow cast on the floor beside each
object, edges and contacts darkened by the screen-space cavity. At the stills' 520x390 it costs less per
still than the flat look did at 480x360 (``benchmarks/render_look.py``, docs/blender-animation.md): FXAA
instead of 5 samples pays for the larger size (560x420 cost 14-24 % more wall time under load, though
15 % less CPU); the shadows and the cavity cost little; AO by sampling (WORLD) doubled the time."""


def visual_bounds(collection: bpy.types.Collection) -> tuple[np.ndarray, np.ndarray]:
    """World bounding box (low, high) of the rendered objects of a puzzle."""
    bpy.context.view_layer.update()
    corners = [
        np.array(obj.matrix_world) @ np.array([*corner, 1.0])
        for obj in collection.all_objects
        if obj.type == "MESH" and phobostype(obj) == "visual" and not obj.hide_render
        for corner in obj.bound_box
    ]
    if not corners:
        raise ValueError(f"collection {collection.name!r} has no visual objects to frame")
    points = np.array(corners)[:, :3]
    return points.min(axis=0), points.max(axis=0)


def setup_stage(scene: bpy.types.Scene, collection: bpy.types.Collection, engine: str,
                size: tuple[int, int], look: Look = GROUND) -> None:
    """Floor, light, world and render settings for ``engine`` ('WORKBENCH' or 'CYCLES') in ``look``."""
    valid = ("WORKBENCH", "CYCLES")
    if engine not in valid:
        raise ValueError(f"render engine {engine!r} is not supported here; valid: {valid}")
    low, high = visual_bounds(collection)
    stage = bpy.data.collections.get(STAGE) or bpy.data.collections.new(STAGE)
    if stage.name not in scene.collection.children:
        scene.collection.children.link(stage)
    for obj in list(stage.objects):
        bpy.data.objects.remove(obj)
    centre = (low + high) / 2
    extent = float(max(high[0] - low[0], high[1] - low[1], 1.0))
    _floor(stage, centre, extent * 20, float(low[2]), look.floor_color)
    sun = bpy.data.objects.new("phyrogen_sun", bpy.data.lights.new("phyrogen_sun", "SUN"))
    sun.data.energy = 3.0
    sun.data.angle = math.radians(10)
    sun.rotation_euler = Euler((math.radians(40), math.radians(10), math.radians(-30)))
    stage.objects.link(sun)

    render = scene.render
    render.engine = "BLENDER_WORKBENCH" if engine == "WORKBENCH" else "CYCLES"
    render.resolution_x, render.resolution_y = size
    render.resolution_percentage = 100
    render.film_transparent = False
    render.image_settings.file_format = "PNG"
    render.image_settings.color_mode = "RGB"
    render.image_settings.color_depth = "8"
    # Stamped metadata (date, render time) would make identical pixels differ in bytes.
    for flag in ("use_stamp", "use_stamp_date", "use_stamp_time", "use_stamp_render_time", "use_stamp_frame",
                 "use_stamp_memory", "use_stamp_hostname", "use_stamp_camera", "use_stamp_lens",
                 "use_stamp_scene", "use_stamp_filename", "use_stamp_marker", "use_stamp_frame_range",
                 "use_stamp_sequencer_strip", "use_stamp_note"):
        if hasattr(render, flag):
            setattr(render, flag, False)
    world = scene.world or bpy.data.worlds.new("phyrogen_world")
    scene.world = world
    world.color = look.world_color
    scene.view_settings.view_transform = "Standard"
    if engine == "WORKBENCH":
        scene.view_settings.exposure = look.exposure
        shading = scene.display.shading
        shading.light = "STUDIO"
        shading.color_type = "MATERIAL"
        shading.show_shadows = True
        shading.shadow_intensity = look.shadow_intensity
        shading.show_cavity = look.cavity is not None
        if look.cavity is not None:
            shading.cavity_type = look.cavity
            shading.curvature_valley_factor = look.valley_factor
        scene.display.render_aa = look.still_aa
        scene.display.light_direction = look.light_direction
        scene.display.shadow_focus = look.shadow_focus
        scene.display.shadow_shift = 0.1
    else:
        cycles = scene.cycles
        cycles.device = "CPU"
        cycles.samples = CYCLES_SAMPLES
        cycles.use_denoising = False
        cycles.seed = 0
        cycles.use_animated_seed = False
        world.use_nodes = True
        background = world.node_tree.nodes.get("Background")
        if background is not None:
            background.inputs["Color"].default_value = (*look.world_color, 1.0)
            background.inputs["Strength"].default_value = 0.8


def _floor(stage: bpy.types.Collection, centre: np.ndarray, size: float, z: float,
           color: tuple[float, float, float, float]) -> None:
    mesh = bpy.data.meshes.get("phyrogen_floor") or bpy.data.meshes.new("phyrogen_floor")
    if not mesh.vertices:
        mesh.from_pydata([(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)], [], [(0, 1, 2, 3)])
        material = bpy.data.materials.new("phyrogen_floor")
        material.use_nodes = True
        mesh.materials.append(material)
    material = mesh.materials[0]
    material.diffuse_color = color
    bsdf = material.node_tree.nodes.get("Principled BSDF")
    if bsdf is not None:
        bsdf.inputs["Base Color"].default_value = color
        bsdf.inputs["Roughness"].default_value = 0.9
    floor = bpy.data.objects.new("phyrogen_floor", mesh)
    floor.location = (float(centre[0]), float(centre[1]), z - 1e-3)
    floor.scale = (size, size, 1.0)
    stage.objects.link(floor)


def add_camera(scene: bpy.types.Scene, collection: bpy.types.Collection, view: View,
               bounds: tuple[np.ndarray, np.ndarray] | None = None) -> bpy.types.Object:
    """A camera looking along ``view`` that frames ``bounds`` (default: the puzzle's visual bounding box)."""
    low, high = bounds if bounds is not None else visual_bounds(collection)
    centre = (low + high) / 2
    radius = float(np.linalg.norm(high - low) / 2)
    stage = bpy.data.collections[STAGE]
    camera = bpy.data.objects.new(f"phyrogen_camera_{view.name}", bpy.data.cameras.new(f"camera_{view.name}"))
    stage.objects.link(camera)
    azimuth, elevation = math.radians(view.azimuth), math.radians(view.elevation)
    direction = np.array([math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth),
                          math.sin(elevation)])
    aspect = scene.render.resolution_x / scene.render.resolution_y
    data = camera.data
    data.clip_start = 0.01
    data.clip_end = 1000.0
    if view.elevation >= 89.0:
        data.type = "ORTHO"
        width, depth = float(high[0] - low[0]), float(high[1] - low[1])
        data.ortho_scale = 1.1 * max(width, depth * aspect, 0.5)
        distance = radius + 10.0
        rotation = Euler((0.0, 0.0, 0.0))
    else:
        data.lens_unit = "FOV"
        data.sensor_fit = "HORIZONTAL"
        data.angle = math.radians(40)
        rotation = Vector(tuple(-direction)).to_track_quat("-Z", "Y").to_euler()
        distance = _fitting_distance(low, high, centre, rotation, data.angle, aspect)
    camera.location = tuple(float(v) for v in centre + direction * distance)
    camera.rotation_euler = rotation
    return camera


def _fitting_distance(low: np.ndarray, high: np.ndarray, centre: np.ndarray, rotation: Euler,
                      horizontal_fov: float, aspect: float, margin: float = 1.08) -> float:
    """Distance from ``centre`` at which a perspective camera sees every corner of the box."""
    basis = np.array(rotation.to_matrix())  # columns: camera right, up, backwards
    tan_x = math.tan(horizontal_fov / 2)
    tan_y = tan_x / aspect
    distance = 0.0
    for corner in np.array(np.meshgrid(*zip(low, high, strict=True))).reshape(3, -1).T:
        x, y, z = (corner - centre) @ basis
        distance = max(distance, z + abs(x) * margin / tan_x, z + abs(y) * margin / tan_y)
    return distance


def render_views(scene: bpy.types.Scene, collection: bpy.types.Collection, folder: Path, name: str,
                 views: Sequence[str] = DEFAULT_VIEWS) -> list[Path]:
    """Render ``views`` to ``folder/<name>_NN.png`` (NN = position in ``views``)."""
    unknown = [v for v in views if v not in VIEWS]
    if unknown:
        raise ValueError(f"unknown views {unknown}; valid: {list(VIEWS)}")
    paths = []
    for index, view_name in enumerate(views):
        camera = add_camera(scene, collection, VIEWS[view_name])
        scene.camera = camera
        path = Path(folder) / image_name(name, index)
        scene.render.filepath = str(path)
        bpy.ops.render.render(write_still=True, scene=scene.name)
        paths.append(path)
    return paths


ANIMATION_SIZE = (320, 240)
ANIMATION_FPS = 10
"""Frames per second of the solution animation: each frame is most of its cost (about 50 ms of CPU in
Workbench on Mesa's software OpenGL), and at 320x240 10 frames a second show every action as smoothly as 12."""
ANIMATION_SECONDS = 4.0
"""The solution animation's moving part lasts about this long (each action at least 4 frames)."""
ANIMATION_HOLD_SECONDS = 1.0
"""The solved puzzle is held this long before the animation loops."""
WEBP_QUALITY = 75
ANIMATION_WORKBENCH_AA = "FXAA"
ANIMATION_CAVITY = False
"""The animation's frames leave the stills' cavity out: at 320x240 it cost 6 % more CPU a frame (the floor's
shadows cost nothing), and the small moving frames show it little."""
ANIMATION_CYCLES_SAMPLES = 4


def render_animation(scene: bpy.types.Scene, collection: bpy.types.Collection, path: Path,
                     frame_range: tuple[int, int], fps: int, keyed_frames: Sequence[float] = (),
                     view: str = GALLERY_VIEW, size: tuple[int, int] = ANIMATION_SIZE,
                     held_from: int | None = None) -> Path:
    """Render frames ``frame_range`` (inclusive) of the keyframed scene from ``view`` into an animated WebP.

    The camera frames every place the puzzle's objects pass through (sampled at
    ``keyed_frames`` and both ends of the range). ``held_from``: from this frame
    on nothing moves (the solved puzzle held), so it is rendered once and shown
    for the rest of the range. The render settings of the stills are restored afterwards.
    """
    import tempfile

    first, last = frame_range
    moving_last = last if held_from is None else max(first, min(last, held_from))
    lows, highs = [], []
    for frame in sorted({float(first), float(last), *map(float, keyed_frames)}):
        scene.frame_set(int(math.floor(frame)), subframe=frame - math.floor(frame))
        low, high = visual_bounds(collection)
        lows.append(low)
        highs.append(high)
    camera = add_camera(scene, collection, VIEWS[view], (np.min(lows, axis=0), np.max(highs, axis=0)))
    render = scene.render
    saved = (render.resolution_x, render.resolution_y, render.filepath, scene.camera, scene.frame_start,
             scene.frame_end, scene.frame_current, scene.display.render_aa, scene.cycles.samples,
             scene.display.shading.show_cavity)
    render.resolution_x, render.resolution_y = size
    # Small moving frames need less smoothing than stills: a third of the time, the same look.
    scene.display.render_aa = ANIMATION_WORKBENCH_AA
    scene.cycles.samples = ANIMATION_CYCLES_SAMPLES
    scene.display.shading.show_cavity = scene.display.shading.show_cavity and ANIMATION_CAVITY
    scene.camera = camera
    scene.frame_start, scene.frame_end = first, moving_last
    image = render.image_settings
    saved_format = image.file_format
    # Uncompressed frames: PNG's compression and decompression cost more than the
    # WebP encoding itself, for files that live a few seconds.
    image.file_format = "TARGA_RAW"
    try:
        with tempfile.TemporaryDirectory(prefix="phyrogen-frames-") as folder:
            render.filepath = str(Path(folder) / "frame_####")
            bpy.ops.render.render(animation=True, scene=scene.name)
            frames = sorted(Path(folder).glob("frame_*.tga"))
            if len(frames) != moving_last - first + 1:
                raise RuntimeError(f"rendering frames {first}..{moving_last} wrote {len(frames)} images")
            write_webp(frames, path, fps, last_frames=last - moving_last + 1)
    finally:
        image.file_format = saved_format
        render.resolution_x, render.resolution_y, render.filepath, scene.camera = saved[:4]
        scene.frame_start, scene.frame_end = saved[4:6]
        scene.frame_set(saved[6])
        scene.display.render_aa, scene.cycles.samples, scene.display.shading.show_cavity = saved[7:]
    return Path(path)


def write_webp(frames: Sequence[Path], path: Path, fps: int, quality: int = WEBP_QUALITY,
               last_frames: int = 1) -> Path:
    """An endlessly looping animated WebP of the images ``frames`` at ``fps`` (lossy, deterministic),
    the last image shown for ``last_frames`` frames."""
    from PIL import Image

    images = [Image.open(frame).convert("RGB") for frame in frames]
    frame_ms = round(1000 / fps)
    durations = [frame_ms] * (len(images) - 1) + [frame_ms * max(1, last_frames)]
    images[0].save(path, format="WEBP", save_all=True, append_images=images[1:], duration=durations,
                   loop=0, quality=quality, method=4, minimize_size=False, allow_mixed=False)
    return Path(path)

"""The panel's job operators Generate, Re-plan, Benchmark and Manipulate: each starts a ``phyrogen``
command (:mod:`.job_control`) and reads its ``--json`` result into the scene."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import bpy
from mathutils import Vector

from phyrogen_core.command_result import (
    read_benchmark_result,
    read_generate_result,
    read_manipulate_result,
    read_replan_result,
)
from phyrogen_core.folder import PuzzleFolder

from .job_control import OPERATIONS, Operation, first_run_note, job_operator
from .jobs import (
    Job,
    JobResult,
    ResultTable,
    benchmark_table,
    generate_table,
    manipulation_summary,
    manipulation_table,
    one_line_error,
    phyrogen_command,
    replan_table,
)
from .panel_settings import chosen_params, current_collection, output_folder, puzzle_folder


def remove_collection(collection: bpy.types.Collection) -> None:
    for obj in list(collection.all_objects):
        bpy.data.objects.remove(obj)
    for child in list(collection.children_recursive):
        bpy.data.collections.remove(child)
    bpy.data.collections.remove(collection)


def frame_in_views(context, collection: bpy.types.Collection) -> int:
    """Centre every 3D view of the window on the puzzle's visual objects, at a distance that shows them
    whole; how many views were framed (none in background mode). The selection stays as it was."""
    corners = [obj.matrix_world @ Vector(corner) for obj in collection.all_objects
               if obj.type == "MESH" and getattr(obj, "phobostype", "") == "visual" for corner in obj.bound_box]
    if not corners or context.window_manager is None:
        return 0
    low = Vector(tuple(min(c[i] for c in corners) for i in range(3)))
    high = Vector(tuple(max(c[i] for c in corners) for i in range(3)))
    radius = max((high - low).length / 2, 0.1)
    framed = 0
    for window in context.window_manager.windows:
        for area in window.screen.areas:
            if area.type != "VIEW_3D":
                continue
            space = area.spaces.active
            view = space.region_3d
            view.view_location = (low + high) / 2
            # The view's narrower field of view (35 mm sensor) must hold the bounding sphere, with a margin.
            half_angle = math.atan(18 / max(space.lens, 1.0))
            view.view_distance = 1.15 * radius / math.sin(half_angle)
            area.tag_redraw()
            framed += 1
    return framed


PHYROGEN_OT_generate = job_operator(
    "generate", "Generate",
    """Generate and certify the puzzle (phyrogen generate, in a subprocess), then build it in the scene""", undo=True)


def _start_generate(context) -> Job:
    settings = context.scene.phyrogen
    spec, params = chosen_params(settings)
    spec.check(settings.seed, params)
    return Job(f"Generate {spec.name}_{settings.seed}",
               generate_command(spec.name, settings.seed, params, output_folder(settings)), note=first_run_note())


def _finish_generate(context, result: JobResult) -> tuple[str, ResultTable]:
    from .scene import build_puzzle_folder

    settings = context.scene.phyrogen
    made = read_generate_result(result.stdout)
    if len(made.puzzles) != 1:
        raise ValueError(f"generate --json result: {len(made.puzzles)} puzzles, expected the one asked for")
    (puzzle,) = made.puzzles
    if puzzle.error is not None or puzzle.folder is None:
        raise RuntimeError(puzzle.error or "generate --json result: the puzzle has no folder")
    folder = Path(puzzle.folder)
    old = bpy.data.collections.get(folder.name)
    if old is not None:
        remove_collection(old)
    cube = remove_untouched_default_cube(context.scene)
    built = build_puzzle_folder(folder, context.scene)
    settings.puzzle = built.collection.name
    frame_in_views(context, built.collection)
    removed = "; Blender's untouched default cube removed (it hid the puzzle)" if cube else ""
    return f"{folder.name}: written to {folder}{removed}", generate_table(made)


FACTORY_OBJECTS = {"Cube": "MESH", "Camera": "CAMERA", "Light": "LIGHT"}
"""The objects of Blender's factory start-up scene."""


def remove_untouched_default_cube(scene) -> bool:
    """Remove Blender's default cube when the scene is the untouched factory scene, where the 2 m cube at the
    origin hides a puzzle built there; whether it was removed. Untouched: the file was never saved, the scene
    holds exactly the factory's Cube, Camera and Light, and the cube is the factory's (eight corners at 1 m,
    not moved, turned, scaled or modified). Any other object of a user's is never removed."""
    objects = {obj.name: obj for obj in scene.objects}
    if bpy.data.filepath or {name: obj.type for name, obj in objects.items()} != FACTORY_OBJECTS:
        return False
    cube = objects["Cube"]
    corners = sorted(tuple(round(c, 6) for c in v.co) for v in cube.data.vertices)
    factory = sorted((x, y, z) for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0))
    untouched = (corners == factory and len(cube.data.polygons) == 6 and not cube.modifiers
                 and tuple(cube.location) == (0, 0, 0) and tuple(cube.rotation_euler) == (0, 0, 0)
                 and tuple(cube.scale) == (1, 1, 1) and cube.parent is None and not cube.children)
    if not untouched:
        return False
    mesh = cube.data
    bpy.data.objects.remove(cube)
    if mesh.users == 0:
        bpy.data.meshes.remove(mesh)
    return True


def override_text(value) -> str:
    """A parameter's value as ``--set key=VALUE`` text that the registry converts back to the same value
    (``ring``, not ``'ring'``; ``true``; every digit of a float)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def generate_command(generator: str, seed: int, params, out: Path) -> list[str]:
    """``phyrogen generate`` of one puzzle with the panel's parameters, in the project's Python.

    A separate process keeps generation deterministic (OMPL is seeded once per
    process) and works inside a Blender binary, whose own Python lacks our dependencies.
    """
    overrides = [f"--set={f.name}={override_text(getattr(params, f.name))}" for f in dataclasses.fields(params)]
    return phyrogen_command("generate", "--generator", generator, "--seeds", str(seed), "--out", str(out),
                            "--workers", "1", *overrides)


def generate_folder(generator: str, seed: int, params, out: Path) -> Path:
    """Generate and certify a puzzle with ``phyrogen generate`` in the project's Python (waiting for it);
    its folder."""
    result = Job(f"Generate {generator}_{seed}", generate_command(generator, seed, params, out)).wait()
    if not result.ok:
        raise RuntimeError(one_line_error(result, "generation"))
    return PuzzleFolder.at(out, generator, f"{generator}_{seed}").path


PHYROGEN_OT_replan = job_operator(
    "replan", "Re-plan",
    """Export the puzzle as it is now (edited or not) and find a new certificate with OMPL's RRT-Connect
    (phyrogen replan, in a subprocess); the scene is rebuilt from the re-planned folder""", undo=True)


def _start_replan(context) -> Job:
    from .export import export_collection

    settings = context.scene.phyrogen
    collection = current_collection(context)
    folder = puzzle_folder(settings, collection).path
    export_collection(collection, folder)
    return Job(f"Re-plan {collection.name}", phyrogen_command("replan", str(folder)), note=first_run_note())


def _finish_replan(context, result: JobResult) -> tuple[str, ResultTable]:
    from .scene import build_puzzle_folder

    settings = context.scene.phyrogen
    replanned = read_replan_result(result.stdout)
    if not replanned.solved:
        raise RuntimeError(f"{replanned.puzzle}: not re-planned")
    folder = Path(replanned.folder)
    collection = bpy.data.collections.get(replanned.puzzle)
    if collection is not None:
        remove_collection(collection)
    built = build_puzzle_folder(folder, context.scene)
    settings.puzzle = built.collection.name
    return (f"{replanned.puzzle}: new certificate by {replanned.planner}, {replanned.states} states",
            replan_table(replanned))


PHYROGEN_OT_benchmark = job_operator(
    "benchmark", "Benchmark",
    """A quick benchmark of every planner on this puzzle (phyrogen benchmark --profile quick --until first,
    in a subprocess) into <output>/benchmark/<puzzle>; its summary is shown in the panel""")


def _written_puzzle(context) -> tuple[bpy.types.PropertyGroup, bpy.types.Collection, PuzzleFolder]:
    """The settings, the scene's puzzle and its folder, which must hold the puzzle (Benchmark and Manipulate
    run on the folder, not on the scene)."""
    settings = context.scene.phyrogen
    collection = current_collection(context)
    folder = puzzle_folder(settings, collection)
    if not folder.metadata.is_file():
        raise ValueError(f"{folder.path} holds no puzzle; press Generate or Export URDF first")
    return settings, collection, folder


def benchmark_folder(settings, collection) -> Path:
    """Where the panel's Benchmark writes: ``<output>/benchmark/<puzzle>``."""
    return output_folder(settings) / "benchmark" / collection.name


def _start_benchmark(context) -> Job:
    settings, collection, folder = _written_puzzle(context)
    return Job(f"Benchmark {collection.name}",
               phyrogen_command("benchmark", "--puzzles", str(folder.path), "--profile", "quick", "--until", "first",
                                "--out", str(benchmark_folder(settings, collection))), note=first_run_note())


def _finish_benchmark(context, result: JobResult) -> tuple[str, ResultTable]:
    made = read_benchmark_result(result.stdout)
    return f"{current_collection(context).name}: quick benchmark in {made.out}", benchmark_table(made)


PHYROGEN_OT_manipulate = job_operator(
    "manipulate", "Manipulate",
    """A KUKA iiwa executes the puzzle's best solution in PyBullet (phyrogen manipulate, DIRECT mode, in a
    subprocess) into <output>/manipulation/<puzzle>: frames, video, report""")


def manipulation_root(settings) -> Path:
    """Where the panel's Manipulate writes: ``<output>/manipulation`` (one folder per puzzle)."""
    return output_folder(settings) / "manipulation"


def _start_manipulate(context) -> Job:
    settings, collection, folder = _written_puzzle(context)
    return Job(f"Manipulate {collection.name}",
               phyrogen_command("manipulate", str(folder.path), "--out", str(manipulation_root(settings))),
               note=first_run_note())


def _finish_manipulate(context, result: JobResult) -> tuple[str, ResultTable]:
    settings = context.scene.phyrogen
    reports = read_manipulate_result(result.stdout).reports
    if len(reports) != 1:
        raise ValueError(f"manipulate --json result: {len(reports)} reports, expected the one puzzle's")
    (report,) = reports
    settings.manipulation_output = report.folder
    return manipulation_summary(report), manipulation_table(report)


_INSTALL = ("install the PhyRoGen zip that bundles it, or pip install it into PHYROGEN_VENV "
            "(pip install -e . in a checkout)")
OPERATIONS.update({
    "generate": Operation("Generate", _start_generate, _finish_generate),
    "replan": Operation("Re-plan", _start_replan, _finish_replan),
    "benchmark": Operation("Benchmark", _start_benchmark, _finish_benchmark, ("matplotlib",), _INSTALL),
    "manipulate": Operation("Manipulate", _start_manipulate, _finish_manipulate,
                            ("pybullet", "imageio", "imageio_ffmpeg"), _INSTALL),
})

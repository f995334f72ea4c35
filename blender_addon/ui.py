"""The sidebar panel, its settings and the operators Generate, Re-plan, Benchmark, Manipulate,
Validate, Export URDF, Render (and Export with Phobos, shown while the Phobos add-on is enabled).

The parameter fields are made from the registry: one property group per
generator, one property per field of its parameter dataclass, so a new
generator appears in the panel without touching this file.

Generate, Re-plan, Benchmark and Manipulate run ``phyrogen`` in a subprocess
(:mod:`.jobs`): pressed in the UI, a modal operator polls it from a timer, shows
its progress in the status bar and stops it on Esc, a right-click or Cancel,
so Blender never freezes; run from a script (``bpy.ops.phyrogen.generate()``)
they wait for it. Their outcome is stored on the scene's settings and drawn
in the panel. One such job runs at a time.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import math
import typing
from collections.abc import Callable
from pathlib import Path

import bpy
from mathutils import Vector

from phyrogen_core.folder import PuzzleFolder, name_problem
from phyrogen_core.registry import ParameterError, all_generators

from .environment import collision_kernels_cached
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
from .phobos import (
    PHOBOS_FOLDER,
    ensure_phobostype,
    forget_phobos_hooks,
    phobos_enabled,
    recognise_phobos_when_loaded,
    remove_phobostype,
)
from .text import wrap_lines

_PROPERTY_OF_TYPE = {bool: bpy.props.BoolProperty, int: bpy.props.IntProperty, float: bpy.props.FloatProperty,
                     str: bpy.props.StringProperty}


def editable_fields(params_type: type) -> list[dataclasses.Field]:
    """The fields of a parameter dataclass the panel can show (bool, int, float, str)."""
    hints = typing.get_type_hints(params_type)
    return [f for f in dataclasses.fields(params_type) if hints[f.name] in _PROPERTY_OF_TYPE]


def _parameter_group(name: str, params_type: type) -> type:
    hints = typing.get_type_hints(params_type)
    annotations = {f.name: _PROPERTY_OF_TYPE[hints[f.name]](name=f.name.replace("_", " ").capitalize(),
                                                            default=f.default,
                                                            description=str(f.metadata.get("doc", "")))
                   for f in editable_fields(params_type)}
    return type(f"PHYROGEN_PG_{name}", (bpy.types.PropertyGroup,), {"__annotations__": annotations})


class PHYROGEN_PG_result_row(bpy.types.PropertyGroup):  # noqa: N801 (Blender's naming)
    """One row of the last job's result table: its cells, tab-separated."""

    cells: bpy.props.StringProperty(name="Cells")


def _settings_class(groups: dict[str, type]) -> type:
    generators = all_generators()
    annotations = {
        "generator": bpy.props.EnumProperty(
            name="Generator",
            items=[(n, s.title, s.doc.splitlines()[0] if s.doc else "") for n, s in generators.items()]),
        "seed": bpy.props.IntProperty(name="Seed", default=1, min=1),
        "output": bpy.props.StringProperty(name="Output", default="output", subtype="DIR_PATH",
                                           description="Folder for exported puzzles and renders"),
        "engine": bpy.props.EnumProperty(name="Engine", items=[("WORKBENCH", "Workbench", "fast"),
                                                               ("CYCLES", "Cycles", "CPU path tracing")]),
        "puzzle": bpy.props.StringProperty(name="Puzzle", description="Collection of the current puzzle"),
        "job_status": bpy.props.StringProperty(name="Job", description="Progress of the running job"),
        "result_label": bpy.props.StringProperty(name="Last run", description="The last job that ended"),
        "result_state": bpy.props.EnumProperty(
            name="Outcome", items=[("NONE", "None", "no job has ended"), ("DONE", "Done", "finished"),
                                   ("FAILED", "Failed", "the command failed"),
                                   ("CANCELLED", "Cancelled", "stopped by the user")]),
        "result_message": bpy.props.StringProperty(name="Message", description="What the last job said"),
        "result_columns": bpy.props.StringProperty(name="Columns", description="Titles of the last job's "
                                                                               "result table, tab-separated"),
        "result_rows": bpy.props.CollectionProperty(type=PHYROGEN_PG_result_row, name="Result",
                                                    description="The last job's result table"),
        "result_row_index": bpy.props.IntProperty(name="Row", default=-1),
        "manipulation_output": bpy.props.StringProperty(
            name="Manipulation output", subtype="DIR_PATH",
            description="The last manipulation run's folder: frames/, the video, report.json"),
        "phobos_output": bpy.props.StringProperty(
            name="Phobos output", default="", subtype="DIR_PATH",
            description="Folder for Export with Phobos (the puzzle goes to <folder>/<puzzle>); "
                        "empty: the puzzle folder's phobos/"),
    }
    for name, group in groups.items():
        annotations[f"params_{name}"] = bpy.props.PointerProperty(type=group)
    return type("PHYROGEN_PG_settings", (bpy.types.PropertyGroup,), {"__annotations__": annotations})


def chosen_params(settings):
    """The selected generator's spec and its parameter dataclass, from the panel's fields."""
    spec = all_generators()[settings.generator]
    group = getattr(settings, f"params_{spec.name}")
    values = {f.name: _exact(getattr(group, f.name)) for f in editable_fields(spec.params)}
    return spec, spec.params(**values)


def _exact(value):
    # Blender keeps float properties in single precision: 0.15 comes back as 0.15000000596.
    # Seven significant digits give back the number that was typed.
    return float(f"{value:.7g}") if isinstance(value, float) else value


def current_collection(context) -> bpy.types.Collection:
    from .scene import puzzle_collections

    settings = context.scene.phyrogen
    collection = bpy.data.collections.get(settings.puzzle) if settings.puzzle else None
    if collection is None:
        found = puzzle_collections(context.scene)
        if not found:
            raise ValueError("the scene holds no puzzle; press Generate first")
        collection = found[-1]
    return collection


def _output(settings) -> Path:
    return _path(settings.output)


def _path(text: str) -> Path:
    # "//" means the .blend file's folder; an unsaved file has none, so the working folder stands in.
    if text.startswith("//"):
        return Path(bpy.path.abspath(text)) if bpy.data.filepath else Path(text[2:] or ".")
    return Path(text)


def puzzle_folder(settings, collection) -> PuzzleFolder:
    """The folder of the scene's puzzle under the panel's output folder."""
    from phyrogen_core.record import folder_identity

    _, generator, _ = folder_identity(json.loads(collection.get("phyrogen/metadata", "{}")), generator="scene")
    return PuzzleFolder.at(_output(settings), generator, collection.name)


def run_reported(operator: bpy.types.Operator, work: Callable[[], str]) -> set[str]:
    """Run an operator's work and report its message; bad input or a failed step is reported
    as an error (the operator is cancelled) instead of a traceback in the console."""
    try:
        message = work()
    except (ParameterError, ValueError, KeyError, OSError, RuntimeError) as exc:
        operator.report({"ERROR"}, str(exc))
        return {"CANCELLED"}
    operator.report({"INFO"}, message)
    return {"FINISHED"}


# -- jobs: work in a subprocess, watched by a modal operator -------------------------------------


@dataclasses.dataclass(frozen=True)
class Operation:
    """A panel operation run as a job: ``start`` does the quick work in Blender and starts the command,
    ``finish`` reads its outcome into the scene (on success) and returns the message and details."""

    label: str
    start: Callable[[bpy.types.Context], Job]
    finish: Callable[[bpy.types.Context, JobResult], tuple[str, ResultTable | None]]
    needs: tuple[str, ...] = ()
    """Modules the command imports beyond Generate's (the button is hidden, with a line, without them)."""
    install: str = ""
    """What to install when ``needs`` are missing."""


def missing_modules(operation: str) -> list[str]:
    """The modules ``operation``'s command needs that cannot be imported here (where the workers import
    them too: the bundled wheels, or the project's environment)."""
    return [name for name in OPERATIONS[operation].needs if importlib.util.find_spec(name) is None]


def first_run_note() -> str:
    """The status line while a job's numba kernels are not compiled yet (the first job after installing)."""
    return "" if collision_kernels_cached() else FIRST_RUN_NOTE


FIRST_RUN_NOTE = "compiling collision kernels (first run only: about 20 s of CPU time, minutes on a busy machine)..."
"""Measured (docs/blender-panel.md): Generate with numba's cache empty took 16 s of CPU (44 s of wall time at a
load of 8 on 2 cores) and 0.6 s with it; from a freshly installed zip 100 s and more at a load of 16."""


OPERATIONS: dict[str, Operation] = {}
"""Filled below: ``generate``, ``replan``, ``benchmark``, ``manipulate``."""
_running: list[tuple[str, Job]] = []  # at most one job at a time


def running_job() -> Job | None:
    """The job that runs now, or None."""
    return _running[0][1] if _running else None


def begin(context, operation: str) -> Job:
    """Start ``operation``'s job (bad input raises before any process starts)."""
    if _running:
        raise RuntimeError(f"{_running[0][1].label} is still running; wait for it or cancel it")
    missing = missing_modules(operation)
    if missing:
        spec = OPERATIONS[operation]
        raise RuntimeError(f"{spec.label} needs {', '.join(missing)}: {spec.install}")
    settings = context.scene.phyrogen
    job = OPERATIONS[operation].start(context)
    _running.append((operation, job))
    # The running form at once (it says how to cancel): a short job may end before the first poll.
    settings.job_status = job.status_text()
    return job


def advance(context) -> tuple[bool, str] | None:
    """Poll the running job: None while it runs (its progress then in the settings' ``job_status``),
    else whether it succeeded and its message, once :func:`conclude` has stored its outcome."""
    if not _running:
        return None
    operation, job = _running[0]
    result = job.poll()
    if result is None:
        context.scene.phyrogen.job_status = job.status_text()
        return None
    return conclude(context, operation, job, result)


def cancel_running() -> bool:
    """Ask the running job to stop; False when none runs."""
    job = running_job()
    if job is None:
        return False
    job.cancel()
    return True


def conclude(context, operation: str, job: Job, result: JobResult) -> tuple[bool, str]:
    """Store the outcome of ``job`` on the scene's settings: finished (after ``finish`` read it into the
    scene), failed (with the command's error line) or cancelled."""
    settings = context.scene.phyrogen
    _running.clear()
    settings.job_status = ""
    settings.result_label = job.label
    table: ResultTable | None = None
    if result.ok:
        try:
            message, table = OPERATIONS[operation].finish(context, result)
            state = "DONE"
        except (ParameterError, ValueError, KeyError, OSError, RuntimeError) as exc:
            message, state = f"{job.label} failed: {exc}", "FAILED"
    else:
        message, state = one_line_error(result, job.label), "CANCELLED" if result.cancelled else "FAILED"
    settings.result_state = state
    settings.result_message = message
    store_table(settings, table)
    return state == "DONE", message


def store_table(settings, table: ResultTable | None) -> None:
    """The result table into the settings (drawn as a UI list), or none."""
    settings.result_rows.clear()
    settings.result_columns = "\t".join(table.columns) if table is not None else ""
    for row in table.rows if table is not None else ():
        settings.result_rows.add().cells = "\t".join(row)
    settings.result_row_index = -1


def result_table(settings) -> ResultTable | None:
    """The stored result table (:func:`store_table`)."""
    if not settings.result_columns:
        return None
    return ResultTable(tuple(settings.result_columns.split("\t")),
                       tuple(tuple(row.cells.split("\t")) for row in settings.result_rows))


class _JobOperator:
    """An operator whose work is a job: modal when pressed in the UI, blocking from a script."""

    operation = ""
    bl_options = {"REGISTER"}

    @classmethod
    def poll(cls, context):
        return running_job() is None

    def execute(self, context):
        def work() -> str:
            begin(context, self.operation)
            _, job = _running[0]
            ok, message = conclude(context, self.operation, job, job.wait())
            if not ok:
                raise RuntimeError(message)
            return message

        return run_reported(self, work)

    def invoke(self, context, event):
        if context.window is None:  # no window to watch it from (background mode)
            return self.execute(context)
        try:
            job = begin(context, self.operation)
        except (ParameterError, ValueError, KeyError, OSError, RuntimeError) as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self._timer = context.window_manager.event_timer_add(0.25, window=context.window)
        context.window_manager.modal_handler_add(self)
        _show_status(context, job.status_text())
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        job = running_job()
        if job is not None and event.type in {"ESC", "RIGHTMOUSE"} and event.value == "PRESS":
            job.cancel()
            _show_status(context, job.status_text())
            return {"RUNNING_MODAL"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}  # the UI stays usable while the job runs
        outcome = advance(context)
        if outcome is None and job is not None:
            _show_status(context, job.status_text())
            return {"PASS_THROUGH"}
        context.window_manager.event_timer_remove(self._timer)
        _show_status(context, None)
        # Redrawn once more after this operator has returned, so that the job buttons are back at once.
        bpy.app.timers.register(_redraw_everything, first_interval=0.05)
        ok, message = outcome if outcome is not None else (False, "the job was lost")
        self.report({"INFO"} if ok else {"WARNING"} if "cancelled" in message else {"ERROR"}, message)
        return {"FINISHED"} if ok else {"CANCELLED"}


def _show_status(context, text: str | None) -> None:
    if context.workspace is not None:
        context.workspace.status_text_set(text)
    _redraw_everything()


def _redraw_everything() -> None:
    """Tag every area of every window for redrawing (the panel, the status bar); as a timer, once."""
    manager = bpy.context.window_manager
    for window in manager.windows if manager is not None else ():
        for area in window.screen.areas:
            area.tag_redraw()
    return None


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


class PHYROGEN_OT_generate(_JobOperator, bpy.types.Operator):  # noqa: N801 (Blender's naming)
    """Generate and certify the puzzle (phyrogen generate, in a subprocess), then build it in the scene"""

    bl_idname = "phyrogen.generate"
    bl_label = "Generate"
    bl_options = {"REGISTER", "UNDO"}
    operation = "generate"


def _start_generate(context) -> Job:
    settings = context.scene.phyrogen
    spec, params = chosen_params(settings)
    spec.check(settings.seed, params)
    return Job(f"Generate {spec.name}_{settings.seed}",
               generate_command(spec.name, settings.seed, params, _output(settings)), note=first_run_note())


def _finish_generate(context, result: JobResult) -> tuple[str, ResultTable]:
    from .scene import build_puzzle_folder

    settings = context.scene.phyrogen
    made = result.json()
    (puzzle,) = made["puzzles"]
    if puzzle.get("error"):
        raise RuntimeError(puzzle["error"])
    folder = Path(puzzle["folder"])
    old = bpy.data.collections.get(folder.name)
    if old is not None:
        _remove_collection(old)
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


class PHYROGEN_OT_replan(_JobOperator, bpy.types.Operator):  # noqa: N801
    """Export the puzzle as it is now (edited or not) and find a new certificate with OMPL's RRT-Connect
    (phyrogen replan, in a subprocess); the scene is rebuilt from the re-planned folder"""

    bl_idname = "phyrogen.replan"
    bl_label = "Re-plan"
    bl_options = {"REGISTER", "UNDO"}
    operation = "replan"


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
    replanned = result.json()
    folder = Path(replanned["folder"])
    collection = bpy.data.collections.get(replanned["puzzle"])
    if collection is not None:
        _remove_collection(collection)
    built = build_puzzle_folder(folder, context.scene)
    settings.puzzle = built.collection.name
    return (f"{replanned['puzzle']}: new certificate by {replanned['planner']}, {replanned['states']} states",
            replan_table(replanned))


class PHYROGEN_OT_benchmark(_JobOperator, bpy.types.Operator):  # noqa: N801
    """A quick benchmark of every planner on this puzzle (phyrogen benchmark --profile quick --until first,
    in a subprocess) into <output>/benchmark/<puzzle>; its summary is shown in the panel"""

    bl_idname = "phyrogen.benchmark"
    bl_label = "Benchmark"
    operation = "benchmark"


def benchmark_folder(settings, collection) -> Path:
    """Where the panel's Benchmark writes: ``<output>/benchmark/<puzzle>``."""
    return _output(settings) / "benchmark" / collection.name


def _start_benchmark(context) -> Job:
    settings = context.scene.phyrogen
    collection = current_collection(context)
    folder = puzzle_folder(settings, collection)
    if not folder.metadata.is_file():
        raise ValueError(f"{folder.path} holds no puzzle; press Generate or Export URDF first")
    return Job(f"Benchmark {collection.name}",
               phyrogen_command("benchmark", "--puzzles", str(folder.path), "--profile", "quick", "--until", "first",
                                "--out", str(benchmark_folder(settings, collection))), note=first_run_note())


def _finish_benchmark(context, result: JobResult) -> tuple[str, ResultTable]:
    made = result.json()
    return f"{current_collection(context).name}: quick benchmark in {made['out']}", benchmark_table(made)


class PHYROGEN_OT_manipulate(_JobOperator, bpy.types.Operator):  # noqa: N801
    """A KUKA iiwa executes the puzzle's best solution in PyBullet (phyrogen manipulate, DIRECT mode, in a
    subprocess) into <output>/manipulation/<puzzle>: frames, video, report"""

    bl_idname = "phyrogen.manipulate"
    bl_label = "Manipulate"
    operation = "manipulate"


def manipulation_root(settings) -> Path:
    """Where the panel's Manipulate writes: ``<output>/manipulation`` (one folder per puzzle)."""
    return _output(settings) / "manipulation"


def _start_manipulate(context) -> Job:
    settings = context.scene.phyrogen
    collection = current_collection(context)
    folder = puzzle_folder(settings, collection)
    if not folder.metadata.is_file():
        raise ValueError(f"{folder.path} holds no puzzle; press Generate or Export URDF first")
    return Job(f"Manipulate {collection.name}",
               phyrogen_command("manipulate", str(folder.path), "--out", str(manipulation_root(settings))),
               note=first_run_note())


def _finish_manipulate(context, result: JobResult) -> tuple[str, ResultTable]:
    settings = context.scene.phyrogen
    (report,) = result.json()["reports"]
    settings.manipulation_output = report["folder"]
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


class PHYROGEN_OT_cancel_job(bpy.types.Operator):  # noqa: N801
    """Stop the running job (its whole process group); what it finished is kept, nothing half-written"""

    bl_idname = "phyrogen.cancel_job"
    bl_label = "Cancel"

    @classmethod
    def poll(cls, context):
        return running_job() is not None

    def execute(self, context):
        cancel_running()
        return {"FINISHED"}


class PHYROGEN_OT_open_manipulation(bpy.types.Operator):  # noqa: N801
    """Open the last manipulation run's video, or its frames folder, with the system's viewer"""

    bl_idname = "phyrogen.open_manipulation"
    bl_label = "Open"

    what: bpy.props.EnumProperty(items=[("VIDEO", "Video", "the run's MP4"),
                                        ("FRAMES", "Frames", "the folder of the run's frames")])

    @classmethod
    def poll(cls, context):
        return bool(context.scene.phyrogen.manipulation_output)

    def execute(self, context):
        path = manipulation_path(context.scene.phyrogen, self.what)
        if not path.exists():
            self.report({"ERROR"}, f"{path} does not exist (run Manipulate again)")
            return {"CANCELLED"}
        return bpy.ops.wm.path_open(filepath=str(path))


def manipulation_path(settings, what: str) -> Path:
    """The last manipulation run's video (``VIDEO``) or frames folder (``FRAMES``)."""
    out = Path(settings.manipulation_output)
    return out / f"{out.name}.mp4" if what == "VIDEO" else out / "frames"


def _remove_collection(collection: bpy.types.Collection) -> None:
    for obj in list(collection.all_objects):
        bpy.data.objects.remove(obj)
    for child in list(collection.children_recursive):
        bpy.data.collections.remove(child)
    bpy.data.collections.remove(collection)


class PHYROGEN_OT_validate(bpy.types.Operator):  # noqa: N801
    """Check the puzzle's solution certificate against the scene as it is now"""

    bl_idname = "phyrogen.validate"
    bl_label = "Validate"

    def execute(self, context):
        return run_reported(self, lambda: self.validate(context))

    @staticmethod
    def validate(context) -> str:
        from phyrogen_core.record import PuzzleRecord

        from . import annotations as keys
        from .scene import read_chain

        verify_certificate = checker()
        collection = current_collection(context)
        if keys.METADATA not in collection:
            raise ValueError(f"{collection.name!r} keeps no puzzle.json: nothing to validate against")
        record = PuzzleRecord.from_json(collection[keys.METADATA], f"{collection.name}: puzzle.json")
        chain = read_chain(collection)
        problems = verify_certificate(chain, record.certificate, record.goal)
        if problems:
            raise ValueError(f"{collection.name}: INVALID: " + "; ".join(problems))
        return f"{collection.name}: certificate valid ({len(record.certificate)} states)"


def checker() -> Callable:
    """The solver's certificate check, imported in Blender's own process (Validate runs no job), or a
    RuntimeError of one line when it cannot be: another add-on's packages may shadow ours there, as
    Phobos's NumPy 2.x does when its requirements are installed without a pin (Numba refuses it)."""
    try:
        from solver.planning.problem import verify_certificate
    except ImportError as exc:
        import numpy

        problem = " ".join(str(exc).split())
        raise RuntimeError(f"Validate cannot load PhyRoGen's checker in this Blender: {problem} (NumPy "
                           f"{numpy.__version__} from {Path(numpy.__file__).parent.parent}); install NumPy below 2 "
                           "there, e.g. with scripts/install_phobos.py (docs/blender.md)") from None
    return verify_certificate


class PHYROGEN_OT_export_urdf(bpy.types.Operator):  # noqa: N801
    """Write the puzzle in the scene to its folder: URDF, SRDF, meshes and puzzle.json (other files stay)"""

    bl_idname = "phyrogen.export_urdf"
    bl_label = "Export URDF"

    def execute(self, context):
        from .export import export_collection

        def export() -> str:
            collection = current_collection(context)
            notices: list[str] = []  # a changed puzzle's old renders and solutions moved aside
            urdf = export_collection(collection, puzzle_folder(context.scene.phyrogen, collection).path, notices)
            return "; ".join([f"wrote {urdf}", *notices])

        return run_reported(self, export)


class PHYROGEN_OT_export_phobos(bpy.types.Operator):  # noqa: N801
    """Export the puzzle in the scene with Phobos (URDF, OBJ meshes) into the puzzle folder's phobos/
    (or the Phobos output folder's <puzzle>/)"""

    bl_idname = "phyrogen.export_phobos"
    bl_label = "Export with Phobos"

    @classmethod
    def poll(cls, context):
        return phobos_enabled()

    def execute(self, context):
        from .phobos import export_with_phobos

        def export() -> str:
            collection = current_collection(context)
            urdf = export_with_phobos(collection, phobos_folder(context.scene.phyrogen, collection))
            return f"Phobos wrote {urdf}"

        return run_reported(self, export)


def phobos_folder(settings, collection) -> Path:
    """Where Export with Phobos writes (replacing it): the chosen folder's ``<puzzle>/``, else the puzzle
    folder's ``phobos/`` (an entry of the interop stage, see ``phyrogen_core.folder``)."""
    if settings.phobos_output:
        problem = name_problem(collection.name)
        if problem is not None:
            raise ValueError(f"{collection.name!r} cannot name a folder: it {problem}")
        return _path(settings.phobos_output) / collection.name
    return puzzle_folder(settings, collection).path / PHOBOS_FOLDER


class PHYROGEN_OT_render(bpy.types.Operator):  # noqa: N801
    """Render the puzzle's views into <output>/<generator>/<puzzle>/images"""

    bl_idname = "phyrogen.render"
    bl_label = "Render"

    def execute(self, context):
        return run_reported(self, lambda: self.render(context))

    @staticmethod
    def render(context) -> str:
        from phyrogen_core.folder import Stage, owned_directory, stage_owns

        from .render import render_views, setup_stage
        from .views import STILL_SIZE

        settings = context.scene.phyrogen
        collection = current_collection(context)
        setup_stage(context.scene, collection, settings.engine, STILL_SIZE)
        # Only the render stage's own images are replaced; a user's file in images/ stays.
        owns = lambda path: stage_owns(Stage.RENDER, collection.name, f"images/{path}")  # noqa: E731
        with owned_directory(puzzle_folder(settings, collection).images, owns) as folder:
            paths = render_views(context.scene, collection, folder, collection.name)
        return f"rendered {len(paths)} views of {collection.name}"


class PHYROGEN_UL_results(bpy.types.UIList):  # noqa: N801 (Blender's naming)
    """The last job's result table, one row per item (the columns' titles are drawn above it)."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0, flt_flag=0):
        draw_cells(layout, item.cells.split("\t"))


def draw_cells(layout, cells) -> None:
    """A table row: the first cell (a name) takes half the width, the others share the rest."""
    split = layout.split(factor=0.5)
    split.label(text=cells[0] if cells else "")
    row = split.row()
    for cell in cells[1:]:
        row.label(text=cell)


class PHYROGEN_PT_panel(bpy.types.Panel):  # noqa: N801
    bl_label = "PhyRoGen"
    bl_idname = "PHYROGEN_PT_panel"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "PhyRoGen"

    def draw(self, context):
        # Labels do not wrap: the job's message is wrapped to about as many characters as fit.
        # At most 7 pixels a character of the default font (5.5 on average in the panel's messages, measured
        # in Blender 3.4's screenshots), less the box's margins, the tab column and an icon.
        characters = int(context.region.width / (7 * context.preferences.system.ui_scale)) - 5
        draw_panel(self.layout, context.scene.phyrogen, width=max(characters, 20))


def draw_panel(layout, settings, phobos: bool | None = None, width: int = 60) -> None:
    """The panel's content (a function of the settings, so a test can draw it into a fake layout);
    ``phobos``: whether to show Export with Phobos, by default while the Phobos add-on is enabled;
    ``width``: characters per line of the job's message.

    Every field's name is a label of its own above the field: beside it, in the sidebar's default
    width, names were cut ("Gene..."). Buttons are one per row for the same reason. While a job runs,
    its progress and Cancel take the job buttons' place: Blender keeps drawing a clicked button that
    its operator disabled greyed until the pointer leaves it, so the buttons are not drawn disabled
    but left out, and come back enabled when the job ends."""
    _labelled(layout, settings, "generator", "Generator")
    layout.prop(settings, "seed")
    if running_job() is not None:
        draw_job(layout, settings, width)
    else:
        row = layout.row()
        row.scale_y = 1.6
        row.operator("phyrogen.generate", icon="MOD_BUILD")
        column = layout.column(align=True)
        column.scale_y = 1.2
        column.operator("phyrogen.replan", icon="FILE_REFRESH")
        for operation, icon in (("benchmark", "TIME"), ("manipulate", "ARMATURE_DATA")):
            missing = missing_modules(operation)
            if missing:  # hidden, with one line saying what to install
                column.label(text=f"{OPERATIONS[operation].label} needs {', '.join(missing)}", icon="INFO")
            else:
                column.operator(f"phyrogen.{operation}", icon=icon)
    column = layout.column(align=True)
    column.operator("phyrogen.validate", icon="CHECKMARK")
    column.operator("phyrogen.export_urdf", icon="EXPORT")
    column.operator("phyrogen.render", icon="RENDER_STILL")
    if running_job() is None:
        draw_job(layout, settings, width)
    spec = all_generators()[settings.generator]
    box = layout.box()
    box.label(text=f"{spec.title} parameters")
    group = getattr(settings, f"params_{spec.name}")
    for field in editable_fields(spec.params):
        box.prop(group, field.name)
    _labelled(layout, settings, "output", "Output folder")
    _labelled(layout, settings, "engine", "Render engine")
    show_phobos = phobos_enabled() if phobos is None else phobos
    if show_phobos:
        box = layout.box()
        box.operator("phyrogen.export_phobos", icon="EXPORT")
        _labelled(box, settings, "phobos_output", "Phobos output (empty: the puzzle's phobos/)")


def _labelled(layout, data, name: str, text: str) -> None:
    """A field with its name on the line above."""
    column = layout.column(align=True)
    column.label(text=text)
    column.prop(data, name, text="")


def draw_job(layout, settings, width: int = 60) -> None:
    """The running job's progress and a Cancel button, else the last job's outcome: a line, its message
    (wrapped at ``width`` characters) and its result table as a UI list."""
    if running_job() is not None:
        box = layout.box()
        for index, part in enumerate(wrap_lines(settings.job_status or "running", width, "  ") or ["running"]):
            box.label(text=part, icon="SORTTIME" if index == 0 else "NONE")
        box.operator("phyrogen.cancel_job", icon="CANCEL")
        return
    if settings.result_state == "NONE":
        return
    box = layout.box()
    icon = {"DONE": "CHECKMARK", "FAILED": "ERROR", "CANCELLED": "CANCEL"}[settings.result_state]
    state = {"DONE": "done", "FAILED": "failed", "CANCELLED": "cancelled"}[settings.result_state]
    box.label(text=f"{settings.result_label.split(' ')[0]}: {state}", icon=icon)  # the message names the puzzle
    for part in wrap_lines(settings.result_message, width, "  "):
        box.label(text=part)
    table = result_table(settings)
    if table is not None and table.rows:
        if len(table.columns) == 2:  # a title and a name (Puzzle, simple_slider_1): the name gets the whole width
            for part in wrap_lines(": ".join(table.columns), width, "  "):
                box.label(text=part)
        else:
            draw_cells(box, table.columns)
        box.template_list("PHYROGEN_UL_results", "", settings, "result_rows", settings, "result_row_index",
                          rows=min(max(len(table.rows), 1), 5))
    if settings.result_label.startswith("Manipulate") and settings.manipulation_output:
        row = box.row(align=True)
        row.operator("phyrogen.open_manipulation", text="Video", icon="FILE_MOVIE").what = "VIDEO"
        row.operator("phyrogen.open_manipulation", text="Frames", icon="FILE_FOLDER").what = "FRAMES"


_OPERATORS = (PHYROGEN_UL_results,
              PHYROGEN_OT_generate, PHYROGEN_OT_replan, PHYROGEN_OT_benchmark, PHYROGEN_OT_manipulate,
              PHYROGEN_OT_cancel_job, PHYROGEN_OT_open_manipulation, PHYROGEN_OT_validate, PHYROGEN_OT_export_urdf,
              PHYROGEN_OT_export_phobos,
              PHYROGEN_OT_render, PHYROGEN_PT_panel)
_registered: list[type] = []


def register() -> None:
    ensure_phobostype()
    groups = {name: _parameter_group(name, spec.params) for name, spec in all_generators().items()}
    settings = _settings_class(groups)
    classes = [*groups.values(), PHYROGEN_PG_result_row, settings, *_OPERATORS]
    for cls in classes:
        bpy.utils.register_class(cls)
        _registered.append(cls)
    bpy.types.Scene.phyrogen = bpy.props.PointerProperty(type=settings)
    recognise_phobos_when_loaded()


def unregister() -> None:
    cancel_running()
    if hasattr(bpy.types.Scene, "phyrogen"):
        del bpy.types.Scene.phyrogen
    while _registered:
        bpy.utils.unregister_class(_registered.pop())
    forget_phobos_hooks()
    remove_phobostype()

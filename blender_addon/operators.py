"""The panel's operators that run in Blender's own process: Validate, Export URDF, Export with Phobos,
Render, and the job buttons Cancel and Open (the last manipulation run's video or frames)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import bpy

from phyrogen_core.folder import name_problem

from .job_control import cancel_running, run_reported, running_job
from .panel_settings import current_collection, panel_path, puzzle_folder
from .phobos import PHOBOS_FOLDER, phobos_enabled


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


class InBlender:
    """An operator whose ``work`` runs in Blender's own process and returns its message, which is reported;
    bad input or a failed step is reported as an error (the operator is cancelled) instead of a traceback."""

    @staticmethod
    def work(context) -> str:
        raise NotImplementedError

    def execute(self, context):
        return run_reported(self, lambda: self.work(context))


class PHYROGEN_OT_validate(InBlender, bpy.types.Operator):  # noqa: N801
    """Check the puzzle's solution certificate against the scene as it is now"""

    bl_idname = "phyrogen.validate"
    bl_label = "Validate"

    @staticmethod
    def work(context) -> str:
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


class PHYROGEN_OT_export_urdf(InBlender, bpy.types.Operator):  # noqa: N801
    """Write the puzzle in the scene to its folder: URDF, SRDF, meshes and puzzle.json (other files stay)"""

    bl_idname = "phyrogen.export_urdf"
    bl_label = "Export URDF"

    @staticmethod
    def work(context) -> str:
        from .export import export_collection

        collection = current_collection(context)
        notices: list[str] = []  # a changed puzzle's old renders and solutions moved aside
        urdf = export_collection(collection, puzzle_folder(context.scene.phyrogen, collection).path, notices)
        return "; ".join([f"wrote {urdf}", *notices])


class PHYROGEN_OT_export_phobos(InBlender, bpy.types.Operator):  # noqa: N801
    """Export the puzzle in the scene with Phobos (URDF, OBJ meshes) into the puzzle folder's phobos/
    (or the Phobos output folder's <puzzle>/)"""

    bl_idname = "phyrogen.export_phobos"
    bl_label = "Export with Phobos"

    @classmethod
    def poll(cls, context):
        return phobos_enabled()

    @staticmethod
    def work(context) -> str:
        from .phobos import export_with_phobos

        collection = current_collection(context)
        urdf = export_with_phobos(collection, phobos_folder(context.scene.phyrogen, collection))
        return f"Phobos wrote {urdf}"


def phobos_folder(settings, collection) -> Path:
    """Where Export with Phobos writes (replacing it): the chosen folder's ``<puzzle>/``, else the puzzle
    folder's ``phobos/`` (an entry of the interop stage, see ``phyrogen_core.folder``)."""
    if settings.phobos_output:
        problem = name_problem(collection.name)
        if problem is not None:
            raise ValueError(f"{collection.name!r} cannot name a folder: it {problem}")
        return panel_path(settings.phobos_output) / collection.name
    return puzzle_folder(settings, collection).path / PHOBOS_FOLDER


class PHYROGEN_OT_render(InBlender, bpy.types.Operator):  # noqa: N801
    """Render the puzzle's views into <output>/<generator>/<puzzle>/images"""

    bl_idname = "phyrogen.render"
    bl_label = "Render"

    @staticmethod
    def work(context) -> str:
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

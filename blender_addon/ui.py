"""The PhyRoGen sidebar panel's registration, and the names scripts and tests use from it.

The panel offers Generate, Re-plan, Benchmark, Manipulate, Validate, Export URDF, Render (and Export
with Phobos, shown while the Phobos add-on is enabled). Its parts, one module each:

- :mod:`.panel_settings`: the settings (one property group per generator, made from the registry, so
  a new generator appears in the panel without touching the add-on) and what they point to;
- :mod:`.job_control`: jobs, ``phyrogen`` commands run in a subprocess (:mod:`.jobs`) that a modal
  operator polls from a timer, showing progress in the status bar and stopping them on Esc, a
  right-click or Cancel, so Blender never freezes (run from a script, ``bpy.ops.phyrogen.generate()``,
  they wait); one job runs at a time, its outcome stored on the scene's settings;
- :mod:`.job_operators`: Generate, Re-plan, Benchmark and Manipulate, each reading its command's
  ``--json`` result into the scene;
- :mod:`.operators`: Validate, Export URDF, Export with Phobos, Render (in Blender's own process),
  Cancel and Open;
- :mod:`.panel`: the panel's drawing.
"""

from __future__ import annotations

import bpy

from phyrogen_core.registry import all_generators

from .job_control import (  # noqa: F401 (the panel's API, used by scripts and tests)
    OPERATIONS,
    Operation,
    advance,
    begin,
    cancel_running,
    first_run_note,
    missing_modules,
    result_table,
)
from .job_operators import (  # noqa: F401
    PHYROGEN_OT_benchmark,
    PHYROGEN_OT_generate,
    PHYROGEN_OT_manipulate,
    PHYROGEN_OT_replan,
    generate_command,
    generate_folder,
    override_text,
    remove_untouched_default_cube,
)
from .operators import (  # noqa: F401
    PHYROGEN_OT_cancel_job,
    PHYROGEN_OT_export_phobos,
    PHYROGEN_OT_export_urdf,
    PHYROGEN_OT_open_manipulation,
    PHYROGEN_OT_render,
    PHYROGEN_OT_validate,
    manipulation_path,
)
from .panel import PHYROGEN_PT_panel, PHYROGEN_UL_results, draw_panel  # noqa: F401
from .panel_settings import (  # noqa: F401
    PHYROGEN_PG_result_row,
    chosen_params,
    editable_fields,
    parameter_group,
    settings_class,
)
from .phobos import ensure_phobostype, forget_phobos_hooks, recognise_phobos_when_loaded, remove_phobostype

_OPERATORS = (PHYROGEN_UL_results,
              PHYROGEN_OT_generate, PHYROGEN_OT_replan, PHYROGEN_OT_benchmark, PHYROGEN_OT_manipulate,
              PHYROGEN_OT_cancel_job, PHYROGEN_OT_open_manipulation, PHYROGEN_OT_validate, PHYROGEN_OT_export_urdf,
              PHYROGEN_OT_export_phobos,
              PHYROGEN_OT_render, PHYROGEN_PT_panel)
_registered: list[type] = []


def register() -> None:
    ensure_phobostype()
    groups = {name: parameter_group(name, spec.params) for name, spec in all_generators().items()}
    settings = settings_class(groups)
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

"""The panel's jobs: work in a subprocess (:mod:`.jobs`), watched by a modal operator.

Pressed in the UI, a job operator polls its job from a timer, shows its progress in the status bar and
stops it on Esc, a right-click or Cancel, so Blender never freezes; run from a script
(``bpy.ops.phyrogen.generate()``) it waits for it. The outcome is stored on the scene's settings and
drawn in the panel. One such job runs at a time. The operations themselves are in :mod:`.job_operators`.
"""

from __future__ import annotations

import dataclasses
import importlib.util
from collections.abc import Callable

import bpy

from phyrogen_core.registry import ParameterError

from .environment import collision_kernels_cached
from .jobs import Job, JobResult, ResultTable, one_line_error


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


class JobOperator:
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


def job_operator(operation: str, label: str, doc: str, undo: bool = False) -> type:
    """The operator ``phyrogen.<operation>`` (class ``PHYROGEN_OT_<operation>``) that runs ``operation``'s
    job; ``doc`` is its tooltip, ``undo`` whether its result in the scene can be undone."""
    return type(f"PHYROGEN_OT_{operation}", (JobOperator, bpy.types.Operator),
                {"__doc__": doc, "bl_idname": f"phyrogen.{operation}", "bl_label": label, "operation": operation,
                 "bl_options": {"REGISTER", "UNDO"} if undo else {"REGISTER"}})


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

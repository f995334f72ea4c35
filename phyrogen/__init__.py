"""PhyRoGen's public Python API and the ``phyrogen`` command line: the top layer.

A thin facade over the layers below it (``phyrogen_core`` <- ``solver`` <-
``blender_addon``, ``manipulation``); each function imports its layer when
called, so ``import phyrogen`` needs neither Blender nor PyBullet::

    import phyrogen

    phyrogen.generators()                                   # name -> GeneratorSpec
    puzzle = phyrogen.generate("grid_world", seed=7, n_objects=4)
    folder = phyrogen.generate_into("output", "grid_world", seed=7)
    loaded = phyrogen.load(folder)                          # chain, start, goal, certificate
    assert phyrogen.check(folder) == []                     # problems with its certificate
    for puzzle_folder in phyrogen.find_puzzles("output"): ...

Every job is also a stage: one function ``run(request) -> result`` over the typed,
versioned records of :mod:`phyrogen_core.stage_records` (``phyrogen.stages``)::

    result = phyrogen.run(phyrogen.CheckRequest("output/grid_world/grid_world_7"))
    result.valid, result.problems, result.to_json()

Generation runs in worker processes that never run the caller's script
again, so these calls work at the top level of a plain ``python script.py``
as well as under an ``if __name__ == "__main__":`` guard
(``docs/examples/generate_from_script.py``); only a generator that the
script registers itself makes the workers run it again, to have it, and
then the guard is needed. Bad arguments (an unknown generator or
parameter, a value out of its bounds, a bad seed, an ``out`` that cannot be
written) raise :class:`ValueError` naming the value, before
any process starts; a puzzle the Maker cannot build raises
:class:`phyrogen_core.maker.GenerationError`.
"""

from __future__ import annotations

# First: in the command's process, Ctrl-C during the imports below gives the command's one line.
from . import startup  # noqa: F401

# isort: split
from pathlib import Path
from typing import Any

from phyrogen.stage_checks import check_generation
from phyrogen.stages import STAGES, run
from phyrogen_core import __version__
from phyrogen_core.folder import PuzzleFolder, find_puzzle_folders
from phyrogen_core.stage_records.audit import AuditRequest, AuditResult
from phyrogen_core.stage_records.benchmark import BenchmarkRequest, BenchmarkResult
from phyrogen_core.stage_records.certify import CertifyRequest, CertifyResult
from phyrogen_core.stage_records.check import CheckRequest, CheckResult
from phyrogen_core.stage_records.dataset import DatasetRequest, DatasetResult
from phyrogen_core.stage_records.export import ExportRequest, ExportResult
from phyrogen_core.stage_records.generate import GenerateRequest, GenerateResult
from phyrogen_core.stage_records.import_urdf import ImportRequest, ImportResult
from phyrogen_core.stage_records.manipulate import ManipulateRequest, ManipulateResult
from phyrogen_core.stage_records.render import RenderRequest, RenderResult
from phyrogen_core.stage_records.replan import ReplanRequest, ReplanResult

__all__ = ["STAGES", "AuditRequest", "AuditResult", "BenchmarkRequest", "BenchmarkResult", "CertifyRequest",
           "CertifyResult", "CheckRequest", "CheckResult", "DatasetRequest", "DatasetResult", "ExportRequest",
           "ExportResult", "GenerateRequest", "GenerateResult", "ImportRequest", "ImportResult", "ManipulateRequest",
           "ManipulateResult", "PuzzleFolder", "RenderRequest", "RenderResult", "ReplanRequest", "ReplanResult",
           "__version__", "check", "find_puzzles", "generate", "generate_into", "generators", "load", "run"]


def generators() -> dict:
    """The registered generators by name (:class:`phyrogen_core.registry.GeneratorSpec`)."""
    from phyrogen_core.registry import all_generators

    return all_generators()


def generate(generator: str, seed: int, **params: Any):
    """One certified :class:`phyrogen_core.puzzle.Puzzle`, generated deterministically in a fresh
    process; ``params`` override the generator's defaults (``phyrogen list`` shows them)."""
    from solver.pipelines.generation import generate_puzzle

    check_generation(generator, params, (seed,))  # as the command line checks, before any work
    return generate_puzzle(generator, seed, params)


def generate_into(out: str | Path, generator: str, seed: int, **params: Any) -> Path:
    """Generate like :func:`generate` and write the puzzle folder under ``out``; its path."""
    from phyrogen_core.folder import require_writable_dir
    from phyrogen_core.maker import GenerationError
    from solver.pipelines.generation import Job, run_jobs

    check_generation(generator, params, (seed,))  # as the command line checks, before any work
    require_writable_dir(out)
    (report,) = list(run_jobs([Job(generator, seed, dict(params))], Path(out), workers=1))
    if report.error is not None or report.folder is None:
        raise GenerationError(report.error or "generation failed")
    return Path(report.folder)


def load(folder: str | Path):
    """The puzzle in a folder (:class:`phyrogen_core.export.LoadedPuzzle`), read strictly."""
    from phyrogen_core.export import read_puzzle_dir

    return read_puzzle_dir(folder)


def check(folder: str | Path) -> list[str]:
    """Problems with a puzzle folder's certificate (empty when it is valid at fine resolution): the check
    stage's (:func:`phyrogen.stages.check.run`)."""
    return list(run(CheckRequest(str(folder))).problems)


def find_puzzles(root: str | Path, generators: list[str] | None = None) -> list[PuzzleFolder]:
    """The puzzle folders under ``root`` (or ``root`` itself), in a stable order."""
    return find_puzzle_folders(root, generators)

"""Generate one puzzle and build it in Blender: a folder with URDF, SRDF, puzzle.json and a .blend.

    blender --background --python scripts/generate.py -- --generator NAME --seed N --out DIR [--render]
    python scripts/generate.py --generator NAME --seed N --out DIR [--render]      (with the bpy wheel)

Inside a Blender binary the project's environment (``.venv`` beside this
folder, or $PHYROGEN_VENV) supplies numpy, OMPL and PhyRoGen. The URDF is
exported from the Blender scene and checked against the core's.

``--render`` then renders the puzzle's images in this Blender, as ``phyrogen
render`` does in its workers (the render stage's ``images/`` and ``<name>.blend``;
``--engine``, ``--size``, ``--views`` as there). Workbench needs an OpenGL
context (a display, or Mesa through EGL) and Blender aborts without one:
``--engine cycles`` renders on the CPU anywhere.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

USAGE = ("blender --background --python scripts/generate.py -- --generator NAME --seed N --out DIR [--render]\n"
         "   or: python scripts/generate.py --generator NAME --seed N --out DIR [--render]")
"""Without its leading "usage: ", which argparse adds (the messages here add it themselves)."""


def script_arguments(argv: list[str]) -> list[str]:
    """The script's own arguments: after ``--`` inside Blender, all of them under plain Python."""
    if "--" in argv:
        return argv[argv.index("--") + 1:]
    in_blender = any(a in argv for a in ("--python", "-P", "--background", "-b"))
    if in_blender:
        raise SystemExit("generate.py: the script's arguments must follow '--' on Blender's command line\n"
                         f"usage: {USAGE}")
    return argv[1:]


def main(argv: list[str]) -> int:
    import argparse

    from blender_addon.environment import ensure_project_importable

    arguments = script_arguments(argv)
    ensure_project_importable()
    try:
        import bpy
    except ImportError:
        print("generate.py: bpy is missing: run it with 'blender --background --python' or install the bpy "
              f"wheel (pip install -e .[blender])\nusage: {USAGE}", file=sys.stderr)
        return 2
    from phyrogen_core.registry import all_generators

    parser = argparse.ArgumentParser(prog="generate.py", usage=USAGE,
                                     description="Generate one puzzle and build it in Blender (a .blend beside "
                                                 "its URDF, SRDF and puzzle.json).")
    parser.add_argument("--generator", required=True, choices=sorted(all_generators()), metavar="NAME",
                        help="one of: " + ", ".join(sorted(all_generators())))
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="generator parameter")
    parser.add_argument("--render", action="store_true", help="also render the puzzle's images (images/)")
    parser.add_argument("--engine", choices=("workbench", "cycles"), default="workbench",
                        help="render engine for --render (default: workbench; cycles needs no OpenGL)")
    parser.add_argument("--size", default="520x390", help="image size for --render, WIDTHxHEIGHT")
    parser.add_argument("--views", default=None,
                        help="views for --render, comma-separated (default: those of phyrogen render)")
    args = parser.parse_args(arguments)

    from blender_addon.render_worker import parse_size
    from blender_addon.views import DEFAULT_VIEWS, parse_views

    try:  # bad input is found before any work
        size = parse_size(args.size)
        views = DEFAULT_VIEWS if args.views is None else parse_views(args.views)
    except ValueError as exc:
        print(f"generate.py: error: {exc}", file=sys.stderr)
        return 2

    from blender_addon.export import export_collection
    from blender_addon.scene import build_puzzle, read_chain
    from phyrogen.cli import parse_overrides
    from phyrogen_core.export import chain_to_urdf, write_puzzle
    from phyrogen_core.maker import GenerationError
    from phyrogen_core.registry import ParameterError, get_generator
    from solver.pipelines.generation import generate_here, versions

    try:
        spec = get_generator(args.generator)
        params = spec.parse_params(parse_overrides(args.set))
        # This process is fresh and plans nothing else: generating here is deterministic.
        puzzle = generate_here(args.generator, args.seed, params)
    except (ParameterError, GenerationError, ValueError) as exc:
        print(f"generate.py: error: {exc}", file=sys.stderr)
        return 2
    notices: list[str] = []
    folder = write_puzzle(puzzle, Path(args.out), versions(), notices)
    for notice in notices:
        print(f"generate.py: note: {notice}", file=sys.stderr)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    built = build_puzzle(puzzle, bpy.context.scene)
    if read_chain(built.collection) != puzzle.chain:
        print("generate.py: error: the Blender scene does not read back to the generated chain", file=sys.stderr)
        return 1
    exported = export_collection(built.collection, folder.parent / f".{folder.name}.from-blender")
    same = exported.read_text(encoding="utf-8") == chain_to_urdf(puzzle.chain)[0]
    import shutil

    shutil.rmtree(exported.parent.parent)
    if not same:
        print("generate.py: error: the URDF exported from the scene differs from the core's", file=sys.stderr)
        return 1
    blend = folder / f"{puzzle.name}.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    print(f"generate.py: {folder} ({len(puzzle.objects)} objects, Blender {bpy.app.version_string}, "
          f"URDF from the scene equals the core's, {blend.name})")
    if args.render:
        return render(folder, args.engine.upper(), size, views)
    return 0


def render(folder: Path, engine: str, size: tuple[int, int], views: tuple[str, ...]) -> int:
    """Render the puzzle folder in this Blender, as a ``phyrogen render`` worker does; the exit code."""
    import time

    from blender_addon.render_worker import render_folder
    from phyrogen_core.errors import PuzzleFormatError
    from phyrogen_core.folder import PuzzleFolder

    started = time.perf_counter()
    try:
        render_folder(folder, engine, size, views)
    except (PuzzleFormatError, OSError, ValueError, RuntimeError) as exc:
        print(f"generate.py: error: rendering {folder} failed: {exc}", file=sys.stderr)
        return 1
    images = sorted(p.name for p in PuzzleFolder.open(folder).images.iterdir())
    print(f"generate.py: rendered {len(images)} files into {folder / 'images'} with {engine.lower()} "
          f"in {time.perf_counter() - started:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

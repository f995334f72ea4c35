"""Build the Blender extension zip from ``blender_addon/``: ``python scripts/build_addon.py [--out DIR]``.

Uses Blender's own extension builder (shipped with the bpy wheel, or given
with ``--builder``), so the zip is what Blender 4.2+ installs. Older Blender
(3.4+) installs ``blender_addon`` as a legacy add-on from the same zip.
Prints the path of the zip.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parent.parent
SOURCE = REPOSITORY / "blender_addon"


def find_builder() -> Path:
    """``blender_ext.py`` of the installed bpy wheel."""
    import importlib.util

    spec = importlib.util.find_spec("bpy")
    if spec is None or spec.origin is None:
        raise FileNotFoundError("the bpy wheel is not installed (pip install -e .[blender]); "
                                "or pass --builder PATH/TO/blender_ext.py")
    found = sorted(Path(spec.origin).parent.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        raise FileNotFoundError(f"no blender_ext.py under {Path(spec.origin).parent}; pass --builder")
    return found[-1]


def build(out_dir: Path, builder: Path | None = None) -> Path:
    """Build the zip into ``out_dir`` and return its path."""
    builder = builder or find_builder()
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as staging:
        # Build from a clean copy: no caches, nothing a developer left beside the sources.
        source = Path(staging) / "phyrogen"
        shutil.copytree(SOURCE, source, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        result = subprocess.run([sys.executable, str(builder), "build", "--source-dir", str(source),
                                 "--output-dir", str(out_dir)], capture_output=True, text=True)
    if result.returncode != 0:
        raise RuntimeError(f"extension build failed ({result.returncode}): {result.stdout}{result.stderr}")
    zips = sorted(out_dir.glob("phyrogen-*.zip"), key=lambda p: p.stat().st_mtime)
    if not zips:
        raise RuntimeError(f"the builder wrote no zip into {out_dir}: {result.stdout}")
    return zips[-1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="dist", help="output folder (default: dist)")
    parser.add_argument("--builder", type=Path, help="Blender's blender_ext.py (default: the bpy wheel's)")
    args = parser.parse_args(argv)
    try:
        print(build(Path(args.out), args.builder))
    except (FileNotFoundError, RuntimeError) as exc:
        print(f"build_addon: error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

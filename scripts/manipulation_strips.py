"""Compose the manipulation frames of a `phyrogen manipulate` output folder into one strip per puzzle.

    python scripts/manipulation_strips.py OUT_DIR DEST_DIR [--width 320] [--puzzles a,b,...]

Each strip is the puzzle's four frames (start, two intermediate, final) side by side, scaled to
``--width`` pixels each, written as ``DEST_DIR/<puzzle>.png``: small enough for the docs; and,
when the run wrote them, its grip close-ups (one per action: the fingers on the handle) as
``DEST_DIR/<puzzle>_grips.png``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from PIL import Image


def strip(frames: list[Path], width: int) -> Image.Image:
    images = [Image.open(f).convert("RGB") for f in frames]
    height = round(images[0].height * width / images[0].width)
    out = Image.new("RGB", (width * len(images), height), "white")
    for i, image in enumerate(images):
        out.paste(image.resize((width, height), Image.LANCZOS), (i * width, 0))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir", type=Path, help="a `phyrogen manipulate --out` folder")
    parser.add_argument("dest", type=Path, help="folder for the strips")
    parser.add_argument("--width", type=int, default=320, help="pixels per frame (default 320)")
    parser.add_argument("--puzzles", default="", help="comma-separated puzzle names (default: all)")
    args = parser.parse_args(argv)
    names = [n for n in args.puzzles.split(",") if n] or sorted(p.name for p in args.out_dir.iterdir() if p.is_dir())
    args.dest.mkdir(parents=True, exist_ok=True)
    for name in names:
        frames = sorted((args.out_dir / name / "frames").glob("frame_*.png"))
        if not frames:
            print(f"error: no frames in {args.out_dir / name / 'frames'}", file=sys.stderr)
            return 2
        strip(frames, args.width).save(args.dest / f"{name}.png", optimize=True)
        grips = sorted((args.out_dir / name / "frames").glob("grip_*.png"),
                       key=lambda p: int(p.stem.split("_")[1]))
        if grips:
            strip(grips, args.width).save(args.dest / f"{name}_grips.png", optimize=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

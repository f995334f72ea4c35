"""Import every puzzle of the prototype (``ljdross/puzzle-generator``) and print the table of docs/import.md.

Usage::

    git clone https://github.com/ljdross/puzzle-generator ../puzzle-generator   # once, by hand
    python scripts/import_prototype.py ../puzzle-generator [--out output/prototype] [--time-limit 60]

Nothing is downloaded here. For each ``puzzles/*/urdf/*.urdf`` of the
checkout it runs ``phyrogen import`` (no option: the goal must come from the
URDF's ``goal`` link), ``phyrogen check`` on the folder written, and then
one benchmark run of our LA-RRT (``phyrogen benchmark --planners la_rrt_push
--runs 1 --until first``) on every imported puzzle. The table goes to
stdout as Markdown; what each command said goes to stderr.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

PHYROGEN = [sys.executable, "-m", "phyrogen"]


def run(argv: list[str]) -> tuple[int, str, str, float]:
    started = time.perf_counter()
    done = subprocess.run(PHYROGEN + argv, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - started
    sys.stderr.write(f"$ phyrogen {' '.join(argv)}\n{done.stdout}{done.stderr}")
    return done.returncode, done.stdout, done.stderr, seconds


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkout", type=Path, help="the prototype's checkout (holding puzzles/)")
    parser.add_argument("--out", type=Path, default=Path("output/prototype"), help="default: output/prototype")
    parser.add_argument("--time-limit", type=float, default=60.0, help="seconds of the LA-RRT run (default 60)")
    args = parser.parse_args()
    urdfs = sorted((args.checkout / "puzzles").glob("*/urdf/*.urdf"))
    if not urdfs:
        parser.error(f"{args.checkout}: no puzzles/*/urdf/*.urdf; is it a checkout of ljdross/puzzle-generator?")
    rows = []
    for urdf in urdfs:
        code, out, err, seconds = run(["import", str(urdf), "--out", str(args.out)])
        row = {"name": urdf.stem, "seconds": seconds, "imported": code == 0}
        if code == 0:
            folder = Path(out.split(": ", 1)[0])
            metadata = json.loads((folder / "puzzle.json").read_text(encoding="utf-8"))
            objects = metadata["objects"]
            row.update(
                movable=sum(o["motion"] != "fixed" for o in objects),
                static=sum(o["motion"] == "fixed" for o in objects),
                joints=len(metadata["joint_order"]), goal=metadata["parameters"]["goal_from"],
                actions=metadata["certificate_actions"], name=metadata["name"],
                hulls=any("no extruded outline" in n for n in metadata["parameters"]["notes"]),
                moved=any("does not exist here" in n for n in metadata["parameters"]["notes"]),
                checked=run(["check", str(folder)])[0] == 0,
            )
        else:
            lines = err.strip().splitlines()
            # "phyrogen: error: <file>: <why> (<details>)": the why.
            row["why"] = lines[-1].split(": ", 3)[-1].split(" (")[0] if lines else f"exit code {code}"
            row["goal"] = "no goal link" if "no goal link" in row["why"] else "?"
        rows.append(row)
    solved = {}
    if any(r["imported"] for r in rows):
        bench = args.out / "benchmark"
        run(["benchmark", "--puzzles", str(args.out), "--generator", "all", "--planners", "la_rrt_push",
             "--runs", "1", "--until", "first", "--time-limit", f"{args.time_limit:g}", "--workers", "1",
             "--out", str(bench), "--quiet"])
        runs = bench / "runs.jsonl"
        for line in runs.read_text(encoding="utf-8").splitlines() if runs.is_file() else []:
            entry = json.loads(line)
            record = entry["record"]
            solved[entry["key"]["puzzle"]] = record.get("first_solution_time") if record.get("solved") else None
    print(table(rows, solved, args.time_limit))
    return 0


def table(rows: list[dict], solved: dict, limit: float) -> str:
    lines = ["| URDF | objects (movable + static) | joints | goal from | imported | certificate | "
             "LA-RRT (1 run) | import + certify [s] |",
             "|---|---:|---:|---|---|---|---|---:|"]
    for r in rows:
        if not r["imported"]:
            lines.append(f"| {r['name']} | | | {r['goal']} | no: {r['why']} | | | {r['seconds']:.1f} |")
            continue
        how = ["yes"] + (["meshes found by name"] if r["moved"] else []) + (["3D meshes as hull prisms"]
                                                                             if r["hulls"] else [])
        first = solved.get(r["name"], "missing")
        bench = ("not run" if first == "missing" else f"not solved in {limit:g} s" if first is None
                 else f"solved, {first:.2f} s")
        certificate = f"{'valid' if r['checked'] else 'INVALID'}, {r['actions']} actions"
        lines.append(f"| {r['name']} | {r['movable'] + r['static']} ({r['movable']} + {r['static']}) | {r['joints']} "
                     f"| {r['goal']} | {'; '.join(how)} | {certificate} | {bench} | {r['seconds']:.1f} |")
    imported = sum(r["imported"] for r in rows)
    done = sum(1 for r in rows if r["imported"] and solved.get(r["name"]) not in (None, "missing"))
    lines.append("")
    lines.append(f"{imported} of {len(rows)} URDFs imported with no hand edits; {done} of {imported} solved by "
                 "LA-RRT in one benchmark run.")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())

"""Where a puzzle's CPU time goes: generation by stage, in this process, with and without the blocking proof.

    python benchmarks/generation_stages.py [--generator grid_world] [--seeds 5000001-5000040] [--set KEY=VALUE]

Each puzzle is generated as a dataset worker generates it (:func:`solver.pipelines.generation.generate_here`),
then written, hashed and read back as the dataset does. The stages are timed by wrapping the functions
that do them (CPU seconds of this process): the first necessity judge (compiled LA-RRT with pushes),
the geometric proofs (:mod:`solver.validation.blocking`, :mod:`solver.validation.region_proof`), the
second judge, the validator's solve per candidate, certification at 2 mm, the stored certificate's
defragmentation, the dependency graph, export, the content hash and the read-back; collision-model
construction is counted inside the stages that build models and shown apart. The run is made twice
on the same seeds: with the proofs (as generation is) and without them (the judges alone, as before
the proofs came), and the two puzzle sets are compared (the same puzzles unless a proof at the top
rung spared a first judge's draws from the validator's stream: :func:`solver.validation.judge.judge`).
Pool and start-up are not in this process: ``benchmarks/dataset_speed.py`` measures whole dataset runs.
"""

from __future__ import annotations

import argparse
import collections
import shutil
import tempfile
import time
from pathlib import Path

from machine_load import measure

import solver.pipelines.generation as generation
import solver.validation.judge as judge
import solver.validation.validator as validator
from phyrogen_core.export import read_puzzle_dir, write_puzzle
from phyrogen_core.registry import get_generator
from solver.collision import model
from solver.pipelines.dataset import manifest
from solver.planning import defragment, problem
from solver.validation import blocking

STAGES = (
    (judge, "attempt_fixed", "first judge (compiled LA-RRT with pushes)"),
    (blocking.BlockingProver, "proves", "geometric proof"),
    (validator, "region_proves", "geometric proof, a target free in the plane (region_proof)"),
    (judge, "attempt_second", "second judge (compiled LA-RRT, goal sampler)"),
    (validator.OmplValidator, "solve", "validator.solve per candidate (extend / RRT-Connect)"),
    (validator.OmplValidator, "certify", "certification at 2 mm"),
    (defragment, "defragment_certificate", "defragmenting the stored certificate"),
    (problem, "dependency_graph", "dependency graph"),
    (model.CollisionModel, "__init__", "(collision-model construction, inside the stages above)"),
)


def _timed(spent: collections.Counter, label: str, function):
    def wrapper(*args, **kwargs):
        started = time.process_time()
        try:
            return function(*args, **kwargs)
        finally:
            spent[label] += time.process_time() - started

    return wrapper


def _run(generator: str, seeds: list[int], params, proof: bool) -> tuple[collections.Counter, float, list[str]]:
    spent: collections.Counter = collections.Counter()
    originals = [(owner, name, getattr(owner, name)) for owner, name, _ in STAGES]
    for (owner, name, label), (_, _, function) in zip(STAGES, originals, strict=True):
        setattr(owner, name, _timed(spent, label, function))
    made = validator.OmplValidator.__init__

    def without_proof(self, *args, **kwargs):
        made(self, *args, **kwargs)
        self.prover = None

    if not proof:
        validator.OmplValidator.__init__ = without_proof
    scratch = Path(tempfile.mkdtemp(prefix="stages-"))
    texts = []
    try:
        started = time.process_time()
        for seed in seeds:
            puzzle = generation.generate_here(generator, seed, params)
            at = time.process_time()
            folder = write_puzzle(puzzle, scratch, generation.versions())
            spent["export (write_puzzle)"] += time.process_time() - at
            at = time.process_time()
            manifest.content_hash(folder, folder.name)
            spent["content hash"] += time.process_time() - at
            at = time.process_time()
            read_puzzle_dir(folder)
            spent["read back (the manifest row)"] += time.process_time() - at
            texts.append((folder / "urdf" / f"{folder.name}.urdf").read_text())
        total = time.process_time() - started
    finally:
        validator.OmplValidator.__init__ = made
        for owner, name, function in originals:
            setattr(owner, name, function)
        shutil.rmtree(scratch, ignore_errors=True)
    return spent, total, texts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--generator", default="grid_world")
    parser.add_argument("--seeds", default="5000001-5000040", help="a range FIRST-LAST")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    first, _, last = args.seeds.partition("-")
    seeds = list(range(int(first), int(last or first) + 1))
    spec = get_generator(args.generator)
    params = spec.parse_params(dict(item.split("=", 1) for item in args.set))
    from solver.validation.judge import warm_up

    warm_up()
    _run(args.generator, seeds[:1], params, True)  # imports, numba's cache, first calls: outside the timing
    with measure() as taken:
        with_proof = _run(args.generator, seeds, params, True)
        judges_alone = _run(args.generator, seeds, params, False)
    n = len(seeds)
    print(f"{args.generator}, {n} puzzles (seeds {seeds[0]}-{seeds[-1]}): CPU seconds per puzzle by stage\n")
    print("| stage | judges alone | with the proof |")
    print("|---|---:|---:|")
    labels = [label for *_, label in STAGES] + ["export (write_puzzle)", "content hash", "read back (the manifest row)"]
    for label in labels:
        print(f"| {label} | {judges_alone[0][label] / n:.4f} | {with_proof[0][label] / n:.4f} |")
    print(f"| **all** | **{judges_alone[1] / n:.4f}** | **{with_proof[1] / n:.4f}** |")
    same = judges_alone[2] == with_proof[2]
    print(f"\n{judges_alone[1] / with_proof[1]:.2f}x; the same puzzles (URDF): {'yes' if same else 'NO'}")
    print(taken.describe())


if __name__ == "__main__":
    main()

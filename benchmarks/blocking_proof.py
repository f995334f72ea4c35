"""The geometric necessity proof's CPU time against another tree's, on the same questions, in one process.

    python benchmarks/blocking_proof.py BASELINE_TREE [--generator lockbox_random] [--seeds 9900001-9900006]
                                        [--set KEY=VALUE] [--rounds 3]

Generates the puzzles with this tree, recording every question the Maker asked the prover
(:meth:`solver.validation.blocking.BlockingProver.proves`: objects, goal, objects held, shrink), then asks
every question again with a fresh prover per puzzle (as a puzzle's validator does) of this tree's
``solver/validation/blocking.py`` and of ``BASELINE_TREE``'s (loaded beside it as another module), in
turns, ``--rounds`` times. Prints the questions, how many were proven, whether both gave the same answer
to every one (exits 1 where not), the best CPU seconds a puzzle of each and their ratio, with the load.
"""

from __future__ import annotations

import argparse
import gc
import importlib.util
import sys
import time
from pathlib import Path

from machine_load import measure

import solver.pipelines.generation as generation
from phyrogen_core.registry import get_generator
from solver.validation import blocking


def _module(tree: Path):
    spec = importlib.util.spec_from_file_location("baseline_blocking", tree / "solver" / "validation" / "blocking.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def _questions(name: str, seeds: range, params) -> list[list[tuple]]:
    asked: list[list[tuple]] = []
    original = blocking.BlockingProver.proves

    def recording(self, objects, goal, fixed, shrink):
        asked[-1].append((tuple(objects), goal, tuple(fixed), shrink))
        return original(self, objects, goal, fixed, shrink)

    blocking.BlockingProver.proves = recording
    try:
        for seed in seeds:
            asked.append([])
            generation.generate_here(name, seed, params)
    finally:
        blocking.BlockingProver.proves = original
    return asked


def _answers(module, puzzles: list[list[tuple]]) -> list[bool]:
    answers = []
    for questions in puzzles:
        prover = module.BlockingProver()
        answers += [bool(prover.proves(*question)) for question in questions]
    return answers


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("baseline", type=Path, help="a tree (e.g. a git worktree) whose blocking.py to compare with")
    parser.add_argument("--generator", default="lockbox_random")
    parser.add_argument("--seeds", default="9900001-9900006", help="FIRST-LAST")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    first, last = (int(v) for v in args.seeds.split("-"))
    params = get_generator(args.generator).parse_params(dict(item.split("=", 1) for item in args.set))
    baseline = _module(args.baseline)
    generation.generate_here(args.generator, first, params)  # compiled code loaded before any timing
    puzzles = _questions(args.generator, range(first, last + 1), params)
    baseline.warm_up()
    blocking.warm_up()
    expected = _answers(baseline, puzzles)
    same = _answers(blocking, puzzles) == expected
    best = {"baseline": float("inf"), "this tree": float("inf")}
    with measure() as load:
        for _ in range(args.rounds):
            for label, module in (("baseline", baseline), ("this tree", blocking)):
                gc.collect()
                start = time.process_time()
                same &= _answers(module, puzzles) == expected
                best[label] = min(best[label], (time.process_time() - start) / len(puzzles))
    print(f"{args.generator} seeds {first}-{last}: {sum(map(len, puzzles))} questions, {sum(expected)} proven, "
          f"same answers: {same}")
    print(f"proof CPU s a puzzle (best of {args.rounds}): baseline {best['baseline']:.4f}, this tree "
          f"{best['this tree']:.4f}, ratio {best['baseline'] / best['this tree']:.2f}; {load.describe()}")
    return 0 if same else 1


if __name__ == "__main__":
    raise SystemExit(main())

"""``--difficulty`` and its two settings, for ``generate`` and ``dataset``."""

from __future__ import annotations

from phyrogen.options import budget_checks_option, whole_number
from phyrogen.usage import UsageError


def add_difficulty_options(parser) -> None:
    parser.add_argument("--difficulty", action="store_true",
                        help="measure each puzzle's difficulty (BIT*'s success rate and median checks to a first "
                             "solution over seeded runs within a check budget) and write it into puzzle.json")
    parser.add_argument("--difficulty-runs", type=difficulty_runs_option, metavar="K",
                        help="runs per puzzle with --difficulty (default 8)")
    parser.add_argument("--difficulty-checks", type=budget_checks_option, metavar="N",
                        help="collision checks per run with --difficulty, a motion charged by its length "
                             "(default 1000000)")


def difficulty_runs_option(text: str) -> int:
    from solver.benchmark.difficulty import MAX_RUNS as MAX_DIFFICULTY_RUNS

    return whole_number(text, 1, MAX_DIFFICULTY_RUNS)


def difficulty_settings(args):
    """The --difficulty settings, or None without --difficulty (then the other two may not be given)."""
    if not args.difficulty:
        if args.difficulty_runs is not None or args.difficulty_checks is not None:
            raise UsageError("--difficulty-runs and --difficulty-checks go with --difficulty")
        return None
    from solver.benchmark.difficulty import DEFAULT_BUDGET_CHECKS, DEFAULT_RUNS, DifficultySettings

    return DifficultySettings(args.difficulty_runs or DEFAULT_RUNS, args.difficulty_checks or DEFAULT_BUDGET_CHECKS)

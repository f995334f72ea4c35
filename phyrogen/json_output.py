"""``--json``: the option, and the command run with its result printed as one JSON object."""

from __future__ import annotations

import argparse
import contextlib
import sys

from phyrogen_core.stage_records.base import StageResult


def add_json_option(parser: argparse.ArgumentParser, what: str) -> None:
    parser.add_argument("--json", action="store_true",
                        help=f"for programs: stdout is one JSON object ({what}); what is printed otherwise goes "
                             "to stderr")


def run_for_json(args) -> int:
    """``--json``: the command's own stdout goes to stderr, then its result (``args.json_result``, set by the
    command: the stage's result record, whose reader reads this text back) is printed as one JSON object.
    Bad input raises before, so its stdout stays empty."""
    args.json_result = None
    with contextlib.redirect_stdout(sys.stderr):
        code = args.func(args)
    result: StageResult | None = args.json_result
    if result is not None:
        print(result.to_json())
    return code

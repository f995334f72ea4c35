"""The ``phyrogen`` command line: thin wrappers over the library."""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import signal
import sys
import traceback

from phyrogen import signals
from phyrogen.commands import COMMANDS
from phyrogen.commands.benchmark import MAX_RUNS, MAX_TIME_LIMIT
from phyrogen.commands.manipulate import MIN_SCENE_SCALE
from phyrogen.json_output import run_for_json
from phyrogen.options import MAX_BENCHMARK_SEED, max_workers
from phyrogen.signals import Interrupted
from phyrogen.stages.manipulate import benchmark_runs
from phyrogen.usage import EXIT_BAD_INPUT, UsageError, parse_overrides, parse_seeds
from phyrogen_core.registry import ParameterError

# Importable from here, as before the commands had their own modules (tests, scripts/generate.py).
__all__ = ["EXIT_BAD_INPUT", "MAX_BENCHMARK_SEED", "MAX_RUNS", "MAX_TIME_LIMIT", "MIN_SCENE_SCALE", "Interrupted",
           "UsageError", "benchmark_runs", "build_parser", "main", "max_workers", "parse_overrides", "parse_seeds"]


class _Parser(argparse.ArgumentParser):
    """argparse, but a bad argument is one line (the contract), not the usage and then the message."""

    def error(self, message: str):
        raise UsageError(f"{message} (see {self.prog} --help)")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="phyrogen", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    for name in COMMANDS:
        importlib.import_module(f"phyrogen.commands.{name}").add_parser(sub)
    # Before or after the command: 'phyrogen --debug generate ...' and 'phyrogen generate ... --debug'.
    debug_help = "print the traceback of an unexpected error"
    parser.add_argument("--debug", action="store_true", help=debug_help)
    for command in sub.choices.values():
        command.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=debug_help)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run a command. Bad input: one line on stderr, exit 2. Interrupted (SIGINT, SIGTERM): one
    line, exit 130 or 143, nothing left running. Anything else: one line (the traceback with
    ``--debug``), exit 1."""
    from phyrogen_core.folder import OutputError

    previous, previous_hook = signals.install()
    debug = False
    try:
        args = build_parser().parse_args(argv)
        debug = args.debug
        if getattr(args, "json", False):
            code = run_for_json(args)
        else:
            code = args.func(args)
        signals.raise_if_dropped()
        return code
    except (UsageError, ParameterError, OutputError, ValueError, FileNotFoundError) as exc:
        if debug:
            traceback.print_exc()
        print(f"phyrogen: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:
        # The reader of stdout went away (``phyrogen generate | head``): the workers were stopped on
        # the way here; end quietly as a program killed by SIGPIPE would, and let the interpreter's
        # final flush of stdout go nowhere.
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 128 + signal.SIGPIPE
    except KeyboardInterrupt as exc:
        signals.ignore(previous)
        print("phyrogen: interrupted", file=sys.stderr)
        return 128 + getattr(exc, "signum", signal.SIGINT)
    except Exception as exc:
        if debug:
            traceback.print_exc()
        else:
            message = (str(exc).splitlines() or [""])[0]
            print(f"phyrogen: error: {type(exc).__name__}: {message} (run with --debug for the traceback)",
                  file=sys.stderr)
        return 1
    finally:
        # A caller in the same process gets its handlers back. Run as the program (no argv), the
        # command keeps them until the process ends: a second Ctrl-C arriving as it exits must
        # still count as ignored, not end it by the signal.
        if argv is not None:
            signals.restore(previous, previous_hook)


if __name__ == "__main__":
    sys.exit(main())

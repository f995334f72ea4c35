"""``phyrogen list``: the registered generators and their parameters."""

from __future__ import annotations

from phyrogen_core.registry import describe_generators


def add_parser(sub) -> None:
    sub.add_parser("list", help="list the registered generators and their parameters").set_defaults(func=run)


def run(args) -> int:
    print(describe_generators())
    return 0

"""``phyrogen list``: the registered generators and their parameters, then the registered planners."""

from __future__ import annotations

from phyrogen_core.registry import describe_generators


def add_parser(sub) -> None:
    sub.add_parser("list", help="list the registered generators and their parameters, and the planners"
                   ).set_defaults(func=run)


def run(args) -> int:
    from solver.planning.registry import describe_planners  # here: the parser stays quick to build

    print(describe_generators())
    print()
    print(describe_planners())
    return 0

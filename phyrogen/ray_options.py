"""``--ray``: the option, its check before any work, and the connection it asks for."""

from __future__ import annotations

import contextlib


def ray_connection(address: str | None, workers: int):
    """The Ray cluster of ``--ray`` (:func:`solver.parallel.ray_pool.ray_instance`); nothing without it."""
    if address is None:
        return contextlib.nullcontext()
    from solver.parallel.ray_pool import ray_instance

    return ray_instance(address, workers)


def check_ray(address: str | None) -> None:
    """Refuse a ``--ray`` that :func:`ray_connection` would refuse, without starting anything."""
    if address is not None:
        from solver.parallel.ray_pool import check_ray_address

        check_ray_address(address)


def add_ray_option(parser, what: str) -> None:
    parser.add_argument("--ray", nargs="?", const="local", metavar="ADDRESS",
                        help=f"make the {what} as Ray tasks: alone, on a local Ray instance with --workers CPUs; "
                             "with an address (auto, HOST:PORT, ray://HOST:PORT), on that cluster, whose nodes "
                             "must see the puzzle folders at the same paths (docs/datasets.md#ray)")

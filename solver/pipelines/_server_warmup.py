"""Imported once by the generation server process (see :mod:`solver.pipelines.generation`).

It compiles the collision kernels, the judge's loop and the necessity proofs' tests there (or loads them
from numba's cache), with every other signature of them that the cache holds, so every worker forked
from the server starts with them loaded instead of paying about 0.2 s each. It loads the generator
registry too (the generators' modules, found through their entry points), which every fresh worker
otherwise loaded before its first puzzle. Then it moves everything imported so far out of the garbage
collector's reach (``gc.freeze``): a worker's first collections would otherwise visit, and so copy,
every page of the server's objects that it shares. A fresh dataset worker's first Simple Slider puzzle
cost about 0.11 CPU s more than the next one, 0.05 with the freeze, 0.02 with the registry and the
other signatures loaded here (2-core machine).
"""

import contextlib

from phyrogen_core.registry import registry
from solver.collision.model import warm_up
from solver.validation.blocking import warm_up as warm_up_proof
from solver.validation.judge import warm_up as warm_up_judge
from solver.validation.region_proof import warm_up as warm_up_region_proof

warm_up()
warm_up_judge()
warm_up_proof()
warm_up_region_proof()

_CALLED_KERNELS = {
    "solver.collision.kernels": ("check_states", "motion_collision", "state_valid_packed", "pair_hits",
                                 "pair_hits_packed", "pair_hits_rows", "nearest_l1", "fixed_poses"),
    "solver.planning._isolated_step": ("isolated_moves",),
    "solver.planning._judge_loop": ("new_trees", "resume"),
    "solver.validation.blocking": ("_pair_overlaps",),
    "solver.validation.region_proof": ("_closed", "_reach"),
}
"""The compiled kernels that generation calls from Python. The warm-ups above call them with one layout
of arrays; generation also passes others (a view of a state, ``np.nonzero``'s indices) and calls
LA-RRT's kernels, each a signature of its own that a fresh worker loaded from numba's cache before its
first puzzle (about 5 ms each, up to five a worker)."""


def _load_cached_signatures() -> None:
    """Load every signature of :data:`_CALLED_KERNELS` that numba's cache holds for the current code: no
    kernel runs, and a call still takes only the signature that matches its arguments exactly (the
    dispatcher compiles an exact match whenever it may compile), so which are loaded changes no result.
    A kernel renamed, a numba without these internals or an unreadable cache leaves the loading to the
    workers: nothing here may stop the server, whose failed import would fail every run."""
    import importlib

    from numba.core.dispatcher import Dispatcher

    for module_name, names in _CALLED_KERNELS.items():
        for name in names:
            try:
                kernel = getattr(importlib.import_module(module_name), name, None)
                if not isinstance(kernel, Dispatcher):
                    continue
                cache, codegen = kernel._cache, kernel.targetctx.codegen()
                for key in cache._cache_file._load_index():
                    if key == cache._index_key(key[0], codegen) and tuple(key[0]) not in kernel.overloads:
                        kernel.compile(key[0])
            except Exception:  # (see the docstring)
                continue


_load_cached_signatures()
# The generators' modules and their entry points, which the registry loads on first use: once here, not
# in every worker. One that does not load is left for the worker to report, with the puzzle it fails.
with contextlib.suppress(Exception):
    registry()

import gc  # noqa: E402

gc.freeze()

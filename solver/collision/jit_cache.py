"""Numba's on-disk cache kept true when the compiled sources change together.

Numba checks a cached function against its own source file only (that file's modification time and
size). Our compiled functions call each other across files: :mod:`solver.collision.raster` and
:mod:`solver.planning._judge_loop` call :mod:`solver.collision.kernels`'s functions, and
:mod:`solver.collision.skipping_move` compiles its inline helpers into itself. A change to
``kernels.py`` alone (a pull, an upgrade) left the callers' cached machine code in place, linked to the
old kernels: it ran the old code, or crashed (seen when the kernels were split:
``NRT_adapt_ndarray_to_python: 'descr' is NULL`` in raster's cached code).

:func:`refresh_stale_jit_cache`, called as the kernels are imported (every one of those files imports
them before anything is compiled or loaded), digests :data:`JIT_SOURCES` together. When the digest is not
the one recorded beside them, every one of those files gets a new modification time, which makes numba
drop all their cached entries, wherever it keeps them (``__pycache__`` or ``NUMBA_CACHE_DIR``), and compile
them afresh. Where the sources cannot be touched (a read-only install) numba's own rule stands.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

JIT_SOURCES = ("collision/kernels.py", "collision/raster.py", "collision/skipping_move.py",
               "planning/_judge_loop.py", "planning/_judge_motion.py", "planning/_isolated_step.py",
               "planning/_paper_loop.py", "planning/_goal_stream.py", "planning/_leg_connect.py",
               "validation/_repair_screen.py", "validation/cell_pairs.py", "validation/cell_reach.py",
               "validation/region_blocks.py", "validation/region_proof.py", "validation/route_grid.py")
"""Every file of :mod:`solver` with cached compiled functions, relative to the package."""
SOLVER_ROOT = Path(__file__).resolve().parent.parent
STAMP = Path("collision") / "__pycache__" / "jit-sources.sha256"
"""Where the digest of the sources last compiled together is recorded, relative to the package."""


def sources_digest(root: Path = SOLVER_ROOT) -> str:
    digest = hashlib.sha256()
    for name in JIT_SOURCES:
        digest.update(name.encode() + b"\0" + (root / name).read_bytes() + b"\0")
    return digest.hexdigest()


def refresh_stale_jit_cache(root: Path = SOLVER_ROOT) -> bool:
    """Invalidate numba's cache of every file in :data:`JIT_SOURCES` under ``root`` when any of them changed
    since the digest recorded there; whether it did."""
    stamp = root / STAMP
    try:
        current = sources_digest(root)
        if stamp.is_file() and stamp.read_text() == current:
            return False
        for name in JIT_SOURCES:
            os.utime(root / name)
        stamp.parent.mkdir(exist_ok=True)
        temporary = stamp.with_name(f".{stamp.name}.{os.getpid()}.tmp")
        temporary.write_text(current)
        os.replace(temporary, stamp)
    except OSError:  # a source missing or read-only: numba's own rule, as before
        return False
    return True

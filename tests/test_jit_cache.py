"""Numba's cache is dropped for every compiled file when any of them changes (solver/collision/jit_cache.py):
numba itself checks a cached function against its own file only, and ours call each other across files."""

from __future__ import annotations

import os
import shutil

from solver.collision.jit_cache import JIT_SOURCES, SOLVER_ROOT, STAMP, refresh_stale_jit_cache


def _copy_sources(root):
    for name in JIT_SOURCES:
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(SOLVER_ROOT / name, root / name)
        os.utime(root / name, ns=(1_000_000_000, 1_000_000_000))  # an old modification time, as after a checkout


def _mtimes(root):
    return {name: (root / name).stat().st_mtime_ns for name in JIT_SOURCES}


def test_a_change_to_one_compiled_file_renews_every_one_and_no_change_touches_none(tmp_path):
    _copy_sources(tmp_path)
    assert refresh_stale_jit_cache(tmp_path)  # no digest recorded yet: a fresh install compiles afresh
    assert (tmp_path / STAMP).is_file()
    recorded = _mtimes(tmp_path)
    assert all(t > 1_000_000_000 for t in recorded.values())

    # Control: nothing changed, nothing is touched (numba keeps its cache).
    assert not refresh_stale_jit_cache(tmp_path)
    assert _mtimes(tmp_path) == recorded

    # An edit of the kernels alone: the callers' files get new times too, so numba drops their cached code.
    for name in JIT_SOURCES:
        os.utime(tmp_path / name, ns=(1_000_000_000, 1_000_000_000))
    kernels = tmp_path / "collision/kernels.py"
    kernels.write_text(kernels.read_text() + "\n# edited\n")
    os.utime(kernels, ns=(2_000_000_000, 2_000_000_000))
    assert refresh_stale_jit_cache(tmp_path)
    after = _mtimes(tmp_path)
    assert all(after[name] > 2_000_000_000 for name in JIT_SOURCES if name != "collision/kernels.py")
    assert not refresh_stale_jit_cache(tmp_path)


def test_sources_that_cannot_be_read_leave_numbas_rule_in_place(tmp_path):
    _copy_sources(tmp_path)
    (tmp_path / JIT_SOURCES[-1]).unlink()
    assert not refresh_stale_jit_cache(tmp_path)
    assert not (tmp_path / STAMP).exists()


def _cached_compiled_files(root):
    """Files of the solver package whose source asks numba for an on-disk cache."""
    return {path.relative_to(root).as_posix() for path in root.rglob("*.py") if "cache=True" in path.read_text()}


def test_every_file_with_cached_compiled_functions_is_renewed_with_the_others(tmp_path):
    # Missed before: the region proof's files call each other's compiled functions and were not listed.
    assert _cached_compiled_files(SOLVER_ROOT) == set(JIT_SOURCES)
    (tmp_path / "validation").mkdir()
    (tmp_path / "validation" / "new.py").write_text("@njit(cache=True)\ndef f(): pass\n")
    assert _cached_compiled_files(tmp_path) == {"validation/new.py"}  # control: a new cached file is found

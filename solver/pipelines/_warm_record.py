"""What the workers' server loaded for a generator's hint puzzle, recorded so that the next server loads it
without generating a puzzle (:mod:`solver.pipelines._server_warmup`).

A hint's puzzle is generated once in the server and thrown away only to learn which compiled kernels'
signatures that generator's puzzles call (and which modules they import on first use). Loading them is
most of the puzzle's cost at the start of a run (about 0.17 of 0.18 CPU s for a Grid World puzzle), but
the puzzle itself costs what any of the generator's puzzles costs: 0.01-0.05 CPU s, and 0.5 for a
Continuous Space seed of the heavy tail. The record keeps, per generator, the kernels (module, name) and
the text of each signature, and the modules of :mod:`solver` and :mod:`phyrogen_core` the puzzle
imported on first use (numba's own come with its first signature); a server that finds a record made
for the same code loads exactly those, from numba's cache, and generates nothing.

A record serves the same code only: its key digests numba's and Python's versions and the size and
modification time of every source file of :mod:`solver` and :mod:`phyrogen_core`, whose changes can
change which signatures a puzzle calls. Even so, which signatures are loaded never changes a result (a
call takes the signature that matches its arguments exactly, loading it then if it is not loaded yet):
a record that misses one costs each worker that signature's load, an unreadable or unwritable record
the puzzle, as before records. It lives beside the digest of the compiled sources
(:data:`solver.collision.jit_cache.STAMP`), in the package's ``__pycache__``.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import json
import os
import sys
from pathlib import Path
from typing import Any

from solver.collision.jit_cache import SOLVER_ROOT, STAMP

RECORD_FILE = SOLVER_ROOT / STAMP.parent / "warm-signatures.json"
"""Where the record is kept (a module attribute, so that a test can keep its own)."""
_SOURCE_PACKAGES = (SOLVER_ROOT, SOLVER_ROOT.parent / "phyrogen_core")
MAX_GENERATORS = 64
"""The most generators a record holds; a record that would hold more starts again (generators come and go)."""


def record_key() -> str:
    """The digest of what a record is valid for (see the module docstring)."""
    import numba

    digest = hashlib.sha256(f"{sys.version}\0{numba.__version__}\0".encode())
    for package in _SOURCE_PACKAGES:
        for folder, dirs, files in os.walk(package):
            dirs[:] = sorted(d for d in dirs if d != "__pycache__")
            for name in sorted(f for f in files if f.endswith(".py")):
                stat = os.stat(os.path.join(folder, name))
                digest.update(f"{folder}/{name}\0{stat.st_size}\0{stat.st_mtime_ns}\0".encode())
    return digest.hexdigest()


def recorded(generator: str, key: str) -> dict[str, Any] | None:
    """The record of ``generator`` made for ``key``, or None (none, another key, unreadable)."""
    try:
        stored = json.loads(Path(RECORD_FILE).read_text("utf-8"))
        if stored.get("key") != key:
            return None
        entry = stored["generators"].get(generator)
        if entry is None:
            return None
        return {"signatures": [(str(m), str(q), str(s)) for m, q, s in entry["signatures"]],
                "modules": [str(m) for m in entry["modules"]]}
    except (OSError, ValueError, TypeError, KeyError, AttributeError):
        return None


def record(generator: str, key: str, signatures: list[tuple[str, str, str]], modules: list[str]) -> None:
    """Add ``generator``'s record, made for ``key``, to the file (replaced whole: atomically; a record of
    another key is dropped). Nothing is written where the package cannot be written."""
    try:
        stored = json.loads(Path(RECORD_FILE).read_text("utf-8"))
        if not isinstance(stored, dict) or stored.get("key") != key or not isinstance(stored.get("generators"), dict) \
                or len(stored["generators"]) >= MAX_GENERATORS:
            stored = None
    except (OSError, ValueError):
        stored = None
    stored = stored or {"key": key, "generators": {}}
    stored["generators"][generator] = {"signatures": sorted(signatures), "modules": sorted(modules)}
    path = Path(RECORD_FILE)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        path.parent.mkdir(exist_ok=True)
        temporary.write_text(json.dumps(stored, sort_keys=True))
        os.replace(temporary, path)
    except OSError:
        with contextlib.suppress(OSError):
            temporary.unlink()


def loaded_signatures(kernels: list) -> list[tuple[str, str, str]]:
    """(module, qualified name, signature text) of every signature the ``kernels`` (numba dispatchers) hold."""
    return [(kernel.py_func.__module__, kernel.py_func.__qualname__, str(tuple(signature)))
            for kernel in kernels for signature in kernel.overloads]


def load(entry: dict[str, Any]) -> bool:
    """Import the record's modules and load its signatures from numba's cache, never compiling one; whether
    every signature is loaded now. One that the cache does not hold (its folder emptied, NUMBA_CACHE_DIR
    elsewhere) or that does not load would be compiled by every worker that calls it: the caller then
    generates the puzzle instead, which compiles it once, here."""
    for name in entry["modules"]:
        with contextlib.suppress(Exception):  # (a module gone: the workers import what they need)
            importlib.import_module(name)
    wanted: dict[tuple[str, str], set[str]] = {}
    for module, qualname, signature in entry["signatures"]:
        wanted.setdefault((module, qualname), set()).add(signature)
    complete = True
    for (module, qualname), signatures in sorted(wanted.items()):
        try:
            kernel = sys.modules[module]
            for part in qualname.split("."):
                kernel = getattr(kernel, part)
            cache, codegen = kernel._cache, kernel.targetctx.codegen()
            for index_key in cache._cache_file._load_index():
                types = tuple(index_key[0])
                if str(types) in signatures and types not in kernel.overloads \
                        and index_key == cache._index_key(index_key[0], codegen):
                    kernel.compile(index_key[0])
            complete = complete and signatures <= {str(tuple(types)) for types in kernel.overloads}
        except Exception:  # (numba's internals differ, a kernel gone)
            complete = False
    return complete

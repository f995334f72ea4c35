"""Imported once by the generation server process (see :mod:`solver.pipelines.generation`).

It loads, before the server forks any worker, what the workers' puzzles would otherwise each load on
first use: the compiled kernels' signatures (from numba's cache), the generator registry (the
generators' modules, found through their entry points) and the package versions every puzzle folder
records. Then it moves everything imported so far out of the garbage collector's reach
(``gc.freeze``): a worker's first collections would otherwise visit, and so copy, every page of the
server's objects that it shares. A fresh dataset worker's first Simple Slider puzzle cost about 0.11
CPU s more than the next one, 0.05 with the freeze, 0.02 with the registry and the signatures loaded
here (2-core machine).

Which signatures: given a hint (:data:`solver.parallel.pool.SERVER_HINT`, made by
:func:`solver.pipelines.generation.warm_hint`: a dataset's first puzzle), the server generates that
puzzle once and throws it away, which loads exactly what that generator's puzzles call (a Simple
Slider of four objects: 10 signatures, about 0.15 CPU s), and records what it loaded; a later server of
the same code loads that record instead of generating a puzzle (:mod:`solver.pipelines._warm_record`:
the puzzle's own cost saved, 0.01-0.05 CPU s, 0.5 for a Continuous Space seed of the heavy tail, and a
crash in it can no longer take the server down). It also loads the records of the request's other
generators (a dataset of several), whose workers would otherwise each load those signatures again; a
puzzle too large to generate here is not, and without a record the server warms every kernel up as
without a hint. Without a hint, or when that fails, it calls
every kernel on small models and loads every signature that numba's cache holds for the kernels the
solver calls (31, about 0.45 CPU s). A server started again after one died preparing (a crash in compiled
code) prepares nothing (:data:`solver.parallel.pool.COLD_SERVER`).
"""

import contextlib
import io
import os

from phyrogen_core.registry import registry
from solver.parallel.pool import COLD_SERVER, SERVER_HINT


def _warm_up_every_kernel() -> None:
    from solver.collision.model import warm_up
    from solver.validation.blocking import warm_up as warm_up_proof
    from solver.validation.judge import warm_up as warm_up_judge
    from solver.validation.region_proof import warm_up as warm_up_region_proof

    warm_up()
    warm_up_judge()
    warm_up_proof()
    warm_up_region_proof()
    _load_cached_signatures()


def _warm_up_for(hint: str | None) -> bool:
    """Prepare for the hint's generators: load what each recorded (:mod:`solver.pipelines._warm_record`) and,
    when its first generator has no record and the hint allows it, generate that generator's puzzle once and
    record what it loaded (see the module docstring). Whether the first generator was prepared for. The
    puzzle's output goes nowhere: the server shares the command's terminal."""
    global RECORDED
    if not hint:
        return False
    import sys

    from solver.pipelines import _warm_record
    from solver.pipelines.generation import generate_for_hint, read_hint

    try:
        read = read_hint(hint)
        key = _warm_record.record_key()
        entry = _warm_record.recorded(read.generator, key)
        if entry is not None and _warm_record.load(entry):
            RECORDED = True
            if read.always:  # (its signatures are loaded: the puzzle costs what any of its puzzles costs)
                with contextlib.suppress(Exception), contextlib.redirect_stdout(io.StringIO()), \
                        contextlib.redirect_stderr(io.StringIO()):
                    generate_for_hint(hint)
        elif read.generate:
            before = set(sys.modules)
            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
                generate_for_hint(hint)
            # (Before any other generator's record is loaded: this one records what its own puzzle loaded.)
            with contextlib.suppress(Exception):  # (unwritable: the next server generates the puzzle again)
                modules = [name for name in set(sys.modules) - before if name.partition(".")[0] in
                           ("solver", "phyrogen_core") and sys.modules.get(name) is not None]
                _warm_record.record(read.generator, key,
                                    _warm_record.loaded_signatures(_kernels_called_from_python()), modules)
        for generator in dict.fromkeys(read.also):  # (one without a record: its puzzles load what they call)
            other = _warm_record.recorded(generator, key) if generator != read.generator else None
            if other is not None:
                _warm_record.load(other)
    except Exception:  # (a generator only the caller's script registers, a bug: the workers report it)
        return False
    return RECORDED or read.generate


def _kernels_called_from_python() -> list:
    """The compiled kernels (numba dispatchers) that the Python code of the solver's modules imported so far
    calls: a name in a function of a module that the module binds to a kernel, or to a module holding one
    (``kernels.check_states``). A kernel only other kernels call is compiled into them: loading its own
    signatures would be wasted. Found from the code, so a kernel added tomorrow is found too; a name that
    only looks like a call costs a load, never a result."""
    import sys
    from types import CodeType, FunctionType, ModuleType

    from numba.core.dispatcher import Dispatcher

    def code_names(code: CodeType, names: set[str]) -> None:
        names.update(code.co_names)
        for const in code.co_consts:
            if isinstance(const, CodeType):
                code_names(const, names)

    def functions(value, module_name: str, seen: set[int]):
        if id(value) in seen:
            return
        seen.add(id(value))
        if isinstance(value, (staticmethod, classmethod)):
            yield from functions(value.__func__, module_name, seen)
        elif isinstance(value, property):
            for accessor in (value.fget, value.fset, value.fdel):
                yield from functions(accessor, module_name, seen)
        elif isinstance(value, FunctionType) and value.__module__ == module_name:
            yield value
        elif isinstance(value, type) and value.__module__ == module_name:
            for member in vars(value).values():
                yield from functions(member, module_name, seen)

    found: dict[int, Dispatcher] = {}
    for module_name, module in list(sys.modules.items()):
        if not module_name.startswith("solver.") or module is None:
            continue
        names: set[str] = set()
        seen: set[int] = set()
        for value in list(vars(module).values()):
            for function in functions(value, module_name, seen):
                code_names(function.__code__, names)
        scopes = [module, *(v for v in vars(module).values()
                            if isinstance(v, ModuleType) and v.__name__.startswith("solver."))]
        for name in names:
            for scope in scopes:
                kernel = getattr(scope, name, None)
                if isinstance(kernel, Dispatcher):
                    found[id(kernel)] = kernel
    return list(found.values())


def _load_cached_signatures() -> None:
    """Load every signature that numba's cache holds for the current code of the kernels generation calls
    (:func:`_kernels_called_from_python`). The warm-ups of :func:`_warm_up_every_kernel` call each with
    one layout of arrays; generation passes others too (a view of a state, ``np.nonzero``'s indices) and
    calls kernels they do not, each a signature of its own that every fresh worker loaded before its first
    puzzle (about 5 ms each, five to seven a worker). No kernel runs here, and a call still takes only the
    signature that matches its arguments exactly (a dispatcher compiles an exact match whenever it may
    compile), so which are loaded changes no result. A numba without these internals or an unreadable cache
    leaves the loading to the workers: nothing here may stop the server, whose failed import fails every run."""
    try:
        kernels = _kernels_called_from_python()
    except Exception:  # (see the docstring)
        return
    for kernel in kernels:
        try:
            cache, codegen = kernel._cache, kernel.targetctx.codegen()
            for key in cache._cache_file._load_index():
                if key == cache._index_key(key[0], codegen) and tuple(key[0]) not in kernel.overloads:
                    kernel.compile(key[0])
        except Exception:  # (see the docstring)
            continue


# The generators' modules and their entry points, which the registry loads on first use: once here, not
# in every worker. One that does not load is left for the worker to report, with the puzzle it fails.
with contextlib.suppress(Exception):
    registry()
RECORDED = False
"""Whether this server prepared for its hint from a record (:mod:`solver.pipelines._warm_record`), without
generating the hint's puzzle."""
_HINT = os.environ.pop(SERVER_HINT, None)
COLD = _HINT == COLD_SERVER
"""Whether this server prepares nothing beyond its imports: it is started again after one died preparing
(:meth:`solver.parallel.pool.FreshProcessPool._start`); the workers load what they call themselves."""
HINTED = not COLD and _warm_up_for(_HINT)
"""Whether this server generated a hint's puzzle to its end (else it warmed every kernel up, unless cold)."""
if not HINTED and not COLD:
    _warm_up_every_kernel()
# The package versions every puzzle folder records: importlib.metadata finds and parses each package's
# METADATA (4.5 ms), once a process; here, not once a worker.
with contextlib.suppress(Exception):
    from solver.pipelines.generation import versions

    versions()

import gc  # noqa: E402

gc.freeze()

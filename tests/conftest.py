"""Shared fixtures: the paper's 24 puzzles, generated once per test session."""

from __future__ import annotations

import signal

import pytest

# The Ctrl-C tests model a user at a terminal, where SIGINT has its default action. A suite started as a
# background job of a shell without job control (``cmd &`` in a script, ``nohup``) inherits SIGINT
# *ignored*, and so would every process a test starts (exec keeps an ignored signal ignored): a plain
# script interrupted by a test would simply go on. With Python's handler installed here, in the
# controller and in every worker, each child starts with the default action again.
signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(scope="session")
def paper_reports(tmp_path_factory):
    """Reports (with puzzles and folders) of the six generators x seeds 1-4."""
    from phyrogen_core.registry import paper_generators
    from solver.pipelines.generation import Job, run_jobs

    out = tmp_path_factory.mktemp("paper")
    jobs = [Job(name, seed) for name in paper_generators() for seed in range(1, 5)]
    reports = list(run_jobs(jobs, out, workers=2))
    failed = [f"{r.generator} {r.seed}: {r.error}" for r in reports if r.error]
    assert not failed, "generation failed:\n" + "\n".join(failed)
    return reports


# Scheduling for scripts/test.sh (pytest-xdist, --dist loadfile: a file is one unit of work, on one worker).
# xdist hands out units in the order it is given them, by default the files with the most tests first, so a
# file of few long tests (the fresh-Blender installs, minutes each) could start last and run alone at the
# end. The longest units start first instead, in this order (measured with --durations of the whole suite);
# a file not named here follows them, in collection order. The order changes when tests run, never what runs.
LONGEST_FIRST = (
    "test_blender_extension.py",
    "paper_reports",
    "test_blender_binary.py",
    "test_manipulation_determinism.py",
    "test_blender_panel_jobs.py",
    "test_benchmark_evidence.py",
    "test_hostile_sizes.py",
    "test_manipulation_media.py",
    "test_blender_addon.py",
    "test_ray.py",
    "test_phobos_export.py",
)
SAME_WORKER = dict.fromkeys(("test_determinism.py", "test_fair_benchmark.py", "test_paper_puzzles.py"),
                            "paper_reports")
"""Files that use the session fixture ``paper_reports`` (24 puzzles, half a minute to generate): one unit
of work, so that one worker builds it once rather than each worker once."""


def _unit(nodeid: str) -> str:
    name = nodeid.split("::", 1)[0].rsplit("/", 1)[-1]
    return SAME_WORKER.get(name, name)


def _rank(nodeid: str) -> int:
    unit = _unit(nodeid)
    return LONGEST_FIRST.index(unit) if unit in LONGEST_FIRST else len(LONGEST_FIRST)


def pytest_collection_modifyitems(items):
    items.sort(key=lambda item: _rank(item.nodeid))  # stable: within a file, the file's own order


def pytest_xdist_make_scheduler(config, log):
    if config.getvalue("dist") != "loadfile":
        return None  # another --dist asked for on the command line: xdist's own
    from xdist.scheduler import LoadFileScheduling

    class LongestFirst(LoadFileScheduling):
        """Units as :func:`_unit` says, handed out in collection order (sorted above), not by test count."""

        def _split_scope(self, nodeid: str) -> str:
            return _unit(nodeid) if _unit(nodeid) == "paper_reports" else super()._split_scope(nodeid)

    config.option.loadscopereorder = False
    return LongestFirst(config, log)

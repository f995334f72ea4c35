"""An action whose object ends off its path's end is named for why: it was not there when the
fingers let go, or it was and drifted after. Each cause is made to happen (a follower that leaves the
object where it is; the object pushed off its end as it is let go); everything else (the grasp, the
release, the settling) is the real run, and the real run untouched is the control."""

from __future__ import annotations

import numpy as np
import pytest

import manipulation.execution as execution
from manipulation.following import FollowResult, Stop
from manipulation.solution import Solution
from phyrogen_core.actions import split_actions

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def slider(tmp_path_factory):
    from phyrogen_core.export import read_puzzle_dir, write_puzzle
    from solver.pipelines.generation import generate_puzzle

    puzzle = generate_puzzle("simple_slider", 8402, {"n_objects": 2})  # a seed no other test uses
    return read_puzzle_dir(write_puzzle(puzzle, tmp_path_factory.mktemp("release")))


def _attempt(slider, monkeypatch, follow=None):
    from phyrogen_core.seeding import stable_seed
    from solver.planning.ompl_setup import seed_ompl

    seed_ompl(stable_seed("ompl", "release-labels", 8402))
    if follow is not None:
        monkeypatch.setattr(execution, "follow", follow)
    settings = execution.ExecutionSettings(max_regrasps_per_action=1, short_benchmark=None)
    path = np.asarray(slider.certificate, dtype=float)
    attempt, _, _ = execution.execute_solution(slider, Solution(path, "certificate", "certificate"), settings)
    return attempt


def _leaves_it(world, trajectory, *args, **kwargs):
    return FollowResult(Stop.WINDOW_ENDED, trajectory.duration, 0)


def test_an_object_never_brought_to_its_end_is_not_called_drifted(slider, monkeypatch):
    attempt = _attempt(slider, monkeypatch, _leaves_it)
    assert not attempt.success
    assert f"{execution.NOT_THERE} at t=" in attempt.message and execution.DRIFTED not in attempt.message


def test_an_object_that_leaves_its_end_after_release_drifted(slider, monkeypatch):
    certificate = np.asarray(slider.certificate, dtype=float)
    first = split_actions(certificate, {n: c for n, c in slider.chain.factors.items() if n != "goal"})[0]
    columns = list(first.columns)
    back = -np.sign(first.states[-1][columns] - first.states[0][columns])  # back the way it came: free
    settle = execution._Run.settle_released

    def pushed_off(self, in_place):
        if self.action_index == 0:
            state = self.sim.puzzle_state()
            state[columns] += 0.002 * back  # scene metres: 4 goal tolerances at the slider's scale
            self.sim.set_puzzle(state)
        return settle(self, in_place)

    monkeypatch.setattr(execution._Run, "settle_released", pushed_off)
    attempt = _attempt(slider, monkeypatch)
    assert not attempt.success
    assert f"{execution.DRIFTED} at t=" in attempt.message and execution.NOT_THERE not in attempt.message


def test_control_the_run_untouched_names_neither_cause(slider, monkeypatch):
    attempt = _attempt(slider, monkeypatch)
    assert attempt.success, attempt.message
    stops = [stop for report in attempt.action_reports for stop in report.stops]
    assert not [stop for stop in stops if execution.DRIFTED in stop or execution.NOT_THERE in stop], stops

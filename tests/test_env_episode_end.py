"""The Gymnasium environment after its episode's end: ``step()`` raises ``ResetNeeded`` until
``reset()``, Gymnasium's convention (docs/interop.md). Before, a step after the goal returned
reward 1 and ``terminated`` again, which a training loop counts as a second success.

The puzzle is the hostile-input tests' one (``hostile_support``), held in memory: its target
slides to the goal in a few steps along its two-state certificate.
"""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium.error import ResetNeeded
from hostile_support import hostile_puzzle

from phyrogen.env import PuzzleEnv


def to_goal(env: PuzzleEnv) -> tuple[float, bool, bool, int]:
    """Step along the certificate until the episode ends: (last reward, terminated, truncated, steps)."""
    steps, terminated, truncated, reward = 0, False, False, 0.0
    for waypoint in env.certificate[1:]:
        while not (terminated or truncated) and np.abs(env.state - waypoint).max() > 1e-9:
            if env.action_space.shape:
                action = env.action_towards(waypoint)
            else:  # discrete: one step up or down of the first joint that is not there yet
                joint = int(np.flatnonzero(np.abs(env.state - waypoint) > 1e-9)[0])
                action = 2 * joint + int(waypoint[joint] < env.state[joint])
            _, reward, terminated, truncated, _ = env.step(action)
            steps += 1
    return reward, terminated, truncated, steps


@pytest.mark.parametrize("action_mode", ["continuous", "discrete"])
def test_a_step_after_the_goal_needs_a_reset(action_mode):
    env = PuzzleEnv([hostile_puzzle()], action_mode=action_mode)
    env.reset(seed=0)
    reward, terminated, truncated, steps = to_goal(env)
    assert (reward, terminated, truncated) == (1.0, True, False) and steps >= 1
    action = env.action_space.sample()
    with pytest.raises(ResetNeeded, match=r"call reset\(\)"):
        env.step(action)
    with pytest.raises(ResetNeeded):  # still, until a reset
        env.step(action)
    # The control: after reset() the same action steps, from the start, without the goal.
    env.reset(seed=0)
    _, reward, terminated, _, _ = env.step(action)
    assert not terminated and reward == 0.0


def test_a_step_after_truncation_needs_a_reset():
    env = PuzzleEnv([hostile_puzzle()], max_episode_steps=3)
    env.reset(seed=0)
    zero = np.zeros(env.size, dtype=np.float32)
    assert [env.step(zero)[3] for _ in range(3)] == [False, False, True]
    with pytest.raises(ResetNeeded):
        env.step(zero)
    env.reset()
    assert env.step(zero)[3] is False


def test_set_state_lets_a_search_go_on_after_the_goal():
    # Search expands any state: set_state() starts from a new state, so step() is allowed again.
    env = PuzzleEnv([hostile_puzzle()])
    env.reset(seed=0)
    to_goal(env)
    env.set_state(env.certificate[0])
    _, reward, terminated, _, _ = env.step(np.zeros(env.size, dtype=np.float32))
    assert (reward, terminated) == (0.0, False)

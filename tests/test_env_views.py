"""The environment's observation modes, image and guided reward (phyrogen.env.views): the raster against the
exact collision model, Gymnasium's checker on every mode, the rgb_array image, reset options by value.

Puzzles: grid_world 8461, rooms 8462 (walls: fixed shapes), continuous_space 8463 (revolute bars), generated
here (seeds 8460-8469 are this file's; no other test uses them).
"""

from __future__ import annotations

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

from env_support import quiet_check  # noqa: E402

from phyrogen.env import ENV_ID, OBSERVATIONS, RASTER_CHANNELS, PuzzleEnv, PuzzleVectorEnv  # noqa: E402
from phyrogen_core.chain import Geometry  # noqa: E402
from phyrogen_core.geometry import Cylinder, Pose  # noqa: E402
from phyrogen_core.objects import Motion, PuzzleObject, build_chain  # noqa: E402
from solver.collision.model import CollisionModel  # noqa: E402
from solver.pipelines.generation import generate_here  # noqa: E402

PUZZLES = (("grid_world", 8461), ("rooms", 8462), ("continuous_space", 8463))
PROBE = PuzzleObject("probe", Motion.R2, Pose.planar(0.0, 0.0, 0.0), (), (Geometry(Cylinder(2e-6, 100.0)),),
                     limits=((-1e3, 1e3), (-1e3, 1e3)))
"""A needle standing through every z: it collides with a shape exactly where its axis pierces the outline."""


@pytest.fixture(scope="module")
def puzzles():
    return {f"{g}_{s}": generate_here(g, s) for g, s in PUZZLES}


def _probe_occupancy(puzzle, objects, env: PuzzleEnv, state: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """Per cell centre: whether the needle there meets one of ``objects`` at the env ``state`` (exact model)."""
    chain = build_chain([*objects, PROBE])
    model = CollisionModel(chain)
    values = {name: float(v) for name, v in zip(env.joint_order, state, strict=True)}
    base = [values.get(j.name, max(min(0.0, j.upper), j.lower)) for j in chain.active_joints
            if j.name in model.joint_order and not j.name.startswith("probe")]
    states = np.hstack([np.tile(base, (len(centres), 1)), centres])
    return ~model.check(states)


def _states_to_test(env: PuzzleEnv, rng: np.random.Generator) -> list[np.ndarray]:
    """The start, the certificate's middle, and where 40 random steps lead."""
    env.reset(seed=0)
    states = [env.state, env.certificate[len(env.certificate) // 2]]
    for _ in range(40):
        env.step(rng.uniform(-1, 1, env.size).astype(np.float32))
    return [*states, env.state]


@pytest.mark.parametrize("name", [f"{g}_{s}" for g, s in PUZZLES])
def test_the_raster_marks_a_cell_exactly_where_the_collision_model_finds_a_shape(puzzles, name):
    puzzle = puzzles[name]
    env = PuzzleEnv(puzzle, observation="raster", raster_size=24, max_episode_steps=None)
    view_of = env.unwrapped._task
    from phyrogen.env.views import raster_view

    view = raster_view(view_of, 24)
    size = view.frame.size
    centres = np.array([view.frame.centre(r, c) for r in range(size) for c in range(size)])
    target = [o for o in puzzle.objects if o.name == puzzle.goal.target]
    movable = [o for o in puzzle.objects if o.is_movable and o.name != puzzle.goal.target]
    fixed = [o for o in puzzle.objects if not o.is_movable]
    channels = {"target": target, "movable": movable, "fixed": fixed}
    rng = np.random.default_rng(8464)
    marked_somewhere = dict.fromkeys(channels, 0)
    for state in _states_to_test(env, rng):
        env.set_state(state)
        raster = env.unwrapped._observation()
        for channel, objects in channels.items():
            got = raster[RASTER_CHANNELS.index(channel)].reshape(-1) > 0
            if not objects:
                assert not got.any(), f"{name}: cells marked {channel} with no such object"
                continue
            exact = _probe_occupancy(puzzle, objects, env, state, centres)
            assert np.array_equal(got, exact), f"{name} {channel}: {np.sum(got != exact)} cells disagree"
            marked_somewhere[channel] += int(got.sum())
            # Negative control: the same raster shifted by one cell disagrees with the model.
            if got.any():
                shifted = np.roll(got.reshape(size, size), 1, axis=1).reshape(-1)
                assert not np.array_equal(shifted, exact)
    assert marked_somewhere["target"] > 0 and marked_somewhere["movable"] > 0
    if name.startswith("rooms"):
        assert marked_somewhere["fixed"] > 0  # the walls


def test_the_goal_channel_is_the_target_drawn_at_its_goal(puzzles):
    env = PuzzleEnv(puzzles["grid_world_8461"], observation="raster", max_episode_steps=None)
    env.reset(seed=0)
    goal = RASTER_CHANNELS.index("goal")
    target = RASTER_CHANNELS.index("target")
    for waypoint in env.certificate[1:]:
        while np.abs(env.state - waypoint).max() > 1e-9:
            obs, _, terminated, _, _ = env.step(env.action_towards(waypoint))
            if terminated:
                break
    # At the goal (within its 1 mm tolerance) the target covers its goal cells, give or take an edge.
    assert terminated
    assert np.sum(obs[goal] != obs[target]) <= 0.1 * obs[goal].sum()


@pytest.mark.parametrize("observation", OBSERVATIONS)
def test_check_env_passes_for_every_observation_mode(puzzles, observation):
    env = gym.make(ENV_ID, puzzle=[puzzles["rooms_8462"], puzzles["grid_world_8461"]], observation=observation,
                   reward="guided", raster_size=16, render_mode="rgb_array")
    quiet_check(env.unwrapped)
    obs, _ = env.reset(seed=3)
    assert env.observation_space.contains(obs)


def test_render_rgb_array_is_an_image_before_and_after_reset(puzzles):
    # As a user first tries it: no seed (the generator's seed 1), no reset.
    first = gym.make(ENV_ID, generator="grid_world", render_mode="rgb_array").render()
    assert first.ndim == 3 and first.shape[2] == 3 and first.dtype == np.uint8
    env = gym.make(ENV_ID, generator="grid_world", puzzle_seed=8465, render_mode="rgb_array")
    before = env.render()
    env.reset(seed=0)
    image = env.render()
    assert np.array_equal(before, image)  # the start state, before the first reset as after it
    assert not np.array_equal(first, image)  # another puzzle, another image
    assert image.shape[2] == 3 and image.ndim == 3 and image.dtype == np.uint8
    assert len(np.unique(image.reshape(-1, 3), axis=0)) >= 3  # background, target, goal at least
    # The image follows the state: the certificate's first move changes it.
    unwrapped = env.unwrapped
    env.step(unwrapped.action_towards(unwrapped.certificate[1]).astype(np.float32))
    assert not np.array_equal(env.render(), image)


def test_the_guided_reward_pays_the_certificate_and_sums_to_one_plus_progress(puzzles):
    env = PuzzleEnv(puzzles["continuous_space_8463"], reward="guided", max_episode_steps=None)
    env.reset(seed=0)
    rewards, info = [], {}
    for waypoint in env.certificate[1:]:
        while not info.get("is_success") and np.abs(env.state - waypoint).max() > 1e-9:
            _, reward, _, _, info = env.step(env.action_towards(waypoint))
            rewards.append(reward)
    assert info["is_success"] and sum(rewards) == pytest.approx(1.0 + info["progress"])
    assert info["progress"] > 0.5
    assert min(rewards[:-1]) > -1e-9  # following the certificate never loses progress
    # Control: moving back along the certificate's first segment is paid negatively.
    env.set_state(env.certificate[1])
    _, reward, *_ = env.step(env.action_towards(env.certificate[0]))
    assert reward < 0


def test_the_vector_env_pays_the_same_guided_rewards(puzzles):
    puzzle = puzzles["grid_world_8461"]
    single = PuzzleEnv(puzzle, reward="guided", max_episode_steps=50)
    vector = PuzzleVectorEnv(3, puzzle, reward="guided", max_episode_steps=50)
    single.reset(seed=0)
    vector.reset(seed=0)
    rng = np.random.default_rng(8466)
    for _ in range(30):
        actions = rng.uniform(-1, 1, (3, single.size))
        actions[0] = single.action_towards(single.certificate[-1])
        _, rewards, *_ = vector.step(actions)
        _, reward, terminated, *_ = single.step(actions[0])
        assert rewards[0] == pytest.approx(reward)
        if terminated:
            break


@pytest.mark.parametrize("bad", ["notadict", 3, ["puzzle", 0]])
def test_reset_options_that_are_not_a_dict_are_refused_by_value(puzzles, bad):
    env = PuzzleEnv(puzzles["grid_world_8461"])
    with pytest.raises(ValueError, match=repr(bad).replace("[", r"\[").replace("]", r"\]")):
        env.reset(options=bad)
    vector = PuzzleVectorEnv(2, puzzles["grid_world_8461"])
    with pytest.raises(ValueError, match="reset options must be a dict"):
        vector.reset(options=bad)
    assert env.reset(options={"puzzle": 0})[1]["puzzle"] == "grid_world_8461"  # a dict still works


def test_bad_observation_options_are_refused(puzzles):
    puzzle = puzzles["grid_world_8461"]
    with pytest.raises(ValueError, match="observation must be one of"):
        PuzzleEnv(puzzle, observation="pixels")
    with pytest.raises(ValueError, match="raster_size must be"):
        PuzzleEnv(puzzle, observation="raster", raster_size=2)
    with pytest.raises(ValueError, match="observes the vector only"):
        PuzzleVectorEnv(2, puzzle, observation="raster")

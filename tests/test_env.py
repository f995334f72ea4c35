"""The Gymnasium environment (phyrogen.env): API conformance, solutions through it, collisions, limits,
seeding, and the batched vector form against Gymnasium's own SyncVectorEnv.

Puzzles: grid_world 8400 and continuous_space 8401 in one dataset root, rooms 8402 generated through
``gym.make`` (seeds 8400-8499 are this file's; no other test uses them).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

from env_support import quiet_check  # noqa: E402
from gymnasium.utils.env_checker import check_env  # noqa: E402

from phyrogen.env import ENV_ID, STEP_LIMIT, PuzzleEnv, PuzzleVectorEnv  # noqa: E402
from solver.planning.problem import in_goal  # noqa: E402

DATASET = (("grid_world", 8400), ("continuous_space", 8401))


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """A dataset root holding two puzzle folders; (root, {name: folder})."""
    from solver.pipelines.generation import Job, run_jobs

    root = tmp_path_factory.mktemp("env_dataset")
    reports = list(run_jobs([Job(g, s) for g, s in DATASET], root, workers=2))
    assert not [r.error for r in reports if r.error]
    return root, {f"{r.generator}_{r.seed}": r.folder for r in reports}


def _replay(env: PuzzleEnv, max_steps: int = 10_000) -> tuple[int, float, list[dict]]:
    """Follow the certificate with action_towards; (steps, total reward, infos)."""
    total, infos = 0.0, []
    for waypoint in env.certificate[1:]:
        while np.abs(env.state - waypoint).max() > 1e-9:
            _, reward, terminated, truncated, info = env.step(env.action_towards(waypoint))
            total += reward
            infos.append(info)
            assert len(infos) < max_steps
            if terminated or truncated:
                return len(infos), total, infos
    return len(infos), total, infos


def test_check_env_passes_for_a_folder_env(dataset):
    _, folders = dataset
    env = gym.make(ENV_ID, puzzle=folders["grid_world_8400"])
    quiet_check(env.unwrapped)
    assert isinstance(env.unwrapped, PuzzleEnv)


def test_check_env_passes_for_a_generator_env():
    env = gym.make(ENV_ID, generator="rooms", puzzle_seed=8402, action_mode="discrete", reward="shaped",
                   render_mode="ansi")
    quiet_check(env.unwrapped)
    env.reset(seed=1)
    assert "rooms_8402" in env.render()


def test_check_env_passes_for_a_dataset_env(dataset):
    root, _ = dataset
    env = PuzzleEnv(root, on_collision="reject")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # no spec: check_env says it cannot test other render modes
        check_env(env)
    assert set(env.puzzle_names) == {f"{g}_{s}" for g, s in DATASET}


@pytest.mark.parametrize("reward", ["sparse", "shaped"])
def test_the_certificate_solves_the_puzzle_through_the_env(dataset, reward):
    root, _ = dataset
    env = PuzzleEnv(root, reward=reward, max_episode_steps=1000)
    for name in env.puzzle_names:
        env.reset(seed=0, options={"puzzle": name})
        steps, total, infos = _replay(env)
        task = env.unwrapped._task
        assert infos[-1]["is_success"] and infos[-1]["puzzle"] == name
        assert in_goal(task.problem, env.state)
        assert not any(i["collided"] for i in infos), f"{name}: the certificate collided through the env"
        assert steps < 1000
        # sparse: 1 at the goal; shaped: plus the goal distance's decrease over the start's, 1 in all.
        assert total == pytest.approx(1.0 if reward == "sparse" else 2.0, abs=1e-6)


def test_terminated_with_reward_one_at_the_goal():
    env = gym.make(ENV_ID, generator="grid_world", puzzle_seed=8403)
    env.reset(seed=5)
    unwrapped = env.unwrapped
    rewards, terminated = [], False
    for waypoint in unwrapped.certificate[1:]:
        while not terminated and np.abs(unwrapped.state - waypoint).max() > 1e-9:
            _, reward, terminated, truncated, _ = env.step(unwrapped.action_towards(waypoint).astype(np.float32))
            rewards.append(reward)
            assert not truncated
    assert terminated and rewards[-1] == 1.0 and set(rewards[:-1]) <= {0.0}


@pytest.mark.parametrize("on_collision", ["stop", "reject"])
def test_a_colliding_action_does_not_move_into_collision(dataset, on_collision):
    _, folders = dataset
    env = PuzzleEnv(folders["grid_world_8400"], on_collision=on_collision)
    env.reset(seed=0)
    task = env.unwrapped._task
    model, steps = task.model, task.steps
    # The target is blocked at the start: pushing it straight to its goal collides.
    goal = env.state
    for column, value in task.goal_pairs:
        goal[column] = value
    before = env.state
    _, _, terminated, _, info = env.step(env.action_towards(goal))
    assert info["collided"] and not terminated
    assert model.is_valid(env.state) and model.check_motion(before, env.state, steps)
    if on_collision == "reject":
        assert np.array_equal(env.state, before)
    # Random actions: every reached state is valid, and so is every motion the env made.
    rng = np.random.default_rng(8404)
    collided = 0
    for _ in range(300):
        before = env.state
        _, _, terminated, truncated, info = env.step(rng.uniform(-1, 1, env.size).astype(np.float32))
        collided += info["collided"]
        assert model.is_valid(env.state) and model.check_motion(before, env.state, steps)
        assert np.all(env.state >= task.lower) and np.all(env.state <= task.upper)
        if terminated or truncated:
            env.reset()
    assert collided > 0


def test_truncated_at_the_step_limit(dataset):
    _, folders = dataset
    env = PuzzleEnv(folders["continuous_space_8401"], max_episode_steps=7)
    env.reset(seed=0)
    flags = [env.step(np.zeros(env.size, dtype=np.float32))[2:4] for _ in range(7)]
    assert flags == [(False, False)] * 6 + [(False, True)]
    env.reset()
    assert env.step(np.zeros(env.size, dtype=np.float32))[3] is False
    # Through gym.make the limit is Gymnasium's TimeLimit: STEP_LIMIT as registered, or gym.make's own keyword.
    made = gym.make(ENV_ID, puzzle=folders["continuous_space_8401"], max_episode_steps=3)
    assert made.spec.max_episode_steps == 3 and gym.spec(ENV_ID).max_episode_steps == STEP_LIMIT
    made.reset(seed=0)
    zero = np.zeros(env.size, dtype=np.float32)
    assert [made.step(zero)[3] for _ in range(3)] == [False, False, True]
    unlimited = PuzzleEnv(folders["continuous_space_8401"], max_episode_steps=None)
    unlimited.reset(seed=0)
    assert not any(unlimited.step(zero)[3] for _ in range(500))


def test_reset_seed_picks_the_puzzle_deterministically(dataset):
    root, _ = dataset
    first, second = PuzzleEnv(root), PuzzleEnv(root)
    picks = []
    for env in (first, second):
        env.reset(seed=8405)
        picks.append([env.puzzle_name] + [env.reset()[1]["puzzle"] for _ in range(20)])
    assert picks[0] == picks[1]
    assert set(picks[0]) == set(first.puzzle_names)  # both puzzles come up
    obs_a, _ = first.reset(seed=8406)
    obs_b, _ = second.reset(seed=8406)
    assert np.array_equal(obs_a, obs_b) and first.puzzle_name == second.puzzle_name
    _, info = first.reset(options={"puzzle": "continuous_space_8401"})
    assert info["puzzle"] == "continuous_space_8401" == first.puzzle_name


def test_observation_layout(dataset):
    root, _ = dataset
    env = PuzzleEnv(root)
    size = env.size
    obs, _ = env.reset(options={"puzzle": "continuous_space_8401"})
    position, goal, mask, objects, kinds = obs.reshape(5, size)
    d = len(env.joint_order)
    assert d < size  # the smaller puzzle is padded
    assert np.array_equal(mask[:d], [1.0] + [0.0] * (d - 1))
    assert np.array_equal(objects[:d], np.arange(1, d + 1)) and not objects[d:].any()
    assert np.array_equal(kinds[:d], [2.0] * d) and not position[d:].any()
    assert -1.0 <= goal[0] <= 1.0 and obs in env.observation_space


def test_the_vector_env_agrees_with_sync_vector_env(dataset):
    root, _ = dataset
    for mode in ("continuous", "discrete"):
        kwargs = {"action_mode": mode, "max_episode_steps": 25, "reward": "shaped"}
        batch = PuzzleVectorEnv(6, root, **kwargs)
        sync = gym.vector.SyncVectorEnv([lambda kw=kwargs: PuzzleEnv(root, **kw) for _ in range(6)])
        obs_a, info = batch.reset(seed=8407)
        obs_b, _ = sync.reset(seed=8407)
        assert np.array_equal(obs_a, obs_b)
        assert len(set(info["puzzle"])) == 2  # both puzzles in play: one kernel call per puzzle
        batch.action_space.seed(8408)
        for _ in range(80):  # several episodes: next-step autoreset, several puzzles at once
            actions = batch.action_space.sample()
            got, want = batch.step(actions), sync.step(actions)
            for a, b in zip(got[:4], want[:4], strict=True):
                assert np.array_equal(a, b)
            if "collided" in want[4]:
                stepped = want[4]["_collided"]
                assert np.array_equal(got[4]["_collided"], stepped)
                assert np.array_equal(got[4]["collided"][stepped], want[4]["collided"][stepped])


def test_make_vec_gives_the_batched_vector_env(dataset):
    _, folders = dataset
    envs = gym.make_vec(ENV_ID, num_envs=3, puzzle=folders["grid_world_8400"])
    assert isinstance(envs.unwrapped, PuzzleVectorEnv)
    obs, _ = envs.reset(seed=0)
    assert obs.shape == (3, 5 * envs.unwrapped.size) and obs in envs.observation_space
    envs.close()


def test_bad_input_is_a_one_line_value_error(dataset, tmp_path):
    _, folders = dataset
    folder = folders["grid_world_8400"]
    cases = [
        (lambda: PuzzleEnv(tmp_path / "missing"), "no such folder"),
        (lambda: PuzzleEnv(generator="no_such_generator", puzzle_seed=1), "unknown generator"),
        (lambda: PuzzleEnv(generator="grid_world", puzzle_seed="7"), "puzzle_seed"),
        (lambda: PuzzleEnv(generator="grid_world", puzzle_seed=[]), "puzzle_seed"),
        (lambda: PuzzleEnv(), "no puzzle"),
        (lambda: PuzzleEnv(folder, reward="dense"), "reward must be one of"),
        (lambda: PuzzleEnv(folder, max_episode_steps=0), "max_episode_steps"),
        (lambda: PuzzleEnv(folder, max_move=float("nan")), "max_move"),
    ]
    for make, words in cases:
        with pytest.raises(ValueError, match=words) as caught:
            make()
        assert "\n" not in str(caught.value)
    env = PuzzleEnv(folder)
    env.reset(seed=0)
    state = env.state
    for action in (np.full(env.size, np.nan), np.array([np.inf] + [0.0] * (env.size - 1)), np.zeros(env.size + 1)):
        with pytest.raises(ValueError, match="finite|shape"):
            env.step(action)
    assert np.array_equal(env.state, state)
    discrete = PuzzleEnv(folder, action_mode="discrete")
    discrete.reset(seed=0)
    with pytest.raises(ValueError, match="int in"):
        discrete.step(2 * discrete.size)
    with pytest.raises(ValueError, match="not a puzzle of this environment"):
        env.reset(options={"puzzle": "grid_world_1"})


def test_set_state_refuses_collisions_and_limits(dataset):
    _, folders = dataset
    env = PuzzleEnv(folders["grid_world_8400"])
    env.reset(seed=0)
    task = env.unwrapped._task
    with pytest.raises(ValueError, match="limits"):
        env.set_state(task.upper + 1.0)
    colliding = next(s for s in np.random.default_rng(8409).uniform(task.lower, task.upper, (500, task.d))
                     if not task.model.is_valid(s))
    with pytest.raises(ValueError, match="collision"):
        env.set_state(colliding)
    obs = env.set_state(env.certificate[-2])
    assert obs in env.observation_space


def test_every_kind_of_puzzle_source_gives_the_same_puzzles(dataset):
    import phyrogen

    root, folders = dataset
    names = sorted(folders)
    from_root = PuzzleEnv(root)
    from_list = PuzzleEnv([folders[n] for n in names])
    from_loaded = PuzzleEnv([phyrogen.load(folders[n]) for n in names])
    for env in (from_root, from_list, from_loaded):
        assert sorted(env.puzzle_names) == names
        for name in names:
            obs, _ = env.reset(seed=0, options={"puzzle": name})
            assert np.array_equal(obs, from_root.reset(seed=0, options={"puzzle": name})[0])
            assert np.array_equal(env.certificate, from_root.certificate)

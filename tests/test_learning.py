"""Learning on PhyRoGen puzzles: the curriculum env, the async vector env with generated puzzles, and the
reference learner (Stable-Baselines3 PPO, scripts/train.py) run for a few hundred steps.

Seeds 8470-8499 are this file's (no other test uses them); Grid World of 1-2 objects, 0.05 CPU s each.
"""

from __future__ import annotations

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

from env_support import quiet_check  # noqa: E402

from phyrogen.env import CURRICULUM_ID, ENV_ID, CurriculumEnv, CurriculumSchedule  # noqa: E402

SEEDS = [8470, 8471, 8472]


def _solve(env: CurriculumEnv) -> tuple[bool, dict]:
    """Play one episode by following the current puzzle's certificate."""
    inner = env.puzzle_env
    info: dict = {}
    for waypoint in inner.certificate[1:]:
        while np.abs(inner.state - waypoint).max() > 1e-9:
            _, _, terminated, truncated, info = env.step(inner.action_towards(waypoint).astype(np.float32))
            if terminated or truncated:
                return terminated, info
    raise AssertionError("the certificate ended short of the goal")


def _fail(env: CurriculumEnv) -> tuple[bool, dict]:
    """Play one episode standing still until the step limit."""
    while True:
        _, _, terminated, truncated, info = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
        if terminated or truncated:
            return terminated, info


def test_the_schedule_raises_and_lowers_at_its_thresholds():
    schedule = CurriculumSchedule((1, 2, 3), window=4, raise_above=0.75, lower_below=0.25)
    assert schedule.next_level(0, [True] * 3) == 0  # fewer than a window: no change
    assert schedule.next_level(0, [False, True, True, True]) == 1
    assert schedule.next_level(0, [True, False, True, False]) == 0  # between the thresholds
    assert schedule.next_level(2, [True] * 4) == 2  # the top level stays
    assert schedule.next_level(1, [False, False, False, True]) == 0
    assert schedule.next_level(0, [False] * 4) == 0  # the bottom level stays
    with pytest.raises(ValueError, match="lower_below < raise_above"):
        CurriculumSchedule((1, 2), raise_above=0.2, lower_below=0.5)


def test_the_curriculum_follows_scripted_successes_up_and_failures_down():
    env = CurriculumEnv("grid_world", levels=(1, 2), puzzle_seed=SEEDS, window=2, raise_above=1.0, lower_below=0.0,
                        observation="vector", max_episode_steps=200)
    env.reset(seed=8473)
    played = []
    for outcome in ("win", "win", "win", "win", "lose", "lose", "win"):
        level = env.level
        success, info = _solve(env) if outcome == "win" else _fail(env)
        assert success == (outcome == "win") and info["level"] == level
        played.append(level)
        env.reset()
    # Two wins raise 1 -> 2; wins at the top keep it; two losses lower 2 -> 1; one win is not a window.
    assert played == [1, 1, 2, 2, 2, 2, 1]
    assert env.level == 1
    # Puzzles at level 2 have two objects: the knob reached the generator.
    assert {len(e.objects) for (level, _), e in env._made.items() if level == 1} == {2}


def test_the_curriculum_draws_its_puzzles_from_its_seed():
    def names(seed):
        env = CurriculumEnv("grid_world", levels=(1,), puzzle_seed=SEEDS, observation="vector")
        out = []
        for i in range(6):
            out.append(env.reset(seed=seed if i == 0 else None)[1]["puzzle"])
        return out

    assert names(8474) == names(8474)
    assert len(set(names(8474)) | set(names(8475))) > 1


def test_the_curriculum_skips_a_seed_it_cannot_generate_and_says_so():
    # Simple Slider's n_objects must lie in 1..50; a level of 60 cannot be generated at any seed.
    with pytest.raises(RuntimeError, match="no puzzle at n_objects=60"):
        CurriculumEnv("simple_slider", levels=(1, 60), puzzle_seed=SEEDS)
    env = CurriculumEnv("simple_slider", levels=(1, 60), puzzle_seed=SEEDS, max_joints=3, window=1,
                        raise_above=0.5, lower_below=0.0, observation="vector", max_episode_steps=100)
    env.reset(seed=1)
    _solve(env)
    with pytest.raises(RuntimeError, match="gave no puzzle"):
        env.reset()


def test_check_env_passes_for_the_curriculum_env():
    env = gym.make(CURRICULUM_ID, levels=(1, 2), puzzle_seed=SEEDS, raster_size=16, render_mode="rgb_array")
    quiet_check(env.unwrapped)
    obs, info = env.reset(seed=0)
    assert set(obs) == {"raster", "vector"} and info["level"] == 1
    image = env.render()
    assert image.dtype == np.uint8 and image.shape[2] == 3
    with pytest.raises(ValueError, match="'notadict'"):
        env.reset(options="notadict")


@pytest.mark.parametrize("env_id, kwargs", [
    (ENV_ID, {"generator": "grid_world", "puzzle_seed": [8476, 8477], "params": {"n_objects": 2},
              "observation": "geometry"}),
    (CURRICULUM_ID, {"levels": (1, 2), "puzzle_seed": SEEDS, "raster_size": 16}),
])
def test_the_async_vector_env_steps_with_generated_puzzles(env_id, kwargs):
    # Gymnasium's async workers are daemonic processes, which may not start the generation's worker pool.
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode="async", **kwargs)
    try:
        obs, _ = envs.reset(seed=0)
        assert obs["raster"].shape[0] == 2
        for _ in range(5):
            obs, rewards, terminated, truncated, info = envs.step(envs.action_space.sample())
        assert np.isfinite(rewards).all() and envs.observation_space.contains(obs)
    finally:
        envs.close()


def test_ppo_trains_a_few_hundred_steps_on_the_curriculum():
    pytest.importorskip("stable_baselines3")
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    torch.set_num_threads(1)

    def make():
        return CurriculumEnv("grid_world", levels=(1, 2), puzzle_seed=SEEDS, raster_size=8, action_mode="discrete",
                             max_episode_steps=30)

    def train(seed):
        venv = DummyVecEnv([make, make])
        model = PPO("MultiInputPolicy", venv, n_steps=64, batch_size=64, n_epochs=1, seed=seed, device="cpu")
        model.learn(256)
        assert model.num_timesteps == 256
        action, _ = model.predict(venv.reset(), deterministic=True)
        assert action.shape == (2,)
        return torch.cat([p.detach().flatten() for p in model.policy.parameters()])

    # Reproducible by seed (PyTorch on one thread); another seed trains another policy.
    first = train(0)
    assert torch.equal(first, train(0))
    assert not torch.equal(first, train(1))


@pytest.mark.slow
def test_the_training_script_writes_its_table_and_curves(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    import importlib.util
    import json
    from pathlib import Path

    path = Path(__file__).resolve().parent.parent / "scripts" / "train.py"
    spec = importlib.util.spec_from_file_location("train_script", path)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    out = tmp_path / "run"
    assert script.main(["--out", str(out), "--arms", "fixed,curriculum", "--train-sizes", "1", "--train-seeds", "2",
                        "--heldout-seeds", "2", "--steps", "256", "--evals", "1", "--curve-puzzles", "2",
                        "--planner-checks", "500", "--envs", "2", "--raster-size", "8"]) == 0
    results = json.loads((out / "results.json").read_text())
    assert set(results["arms"]) == {"fixed", "curriculum"} and set(results["rows"]) == {"random", "LA-RRT"}
    assert len(results["rows"]["LA-RRT"]) == 4  # 2 held-out seeds at size 1 and at size 2
    assert (out / "curves.png").stat().st_size > 0 and "LA-RRT" in (out / "table.md").read_text()
    with pytest.raises(SystemExit) as exc:
        script.main(["--out", str(out), "--arms", "nonsense"])
    assert exc.value.code == 2 and "unknown arm 'nonsense'" in capsys.readouterr().err

"""Learners from other libraries (issue 44): outside code runs on the environments unchanged.

Gymnasium's own vector wrappers run per agent on :func:`mgrao_core.env.vector_env` (:mod:`mgrao_core.per_agent`),
each agent's numbers equal to what the wrapper computes from that agent's observations and rewards alone; and
SuperSuit's vector conversion of :func:`mgrao_core.env.parallel_env` runs the training loop of
examples/supersuit_learner.py, with the numbers of examples/independent_learner.py on the same seeds.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from gymnasium.wrappers.utils import RunningMeanStd
from gymnasium.wrappers.vector import ClipAction, NormalizeObservation, RecordEpisodeStatistics

from mgrao_core.env import parallel_env, vector_env
from mgrao_core.per_agent import per_agent

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
WORLDS, EPISODES = 4, 5


def _example(name: str):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _actions(env):
    return {agent: np.stack([np.linspace(1.0, 2.0 + i + c, 20) for i in range(env.num_envs)])
            for c, agent in enumerate(env.possible_agents)}


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_gymnasiums_record_episode_statistics_counts_each_agents_own_returns(mode):
    env = vector_env("multi", seeds=range(WORLDS), episodes=EPISODES, autoreset_mode=mode)
    raw = vector_env("multi", seeds=range(WORLDS), episodes=EPISODES, autoreset_mode=mode)
    wrapped = per_agent(env, RecordEpisodeStatistics)
    actions = _actions(env)
    wrapped.reset(seed=3)
    raw.reset(seed=3)
    returns = {agent: np.zeros(WORLDS) for agent in env.possible_agents}
    ended = {agent: [] for agent in env.possible_agents}
    for t in range(2 * EPISODES + (mode is AutoresetMode.NEXT_STEP)):
        observations, rewards, terminations, truncations, infos = wrapped.step(actions)
        expected = raw.step(actions)
        restarting = mode is AutoresetMode.NEXT_STEP and t == EPISODES  # the step that starts the worlds afresh
        for agent in env.possible_agents:
            for got, want in zip((observations, rewards, terminations, truncations), expected[:4], strict=True):
                np.testing.assert_equal(got[agent], want[agent])  # the wrapper changes none of them
            info = infos[agent]
            if not restarting:
                returns[agent] += rewards[agent]
                np.testing.assert_array_equal(info["episode_index"], expected[4][agent]["episode"])
            if truncations[agent].any():
                assert info["_episode"].all() and (info["episode"]["l"] == EPISODES).all()
                np.testing.assert_array_equal(info["episode"]["r"], returns[agent])  # this agent's return alone
                ended[agent].extend(returns[agent].tolist())
                returns[agent][:] = 0.0
            else:
                assert "episode" not in info
    for agent in env.possible_agents:
        assert list(wrapped.wrapped[agent].return_queue) == ended[agent] and len(ended[agent]) == 2 * WORLDS
    assert len(set(ended["child_0"])) == 2 * WORLDS  # two runs of four worlds each, the second of fresh worlds


def test_gymnasiums_normalize_observation_keeps_each_agents_running_mean():
    env = vector_env("multi", seeds=range(WORLDS), episodes=EPISODES, flatten=True)
    raw = vector_env("multi", seeds=range(WORLDS), episodes=EPISODES, flatten=True)
    wrapped = per_agent(env, lambda view: NormalizeObservation(RecordEpisodeStatistics(view)))
    assert all(wrapped.single_observation_space(agent).dtype == np.float32 for agent in wrapped.possible_agents)
    statistics = {agent: RunningMeanStd(shape=env.single_observation_space(agent).shape, dtype=np.float32)
                  for agent in env.possible_agents}  # the wrapper's own (float32), fed with one agent's observations

    def check(observations, expected):
        for agent, rms in statistics.items():
            rms.update(expected[agent])
            want = ((expected[agent] - rms.mean) / np.sqrt(rms.var + 1e-8)).astype(np.float32)
            np.testing.assert_array_equal(observations[agent], want, err_msg=agent)

    actions = _actions(env)
    check(wrapped.reset()[0], raw.reset()[0])
    for _ in range(2 * EPISODES + 1):
        check(wrapped.step(actions)[0], raw.step(actions)[0])
    # Gymnasium's own checks pass through: NormalizeObservation takes no partial reset (nothing is reset) ...
    seeds = env.world_seeds
    with pytest.raises(ValueError, match="NormalizeObservation does not support partial resets"):
        wrapped.reset(options={"reset_mask": np.array([True, False, False, False])})
    assert env.world_seeds == seeds and env.world_episodes.tolist() == [EPISODES] * WORLDS
    # ... nor same-step autoreset
    with pytest.raises(ValueError, match="Expected .*autoreset_mode.* to be (AutoresetMode.)?NEXT_STEP"):
        per_agent(vector_env("multi", seeds=range(2), flatten=True, autoreset_mode="SameStep"), NormalizeObservation)


def test_record_episode_statistics_through_a_partial_reset():
    env = vector_env("single", seeds=range(3), episodes=EPISODES, autoreset_mode="Disabled")
    wrapped = per_agent(env, RecordEpisodeStatistics)
    wrapped.reset()
    actions = _actions(env)
    rewards = [wrapped.step(actions)[1]["child_0"] for _ in range(2)]
    options = {"reset_mask": np.array([False, True, False])}
    wrapped.reset(options=options)
    assert "reset_mask" in options  # each agent's wrappers took their own copy
    for _ in range(EPISODES - 2):
        rewards.append(wrapped.step(actions)[1]["child_0"])
    statistics = wrapped.wrapped["child_0"]
    assert list(statistics.return_queue) == [sum(r[i] for r in rewards) for i in (0, 2)]  # worlds 0 and 2 ended
    assert statistics.episode_returns[1] == sum(r[1] for r in rewards[2:])  # world 1 since its reset


def test_an_action_wrapper_is_refused_naming_the_agent_and_nothing_is_stepped():
    env = vector_env("single", seeds=range(2), episodes=3)
    wrapped = per_agent(env, ClipAction)
    wrapped.reset()
    with pytest.raises(RuntimeError, match="child_0: a wrapper changed the action on its way"):
        wrapped.step({"child_0": np.full((2, 20), 2.0)})  # ClipAction clips it: a new array
    assert env.episode == 0
    with pytest.raises(RuntimeError, match="child_0: its view answers the PerAgent's step under way"):
        wrapped.views["child_0"].step(np.ones((2, 20)))
    with pytest.raises(ValueError, match="no action for child_0"):
        wrapped.step({})


def test_supersuits_vector_conversion_runs_the_example_training_loop_with_the_same_numbers():
    trained = _example("supersuit_learner").train("multi", 3, 3, 6)
    independent = _example("independent_learner")
    assert [seed for seed, _, _ in trained] == [3, 4, 5]
    for seed, utilities, weights in trained:
        assert (utilities, weights) == independent.train("multi", seed, 6), seed  # the adapter changes nothing


def test_supersuit_starts_each_copy_afresh_as_parallel_envs_reset_does():
    import supersuit

    vector = supersuit.concat_vec_envs_v1(supersuit.pettingzoo_env_to_vec_env_v1(parallel_env("single", episodes=2)),
                                          2, num_cpus=0, base_class="gymnasium")
    vector.reset(seed=8)
    for _ in range(2):
        vector.step(np.ones((2, 20)))
    expected = []
    for seed in (8, 9):
        single = parallel_env("single", seed=seed, episodes=2)
        single.reset()
        single.reset()
        expected.append(single.world_seed)
    assert [copy.par_env.world_seed for copy in vector.vec_envs] == expected


def test_gymnasiums_own_vectoriser_and_statistics_run_on_the_single_agent_env():
    # Gymnasium's RecordEpisodeStatistics refused its info at an episode's end: the info's "episode" (the index)
    # is the key it writes its statistics under (the index is now "episode_index" there)
    import gymnasium
    from gymnasium.wrappers import RecordEpisodeStatistics as RecordOne

    from mgrao_core.env import single_agent_env

    one = RecordOne(single_agent_env("single", episodes=3))
    one.reset(seed=4)
    for _ in range(2):
        one.step(np.ones(20))
    *_, truncated, info = one.step(np.ones(20))
    assert truncated and info["episode_index"] == 2 and info["episode"]["l"] == 3
    envs = RecordEpisodeStatistics(gymnasium.vector.SyncVectorEnv(
        [lambda: single_agent_env("single", episodes=3) for _ in range(2)]))
    envs.reset(seed=4)
    for _ in range(3):
        *_, infos = envs.step(np.ones((2, 20)))
    assert infos["_episode"].all() and infos["episode"]["r"][0] == pytest.approx(one.return_queue[0], abs=1e-12)
    assert infos["episode_index"].tolist() == [2, 2]

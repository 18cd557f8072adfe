"""mgrao_core.env.vector_env follows Gymnasium's vector API wherever it has a meaning for many agents (issue 44).

Each world of the vector environment is :func:`parallel_env` of its seed, step for step, through autoresets and
partial resets too: a world that starts afresh without a seed takes the world ``parallel_env``'s ``reset()``
would, and a world reset apart from the others is a fresh world of its seed while the others go on as if nothing
happened (:class:`mgrao_core.stepper.SteppedWorlds.renew`).
"""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from mgrao_core import ConfigError
from mgrao_core.env import OBSERVATION_KEYS, parallel_env, system_params, vector_env
from mgrao_core.stepper import SteppedWorlds

SEEDS = (5, 6, 7)
EPISODES = 4


def _actions(env):
    """Fixed actions, a different one per child and world (the same in parallel_env: row ``i`` is world ``i``'s)."""
    n, shape = env.n_worlds, env.single_action_space(env.possible_agents[0]).shape
    return {agent: np.stack([np.linspace(1.0, 2.0 + i + c, shape[-1]) for i in range(n)])
            for c, agent in enumerate(env.possible_agents)}


def _parallel_runs(system, seed, runs, actions, episodes=EPISODES):
    """``parallel_env(seed=seed)`` reset with the seed, then ``runs - 1`` times without: each run's steps and seed."""
    env = parallel_env(system, seed=seed, episodes=episodes)
    played = []
    for run in range(runs):
        env.reset(seed=seed if run == 0 else None)
        steps = []
        while env.agents:
            steps.append(env.step(actions))
        played.append((env.world_seed, steps))
    return played


def _assert_world_is(vector_step, i, single_step, agents):
    observations, rewards, terminations, truncations, infos = vector_step
    obs, rew, term, trunc, info = single_step
    for agent in agents:
        for key in OBSERVATION_KEYS:
            np.testing.assert_array_equal(observations[agent][key][i], obs[agent][key], err_msg=key)
        assert (rewards[agent][i], terminations[agent][i], truncations[agent][i]) == (rew[agent], term[agent],
                                                                                      trunc[agent])
        assert (infos[agent]["utility"][i], infos[agent]["episode"][i]) == (info[agent]["utility"],
                                                                            info[agent]["episode"])
        assert infos[agent]["_utility"][i] and infos[agent]["_episode"][i]


def test_the_vector_attributes_and_each_agents_single_spaces():
    for flatten in (False, True):
        env = vector_env("multi", seeds=SEEDS, episodes=EPISODES, flatten=flatten)
        assert env.num_envs == env.n_worlds == 3
        assert env.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP  # Gymnasium's default
        for agent in env.possible_agents:
            # Gymnasium's batching of one world's spaces, the world axis first
            assert env.observation_space(agent) == batch_space(env.single_observation_space(agent), 3)
            assert env.action_space(agent) == batch_space(env.single_action_space(agent), 3)
            assert env.single_observation_space(agent) == parallel_env("multi", episodes=EPISODES,
                                                                       flatten=flatten).observation_space(agent)
        observations, _ = env.reset()
        assert all(env.observation_space(agent).contains(observations[agent]) for agent in env.possible_agents)
    for mode in AutoresetMode:
        for given in (mode, mode.value):
            assert vector_env("single", seeds=[0], autoreset_mode=given).metadata["autoreset_mode"] is mode
    with pytest.raises(ConfigError) as error:
        vector_env("single", seeds=[0], autoreset_mode="next-step")
    assert error.value.field == "autoreset_mode" and "NextStep, SameStep, Disabled" in error.value.message


def test_next_step_autoreset_starts_each_world_as_parallel_envs_next_reset_would():
    # stepping after a world's last episode raised "call reset() first" (issue 44, item 1)
    env = vector_env("multi", seeds=SEEDS, episodes=EPISODES)
    actions = _actions(env)
    singles = [_parallel_runs("multi", seed, 3, {a: x[i] for a, x in actions.items()}) for i, seed in enumerate(SEEDS)]
    env.reset()
    for run in range(3):
        if run:  # the step after the last episode: every world starts afresh, nothing is played
            observations, rewards, terminations, truncations, infos = env.step(actions)
            assert infos == {agent: {} for agent in env.possible_agents} and env.agents == env.possible_agents
            for agent in env.possible_agents:
                assert not rewards[agent].any() and not terminations[agent].any() and not truncations[agent].any()
                assert not observations[agent]["received"].any() and not observations[agent]["episode"].any()
        assert env.world_seeds == tuple(single[run][0] for single in singles)
        for t in range(EPISODES):
            step = env.step(actions)
            for i, single in enumerate(singles):
                _assert_world_is(step, i, single[run][1][t], env.possible_agents)
        assert env.agents == []  # every world ended together (PettingZoo's loops stop here)
    assert len(set(env.world_seeds) | set(SEEDS)) == 6  # fresh worlds, not the constructor's again


def test_same_step_autoreset_returns_the_fresh_world_and_keeps_the_last_in_the_infos():
    same = vector_env("multi", seeds=SEEDS, episodes=EPISODES, flatten=True, autoreset_mode="SameStep")
    nxt = vector_env("multi", seeds=SEEDS, episodes=EPISODES, flatten=True)
    actions = _actions(same)
    same.reset()
    nxt.reset()
    for _ in range(EPISODES - 1):
        for a, b in zip(same.step(actions), nxt.step(actions), strict=True):
            for agent in same.possible_agents:
                np.testing.assert_equal(a[agent], b[agent])
    observations, rewards, _, truncations, infos = same.step(actions)
    last, last_rewards, _, last_truncations, last_infos = nxt.step(actions)
    fresh, *_ = nxt.step(actions)  # next-step: the fresh worlds a step later
    assert same.agents == same.possible_agents and same.world_seeds == nxt.world_seeds
    for agent in same.possible_agents:
        info = infos[agent]
        np.testing.assert_array_equal(observations[agent], fresh[agent])
        np.testing.assert_array_equal(rewards[agent], last_rewards[agent])
        assert truncations[agent].all() and last_truncations[agent].all()
        assert info["_final_obs"].all() and info["_final_info"].all() and not info["_utility"].any()
        for i in range(3):
            np.testing.assert_array_equal(info["final_obs"][i], last[agent][i])
        np.testing.assert_array_equal(info["final_info"]["utility"], last_infos[agent]["utility"])
        np.testing.assert_array_equal(info["final_info"]["episode"], last_infos[agent]["episode"])
    for a, b in zip(same.step(actions), nxt.step(actions), strict=True):
        for agent in same.possible_agents:
            np.testing.assert_equal(a[agent], b[agent])


def test_a_partial_reset_restarts_those_worlds_and_the_others_go_on_untouched():
    # reset(options={"reset_mask": ...}) was refused (issue 47) and, before that, reset every world (issue 44, item 1)
    episodes = 9
    env = vector_env("volatile", seeds=SEEDS, episodes=episodes, autoreset_mode="Disabled")
    whole = vector_env("volatile", seeds=SEEDS, episodes=episodes)
    actions = _actions(env)
    env.reset()
    whole.reset()
    for _ in range(3):
        env.step(actions)
        before = whole.step(actions)
    options = {"reset_mask": np.array([False, True, False])}
    observations, infos = env.reset(seed=[None, 11, None], options=options)
    assert options["reset_mask"].tolist() == [False, True, False]  # the caller's options are left as they were
    assert env.world_seeds == (5, 11, 7) and infos == {"child_0": {}} and env.world_episodes.tolist() == [3, 0, 3]
    for key in OBSERVATION_KEYS:
        np.testing.assert_array_equal(observations["child_0"][key][[0, 2]], before[0]["child_0"][key][[0, 2]])
    assert not observations["child_0"]["received"][1].any() and observations["child_0"]["episode"][1] == 0
    single = _parallel_runs("volatile", 11, 1, {"child_0": actions["child_0"][1]}, episodes)[0][1]
    for t in range(episodes - 3):  # mid-block: world 1's draws from here on are seed 11's first
        step = env.step(actions)
        _assert_world_is(step, 1, single[t], ["child_0"])
        reference = whole.step(actions)
        for i in (0, 2):
            for key in OBSERVATION_KEYS:
                np.testing.assert_array_equal(step[0]["child_0"][key][i], reference[0]["child_0"][key][i])
            assert step[1]["child_0"][i] == reference[1]["child_0"][i]
    assert step[3]["child_0"].tolist() == [True, False, True]
    with pytest.raises(RuntimeError, match="worlds 0, 2 ended \\(autoreset is disabled: reset them"):
        env.step(actions)
    env.reset(options={"reset_mask": np.array([True, False, True])})  # fresh worlds: parallel_env's next
    assert env.world_seeds == (_parallel_runs("volatile", 5, 2, {"child_0": actions["child_0"][0]})[1][0], 11,
                               _parallel_runs("volatile", 7, 2, {"child_0": actions["child_0"][2]})[1][0])
    step = env.step(actions)
    _assert_world_is(step, 1, single[episodes - 3], ["child_0"])


@pytest.mark.parametrize("options, field, match", [
    ({"reset_mask": np.array([True, False])}, "options.reset_mask", "must be 3 booleans, one per world"),
    ({"reset_mask": np.array([1, 0, 1])}, "options.reset_mask", "must be 3 booleans"),
    ({"reset_mask": np.zeros(3, bool)}, "options.reset_mask", "at least one True"),
    ({"reset_mask": "all"}, "options.reset_mask", "must be 3 booleans"),
    ({"reset_mask": np.ones(3, bool), "b": 1}, "options", "unknown option b: this environment takes reset_mask only"),
    ({"options": 1, "b": 1}, "options", "unknown options b, options: this environment takes reset_mask only"),
    (["reset_mask"], "options", "must be a dict of options or None \\(got list\\)"),
])
def test_a_reset_refuses_options_it_would_not_honour_naming_them_and_resets_nothing(options, field, match):
    env = vector_env("single", seeds=SEEDS, episodes=3)
    with pytest.raises(ConfigError) as error:
        env.reset(options={"reset_mask": np.ones(3, bool)})
    assert error.value.field == "options.reset_mask" and "first reset() starts every world" in error.value.message
    env.reset()
    env.step(_actions(env))
    with pytest.raises(ConfigError, match=match) as error:
        env.reset(options=options)
    assert error.value.field == field
    assert env.episode == 1 and env.world_seeds == SEEDS  # nothing reset
    with pytest.raises(ConfigError) as error:
        env.reset(seed=[None, 3, 3], options={"reset_mask": np.ones(3, bool)})
    assert error.value.field == "seed" and env.world_episodes.tolist() == [1, 1, 1]


def test_an_unseeded_reset_gives_fresh_worlds_as_parallel_env_and_gymnasium_do():
    # reset() after reset(seed=[10, 11, 12]) replayed the constructor's worlds 5, 6, 7 (issue 44, item 2)
    env = vector_env("volatile", seeds=SEEDS, episodes=2)
    env.reset()
    assert env.world_seeds == SEEDS  # the first reset without a seed: the constructor's
    env.reset(seed=[10, 11, 12])
    env.reset()
    expected = []
    for seed in (10, 11, 12):
        single = parallel_env("volatile", seed=0, episodes=2)
        single.reset(seed=seed)
        single.reset()
        expected.append(single.world_seed)
    assert env.world_seeds == tuple(expected) and not set(expected) & {5, 6, 7, 10, 11, 12}
    env.reset(seed=20)
    assert env.world_seeds == (20, 21, 22)  # a seeded reset: the engine's seeds, exactly


def test_call_and_get_attr_answer_for_each_world():
    env = vector_env("volatile", seeds=SEEDS, episodes=3, flatten=True, autoreset_mode="Disabled")
    assert env.get_attr("world_seed") == (None, None, None) and env.get_attr("seed") == SEEDS
    env.reset()
    env.step(_actions(env))
    env.reset(seed=[None, 9, None], options={"reset_mask": np.array([False, True, False])})
    assert env.get_attr("world_seed") == (5, 9, 7) and env.call("episode") == (1, 0, 1)
    assert env.get_attr("episodes") == (3, 3, 3) and env.get_attr("params") == (env.params,) * 3
    assert env.call("observation_space", "child_0") == (env.single_observation_space("child_0"),) * 3
    states = env.call("state")
    assert len(states) == 3 and all((state == row).all() for state, row in zip(states, env.state(), strict=True))
    assert env.call("render") == (None,) * 3
    for name in ("step", "reset", "nothing", "_worlds"):
        with pytest.raises(AttributeError, match=f"call: '{name}' is nothing a world answers on its own"):
            env.call(name)


def test_float32_observations_on_request_the_spaces_to_match():
    actions = _actions(vector_env("multi", seeds=SEEDS))
    for flatten in (False, True):
        wide = vector_env("multi", seeds=SEEDS, episodes=3, flatten=flatten)
        narrow = vector_env("multi", seeds=SEEDS, episodes=3, flatten=flatten, dtype=np.float32)
        assert wide.dtype == np.float64 and narrow.dtype == np.float32
        pairs = [(wide.reset()[0], narrow.reset()[0])]
        while narrow.agents:
            pairs.append((wide.step(actions)[0], narrow.step(actions)[0]))
        for agent in narrow.possible_agents:
            space = narrow.observation_space(agent)
            for a, b in pairs:
                assert space.contains(b[agent])
                if flatten:
                    assert b[agent].dtype == np.float32 and space.dtype == np.float32
                    np.testing.assert_array_equal(b[agent], a[agent].astype(np.float32))
                    continue
                for key in ("value", "allocation", "resources"):
                    assert b[agent][key].dtype == space[key].dtype == np.float32
                    np.testing.assert_array_equal(b[agent][key], a[agent][key].astype(np.float32))
                for key in ("received", "task_type", "position", "episode"):
                    np.testing.assert_array_equal(b[agent][key], a[agent][key])
        assert narrow.state().dtype == narrow.state_space.dtype == np.float32
        np.testing.assert_array_equal(narrow.state(), wide.state().astype(np.float32))
    single = parallel_env("single", dtype="float32", flatten=True)
    assert single.observation_space("child_0").dtype == single.state_space.dtype == np.float32
    assert single.reset()[0]["child_0"].dtype == np.float32
    with pytest.raises(ConfigError) as error:
        vector_env("single", dtype=np.float16)
    assert error.value.field == "dtype"


@pytest.mark.parametrize("system, overrides", [
    ("volatile", {"rejoin_profile": "new"}),
    ("multi", {"routing": "per-task", "leave_probability": 0.3, "join_probability": 0.4}),
    ("multi-resource", {}),
    ("bursty", {}),
])
def test_a_renewed_world_is_a_fresh_world_of_its_seed_however_far_the_others_are(system, overrides):
    params = system_params(system, overrides)
    rng = np.random.default_rng(3)
    shape = (params.n_children, *((params.n_types,) if params.n_resources == 1 else (params.n_resources,
                                                                                      params.n_types)))
    weights = rng.random((14, 3, *shape))
    weights /= weights.sum(axis=-1, keepdims=True)
    worlds = SteppedWorlds(params, [0, 1, 2], block=5)
    others = SteppedWorlds(params, [0, 1, 2], block=5)
    fresh = SteppedWorlds(params, [9], block=5)

    def outcome(stepped, w, rows):
        out = stepped.step(w)
        return [np.array(part)[rows] for part in out]

    for t in range(7):  # into the second block
        outcome(worlds, weights[t], [0])
        outcome(others, weights[t], [0])
    worlds.renew([1], [9])
    assert worlds.seeds == (0, 9, 2) and worlds.played.tolist() == [7, 0, 7] and worlds.played_together is None
    for t in range(7, 14):
        mine = outcome(worlds, weights[t], [0, 1, 2])
        for got, want in zip(mine, outcome(others, weights[t], [0, 1, 2]), strict=True):
            np.testing.assert_array_equal(got[[0, 2]], want[[0, 2]])
        for got, want in zip(mine, outcome(fresh, weights[t, 1:2], [0]), strict=True):
            np.testing.assert_array_equal(got[1], want[0])

"""mgrao_core.env: PettingZoo's own checks, and proof that the environment is the engine's world.

The proof: a reference MG-RAO policy acting through the environment (algorithm 1 on each
observation, algorithm 2 for the action: the mgrao family's dense reference child) reproduces the
engine's utilities to 1e-12 for the same system, seed and configuration, in every paper system, and
``uniform`` through the environment equals the engine's ``uniform``.
"""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from gymnasium import spaces
from gymnasium.utils.env_checker import check_env  # the env extra, part of the test extra
from pettingzoo.test import parallel_api_test, parallel_seed_test

from mgrao_core import ConfigError, make_spec, run_experiment
from mgrao_core import equations as eq
from mgrao_core.algorithms import family_of, parse_algorithm
from mgrao_core.env import (
    NORMALISED,
    OBSERVATION_KEYS,
    RETURNED_KEYS,
    WeightsSpace,
    allocations,
    parallel_env,
    single_agent_env,
)
from mgrao_core.spec import MAX_SEED_VALUE
from mgrao_core.world import EpisodeStreams, draw_world

SYSTEMS = ("single", "multi", "volatile", "large")
EPISODES = 12
SEEDS = (0, 7)


def act_through_env(env, algorithm: str, seed: int) -> np.ndarray:
    """Run the family's dense reference children through ``env`` on ``seed``; the episodes' utilities.

    Each child's action is its allocation (algorithm 2 for MG-RAO); after each step it learns from
    every value that came back to it, in the order of ``position`` (algorithm 1 for MG-RAO).
    """
    params = env.params
    alg = parse_algorithm(algorithm, params.n_parents)
    observations, _ = env.reset(seed=seed)
    # MG-RAO's children read no world; a fixed family's read the seed's (the oracle's allocation).
    children = family_of(alg).reference_children(params, alg, draw_world(params, seed), seed)
    utilities = []
    while env.agents:
        actions = {agent: children[c].allocation() for c, agent in enumerate(env.agents)}
        observations, _, _, _, infos = env.step(actions)
        utilities.append(infos[env.possible_agents[0]]["utility"])
        for c, agent in enumerate(env.possible_agents):
            obs = observations[agent]
            parents, tasks = np.nonzero(obs["received"])
            for i in np.argsort(obs["position"][parents, tasks]):
                p, k = parents[i], tasks[i]
                children[c].learn(int(p), int(obs["task_type"][p, k]), float(obs["value"][p, k]))
    return np.array(utilities)


def engine_utilities(system: str, algorithm: str, episodes: int, **overrides) -> dict[int, np.ndarray]:
    result = run_experiment(make_spec(system, [algorithm], list(SEEDS), episodes, overrides or None))
    return {run.seed: run.utilities for run in result.runs}


# ---- PettingZoo's and Gymnasium's checks ----------------------------------------------------------


@pytest.mark.parametrize("system", SYSTEMS)
def test_parallel_api_test(system):
    parallel_api_test(parallel_env(system, episodes=40), num_cycles=100)


@pytest.mark.parametrize("system", SYSTEMS)
def test_parallel_seed_test(system):
    parallel_seed_test(lambda: parallel_env(system, episodes=40), num_cycles=50)


def test_gymnasium_env_checker_on_the_single_agent_wrapper():
    env = single_agent_env("single", episodes=5)
    check_env(env, skip_render_check=True)
    observation, info = env.reset(seed=3)
    assert env.observation_space.contains(observation) and info == {}
    done, steps = False, 0
    while not done:
        observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert not terminated and env.observation_space.contains(observation)
        assert reward == pytest.approx(info["utility"])  # one child: every value comes back to it
        done, steps = truncated, steps + 1
    assert steps == 5


def test_single_agent_wrapper_refuses_several_children():
    with pytest.raises(ConfigError, match="n_children"):
        single_agent_env("multi")


# ---- the same world --------------------------------------------------------------------------------


@pytest.mark.parametrize("system", SYSTEMS)
@pytest.mark.parametrize("algorithm", ["mgrao-1:1", "mgrao-max"])
def test_mgrao_through_the_env_reproduces_the_engine(system, algorithm):
    expected = engine_utilities(system, algorithm, EPISODES)
    env = parallel_env(system, episodes=EPISODES)
    for seed in SEEDS:
        np.testing.assert_allclose(act_through_env(env, algorithm, seed), expected[seed], rtol=0, atol=1e-12,
                                   err_msg=f"{system} {algorithm} seed {seed}")


@pytest.mark.parametrize("system", SYSTEMS)
def test_uniform_through_the_env_equals_the_engine(system):
    expected = engine_utilities(system, "uniform", EPISODES)
    env = parallel_env(system, episodes=EPISODES)
    zeros = np.zeros(env.params.n_types)  # all zeros mean uniform
    for seed in SEEDS:
        env.reset(seed=seed)
        utilities = []
        while env.agents:
            _, _, _, _, infos = env.step(dict.fromkeys(env.agents, zeros))
            utilities.append(infos["child_0"]["utility"])
        np.testing.assert_allclose(utilities, expected[seed], rtol=0, atol=1e-12, err_msg=f"{system} seed {seed}")
        np.testing.assert_allclose(act_through_env(env, "uniform", seed), expected[seed], rtol=0, atol=1e-12)


@pytest.mark.parametrize("overrides", [
    {"routing": "per-task", "load_sharing": True, "quality_model": "exponential"},
    {"leave_probability": 0.3, "join_probability": 0.4, "rejoin_profile": "new", "absent_tasks": "counted",
     "quality_model": "relative-linear", "tie_break": "first"},
], ids=["per-task-load-sharing", "volatile-counted"])
def test_mgrao_through_the_env_reproduces_the_engine_under_other_readings(overrides):
    expected = engine_utilities("multi", "mgrao-max", EPISODES, **overrides)
    env = parallel_env("multi", episodes=EPISODES, **overrides)
    for seed in SEEDS:
        np.testing.assert_allclose(act_through_env(env, "mgrao-max", seed), expected[seed], rtol=0, atol=1e-12)


def test_episodes_past_a_draw_block_follow_the_engine(monkeypatch):
    monkeypatch.setattr("mgrao_core.env.DRAW_BLOCK", 5)  # the streams are drawn 5 episodes at a time
    expected = engine_utilities("volatile", "mgrao-max", 13)
    env = parallel_env("volatile", episodes=13)
    np.testing.assert_allclose(act_through_env(env, "mgrao-max", 7), expected[7], rtol=0, atol=1e-12)


# ---- seeds, observations, actions ------------------------------------------------------------------


def _play(env, seed=None, steps=4):
    env.reset(seed=seed)
    rng = np.random.default_rng(1)
    out = []
    for _ in range(steps):
        observations, rewards, _, _, infos = env.step({a: rng.random(env.params.n_types) for a in env.agents})
        out.append((observations, rewards, infos))
    return out


def _same(a, b):
    for (obs_a, rew_a, info_a), (obs_b, rew_b, info_b) in zip(a, b, strict=True):
        assert rew_a == rew_b and info_a == info_b
        for agent in obs_a:
            for key in obs_a[agent]:
                np.testing.assert_array_equal(obs_a[agent][key], obs_b[agent][key])


def test_reset_without_a_seed_follows_gymnasiums_convention():
    # the first reset() gives the constructor's world; after reset(seed=s), reset() draws a fresh world from the
    # environment's generator, which s seeded: the same worlds for the same s, wherever
    env = parallel_env("volatile", seed=5, episodes=10)
    first = _play(env)
    assert env.world_seed == 5
    _same(_play(parallel_env("volatile", seed=0, episodes=10), seed=5), first)
    _play(env, seed=9)
    assert env.world_seed == 9
    fresh = _play(env)
    drawn = np.random.default_rng(9).integers(0, MAX_SEED_VALUE, size=2, endpoint=True)
    assert env.world_seed == drawn[0] != 9
    _same(fresh, _play(parallel_env("volatile", episodes=10), seed=int(drawn[0])))
    _play(env)
    assert env.world_seed == drawn[1]
    other = parallel_env("single", seed=1, episodes=3)
    other.reset(seed=9)
    other.reset()
    assert other.world_seed == drawn[0]


def test_other_seeds_give_other_worlds():
    env = parallel_env("single", episodes=10)
    a, b = _play(env, seed=1), _play(env, seed=2)
    assert a[0][2]["child_0"]["utility"] != b[0][2]["child_0"]["utility"]


def test_observation_masks_what_came_back_in_the_order_of_returns():
    env = parallel_env("volatile", seed=3, episodes=10)
    observations, infos = env.reset()
    assert infos == {"child_0": {}}
    assert all(not observations["child_0"][key].any() for key in (*RETURNED_KEYS, "allocation", "episode"))
    world = draw_world(env.params, 3)
    present = np.ones(env.params.n_parents, dtype=bool)
    draws = EpisodeStreams(env.params, 3).draw(10)
    for e in range(10):
        observations, rewards, terminations, truncations, infos = env.step({"child_0": np.ones(env.params.n_types)})
        obs = observations["child_0"]
        assert env.observation_space("child_0").contains(obs)
        # the volatile preset's parents leave and rejoin with probability 0.25 (docs/model.md)
        present = np.where(present, draws.volatility[e] >= 0.25, draws.volatility[e] < 0.25)
        assert np.array_equal(obs["received"].all(axis=1), present)
        assert not obs["received"][~present].any() and not obs["value"][~present].any()
        np.testing.assert_array_equal(obs["task_type"][present], world.parent_types[present])
        n = int(obs["received"].sum())
        assert sorted(obs["position"][obs["received"] == 1]) == list(range(n))
        returned = [p for p in draws.order[e] if present[p]]
        firsts = obs["position"][returned, 0]
        assert list(firsts) == sorted(firsts)  # composites come back in the episode's order of parents
        assert rewards["child_0"] == pytest.approx(obs["value"].sum(), abs=1e-12)
        assert infos["child_0"]["episode"] == e and not terminations["child_0"]
        assert truncations["child_0"] == (e == 9)
    assert env.agents == []
    with pytest.raises(RuntimeError, match="reset"):
        env.step({"child_0": np.ones(env.params.n_types)})


def test_multi_children_see_only_their_tasks():
    env = parallel_env("multi", episodes=5)
    env.reset(seed=0)
    observations, rewards, _, _, infos = env.step({a: np.zeros(20) for a in env.agents})
    received = sum(observations[a]["received"] for a in env.agents)
    assert received.max() == 1 and received.all()  # every atomic task went to exactly one child
    assert sum(rewards.values()) == pytest.approx(infos["child_0"]["utility"], abs=1e-12)


def test_actions_are_sum_normalised_and_zeros_are_uniform():
    env = parallel_env("single")
    np.testing.assert_array_equal(env.allocation(np.zeros(20)), np.full(20, 1 / 20))
    weights = np.arange(20.0)
    np.testing.assert_allclose(env.allocation(weights * 7), weights / weights.sum(), rtol=1e-15)
    normalised = np.full(20, 0.05)  # sums to 1 up to a rounding: taken as it is, not divided again
    assert env.allocation(normalised).tobytes() == normalised.tobytes()
    a, b = parallel_env("single", episodes=3), parallel_env("single", episodes=3)
    a.reset(seed=2)
    b.reset(seed=2)
    _, rewards_a, *_ = a.step({"child_0": weights / 19})
    _, rewards_b, *_ = b.step({"child_0": weights / weights.sum()})
    assert rewards_a["child_0"] == pytest.approx(rewards_b["child_0"], abs=1e-14)


def test_one_allocation_is_normalised_as_sumnorm_bit_for_bit():
    """The one-allocation shortcut of ``allocations`` gives eq.sumnorm's numbers, over sums from 1e-300 to overflow."""
    rng = np.random.default_rng(5)
    for _ in range(3000):
        n = int(rng.integers(1, 40))
        action = rng.uniform(0.0, 10.0 ** rng.integers(-300, 308), n) * (rng.uniform(size=n) > 0.2)
        total = action.sum() if np.isfinite(action.sum()) else np.inf
        expected = action if abs(total - 1.0) <= NORMALISED else None
        if expected is None:
            scaled = action / action.max() if np.isinf(total) else action
            expected = eq.sumnorm(scaled)
        assert allocations(action, "child_0", n).tobytes() == expected.tobytes(), action
        assert allocations(action[None], "child_0", n).tobytes() == expected.tobytes(), action  # one world's


def test_the_action_space_samples_what_a_box_samples():
    """``WeightsSpace.sample`` is gymnasium's ``Box.sample`` of the same bounds in one draw: the same numbers."""
    for shape in [(20,), (2, 7), (3, 1, 5)]:
        ours, box = WeightsSpace(shape), spaces.Box(0.0, 1.0, shape, np.float64)
        ours.seed(11)
        box.seed(11)
        for _ in range(5):
            sample = ours.sample()
            assert sample.tobytes() == box.sample().tobytes() and ours.contains(sample)
    with pytest.raises(gymnasium.error.Error, match="mask"):
        WeightsSpace((3,)).sample(mask=np.ones(3))


@pytest.mark.parametrize("action, match", [
    (np.ones(19), "shape"), (-np.ones(20), "at least 0"), (np.full(20, np.nan), "finite"),
    (np.r_[np.nan, np.ones(19)], "finite"), (np.r_[np.ones(19), np.nan], "finite"),  # a NaN that min and max
    (np.r_[0.5, np.nan, np.ones(18)], "finite"), (np.r_[np.ones(19), np.inf], "finite"),  # of a list let pass
    ([], "child_0: an action is 20 numbers, one weight per atomic type \\(got none\\)"),
    (np.ones(20) + 1j, "child_0: .*real numbers.* \\(got complex"),
    (np.ones(20, dtype=bool), "child_0: .*real numbers.* \\(got booleans"),
    ([True] * 20, "child_0: .*real numbers.* \\(got booleans"),
    ([np.True_] + [1.0] * 19, "child_0: .*real numbers.* \\(got booleans"),
])
def test_invalid_actions_are_refused(action, match):
    env = parallel_env("single")
    env.reset()
    with pytest.raises(ValueError, match=match):
        env.step({"child_0": action})
    with pytest.raises(ValueError, match="no action for child_0"):
        env.step({})


def test_spaces():
    env = parallel_env("large", n_types=30)
    space = env.observation_space("child_0")
    assert set(space.spaces) == set(OBSERVATION_KEYS)
    assert all(space[key].shape == (50, 5) for key in RETURNED_KEYS)
    assert space["allocation"].shape == space["resources"].shape == (30,) and space["episode"].shape == (1,)
    assert space["task_type"].nvec.max() == 30 and space["position"].nvec.max() == 250
    assert env.action_space("child_0").shape == (30,)
    assert env.observation_space("child_0") is space


@pytest.mark.parametrize("kwargs, field", [
    ({"system": "nope"}, "system"), ({"learning_rat": 1}, "learning_rat"), ({"n_parents": 0}, "n_parents"),
    ({"seed": -1}, "seed"), ({"episodes": 0}, "episodes"),
])
def test_invalid_configurations_name_the_field(kwargs, field):
    with pytest.raises(ConfigError) as error:
        parallel_env(**kwargs)
    assert error.value.field == field


def test_the_single_agent_env_refuses_unknown_reset_options_too():
    env = single_agent_env("single", episodes=3)
    env.reset(seed=4, options={})
    with pytest.raises(ConfigError, match="options: unknown option reset_mask: one world, which a reset starts"):
        env.reset(options={"reset_mask": np.array([True])})
    assert env.parallel.world_seed == 4

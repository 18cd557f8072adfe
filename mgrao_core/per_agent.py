"""Gymnasium's single-agent vector wrappers on each agent of a vector environment.

Gymnasium's vector wrappers (``gymnasium.wrappers.vector``: ``RecordEpisodeStatistics``, ``NormalizeObservation``,
``NormalizeReward``, ``TransformObservation``, ``DictInfoToList``...) wrap a ``gymnasium.vector.VectorEnv`` of one
agent: one array of observations and one reward per world a step. :class:`mgrao_core.env.MgraoVectorEnv` steps
every agent at once, keyed by agent. :func:`per_agent` gives each agent its own view of it, a true
``gymnasium.vector.VectorEnv`` (:class:`AgentVectorEnv`: the agent's spaces, observations, rewards,
terminations, truncations and infos, ``num_envs``, ``metadata`` with ``autoreset_mode``), wraps each view with the
caller's wrappers, and steps the environment once a step for every agent: the first agent's wrappers to reach
their view step the environment with every agent's action, and each view answers with its agent's part.

So the wrappers run unchanged, per agent: each agent's ``RecordEpisodeStatistics`` counts that agent's returns,
each ``NormalizeObservation`` keeps that agent's running mean. Wrappers of observations, rewards and infos run
this way; one that changes the action on its way down cannot (the agents act together, and the step is taken with
the actions given to :meth:`PerAgent.step`): the view refuses it, naming the agent. In a view's infos the
environment's ``"episode"`` (the episode's index) is ``"episode_index"`` (:func:`mgrao_core.env.gymnasium_info`):
Gymnasium's ``RecordEpisodeStatistics`` writes its statistics under ``"episode"``. docs/platform.md ("Learners
from other libraries") shows it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium
from gymnasium import spaces

from mgrao_core.env import gymnasium_info

__all__ = ["AgentVectorEnv", "PerAgent", "per_agent"]

class AgentVectorEnv(gymnasium.vector.VectorEnv):
    """One agent's view of a vector environment, a ``gymnasium.vector.VectorEnv`` (built by :func:`per_agent`).

    Its ``reset`` and ``step`` answer the :class:`PerAgent` step under way with the agent's part; called by
    anything else, they refuse.

    Attributes:
        agent: whose view it is.
        num_envs: the environment's worlds.
        single_observation_space, single_action_space: the agent's in one world.
        observation_space, action_space: the agent's in every world (Gymnasium's batching of them).
        metadata: the environment's (``autoreset_mode`` among them).
    """

    def __init__(self, joint: PerAgent, agent: str) -> None:
        env = joint.env
        self.agent = agent
        self._joint = joint
        self.num_envs = env.num_envs
        self.single_observation_space: spaces.Space = env.single_observation_space(agent)
        self.single_action_space: spaces.Space = env.single_action_space(agent)
        self.observation_space: spaces.Space = env.observation_space(agent)
        self.action_space: spaces.Space = env.action_space(agent)
        self.metadata = dict(env.metadata)
        self.render_mode = None

    def reset(self, *, seed: Any = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """The agent's part of the environment's reset (the seed and options given to :meth:`PerAgent.reset`)."""
        observations, infos = self._joint._answer("reset", self.agent, None)
        return observations[self.agent], gymnasium_info(infos[self.agent])

    def step(self, actions: Any) -> tuple[Any, Any, Any, Any, dict[str, Any]]:
        """The agent's part of the environment's step (taken with every agent's action given to :meth:`PerAgent.step`).

        Raises:
            RuntimeError: ``actions`` are not the agent's action as given (a wrapper changed it on its way).
        """
        observations, rewards, terminations, truncations, infos = self._joint._answer("step", self.agent, actions)
        a = self.agent
        return observations[a], rewards[a], terminations[a], truncations[a], gymnasium_info(infos[a])

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Each world's answer to ``name`` (the environment's ``call``)."""
        return self._joint.env.call(name, *args, **kwargs)

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """Each world's ``name`` (the environment's ``get_attr``)."""
        return self._joint.env.get_attr(name)


class PerAgent:
    """A vector environment each of whose agents sees it through its own Gymnasium wrappers (:func:`per_agent`).

    The same API as the environment (``reset``, ``step``, keyed by agent, a leading world axis), each agent's
    observations, rewards and infos as its wrappers give them, and its spaces theirs.

    Attributes:
        env: the vector environment.
        views: each agent's :class:`AgentVectorEnv`.
        wrapped: each agent's wrappers around its view (``wrapped[agent].return_queue``: its episode returns, for
            ``RecordEpisodeStatistics``).
    """

    def __init__(self, env: Any, wrap: Callable[[AgentVectorEnv], gymnasium.vector.VectorEnv]) -> None:
        self.env = env
        self.possible_agents = list(env.possible_agents)
        self.num_envs = env.num_envs
        self.metadata = dict(env.metadata)
        self._round: tuple[str, Any, Any] | None = None  # the reset or step under way: kind, seed or actions, options
        self._result: tuple | None = None
        self.views = {agent: AgentVectorEnv(self, agent) for agent in self.possible_agents}
        self.wrapped = {agent: wrap(view) for agent, view in self.views.items()}

    @property
    def agents(self) -> list[str]:
        """The environment's agents."""
        return self.env.agents

    def observation_space(self, agent: str) -> spaces.Space:
        """The agent's observations in every world, as its wrappers give them."""
        return self.wrapped[agent].observation_space

    def single_observation_space(self, agent: str) -> spaces.Space:
        """The agent's observation in one world, as its wrappers give it."""
        return self.wrapped[agent].single_observation_space

    def action_space(self, agent: str) -> spaces.Space:
        """The agent's actions in every world."""
        return self.wrapped[agent].action_space

    def single_action_space(self, agent: str) -> spaces.Space:
        """The agent's action in one world."""
        return self.wrapped[agent].single_action_space

    def reset(self, seed: Any = None, options: dict[str, Any] | None = None) -> tuple[dict, dict]:
        """Reset the environment (``seed`` and ``options`` as its own ``reset``), through every agent's wrappers.

        Each agent's wrappers get their own copy of ``options`` (Gymnasium's take ``reset_mask`` out of theirs).
        """
        answers = self._through("reset", seed, options, lambda agent: self.wrapped[agent].reset(
            seed=seed, options=None if options is None else dict(options)))
        return {agent: answer[0] for agent, answer in answers.items()}, \
            {agent: answer[1] for agent, answer in answers.items()}

    def step(self, actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        """One step of the environment with every agent's action, through every agent's wrappers.

        Raises:
            ValueError: ``actions`` are no dict or want an agent's (the environment's own refusal); nothing is
                stepped.
        """
        if not isinstance(actions, dict) or actions.keys() != set(self.possible_agents):
            return self.env.step(actions)  # which refuses them, naming what is wrong
        answers = self._through("step", actions, None, lambda agent: self.wrapped[agent].step(actions[agent]))
        return tuple({agent: answer[i] for agent, answer in answers.items()} for i in range(5))

    def _through(self, kind: str, given: Any, options: Any, call: Callable[[str], tuple]) -> dict[str, tuple]:
        """``call`` for every agent, the environment's ``kind`` taken once, by the first view reached."""
        self._round, self._result = (kind, given, options), None
        try:
            answers = {agent: call(agent) for agent in self.possible_agents}
        finally:
            self._round = self._result = None
        return answers

    def _answer(self, kind: str, agent: str, action: Any) -> tuple:
        """The environment's answer to the ``kind`` under way (taking it first, if no view has yet)."""
        if self._round is None or self._round[0] != kind:
            raise RuntimeError(f"{agent}: its view answers the PerAgent's {kind} under way; call PerAgent.{kind}")
        _, given, options = self._round
        if kind == "step" and action is not given[agent]:
            raise RuntimeError(f"{agent}: a wrapper changed the action on its way to the environment; action wrappers "
                               "cannot run per agent (every agent acts in one step): change the actions before "
                               "PerAgent.step")
        if self._result is None:
            self._result = self.env.step(given) if kind == "step" else self.env.reset(seed=given, options=options)
        return self._result

    def state(self) -> Any:
        """The environment's state."""
        return self.env.state()

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Each world's answer to ``name`` (the environment's ``call``)."""
        return self.env.call(name, *args, **kwargs)

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """Each world's ``name`` (the environment's ``get_attr``)."""
        return self.env.get_attr(name)

    def close(self) -> None:
        """Close every agent's wrappers and the environment."""
        for wrapped in self.wrapped.values():
            wrapped.close()
        self.env.close()


def per_agent(env: Any, wrap: Callable[[AgentVectorEnv], gymnasium.vector.VectorEnv]) -> PerAgent:
    """``env`` (a :func:`mgrao_core.env.vector_env`) with each agent's view wrapped by ``wrap(view)``.

    Args:
        env: a vector environment keyed by agent, with ``num_envs``, ``single_observation_space(agent)``,
            ``single_action_space(agent)`` and ``metadata["autoreset_mode"]``.
        wrap: builds an agent's wrappers around its :class:`AgentVectorEnv`, e.g. ``lambda view:
            NormalizeObservation(RecordEpisodeStatistics(view))`` (Gymnasium's ``gymnasium.wrappers.vector``).

    Returns:
        The environment seen through every agent's wrappers (:class:`PerAgent`).
    """
    return PerAgent(env, wrap)

"""The simulated world of one seed: what is drawn once, and the per-episode randomness.

Every random number comes from a stream keyed by ``(seed, stream name)`` alone, never by the
algorithm, so every algorithm of one seed faces the same world (common random numbers), and the
numbers do not depend on how many episodes are drawn at a time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mgrao_core.algorithms import FAMILIES
from mgrao_core.algorithms.state import routing_choices
from mgrao_core.params import SystemParams

_STREAM_IDS = {"world": 0, "noise": 1, "order": 2, "volatility": 3, "routing": 4, "profiles": 6,
               "arrivals": 16, "schedule": 17, "unpredictable": 18, "capability": 19, "resources": 20,
               "needs": 21, "topology": 22} | {
    name: number for family in FAMILIES for name, number in family.streams.items()}
"""Each stream's number in its seed sequence: the environment's, then each family's own (the oracle's
``"oracle"``, 5); a number, once used, is never given to another stream. The system's dynamics took 16 to
19 (arrival phases, scheduled events, unpredictable parents, capability), several resources 20 and 21 (the
amounts of resources after the first, the types' needs), a sparse world 22 (its random links), leaving 7 to 15
to families."""
RESOURCE_FLOOR = 1e-6
NEED_FLOOR = 1e-6
"""Smallest need of a type for a resource (a Dirichlet draw at a small concentration may underflow to 0)."""
NEW_PROFILE = 1
"""A parent change (:attr:`EpisodeDraws.changes`): the parent takes the value profile of ``event_profiles``."""
NEW_COMPOSITE = 2
"""A parent change: the parent takes the atomic types of ``event_types`` (a new composite type)."""


def stream(seed: int, name: str) -> np.random.Generator:
    """The independent random generator for ``name`` (see module docstring) of ``seed``."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence([seed, _STREAM_IDS[name]])))


@dataclass(frozen=True)
class World:
    """What one seed draws once: docs/model.md ("The system", "Value of atomic tasks").

    Attributes:
        composite_types: ``(n_composite_types, types_per_composite)`` atomic types of each composite.
        parent_types: ``(n_parents, types_per_composite)``; parent ``p`` handles composite
            ``p mod n_composite_types`` (the paper's ``tg`` mapping).
        profiles: ``(n_parents, types_per_composite)`` each parent's Dirichlet value profile.
        resources: ``(n_children,)`` each child's resource amount in (0, 1].
        capability: ``(n_children, n_types)`` the factor on each child's half-saturation per type,
            ``exp(capability_spread * N(0, 1))`` from the ``"capability"`` stream (exactly 1 at spread 0,
            drawing nothing).
        amounts: ``(n_children, n_resources)`` each child's amount of each resource (the first is
            ``resources``, the others from the ``"resources"`` stream); None with one resource.
        needs: ``(n_types, n_resources)`` each type's needs, Dirichlet(``need_concentration``) from the
            ``"needs"`` stream, summing to 1; None with one resource.
        combination: ``resource_combination``.
    """

    composite_types: np.ndarray
    parent_types: np.ndarray
    profiles: np.ndarray
    resources: np.ndarray
    capability: np.ndarray
    amounts: np.ndarray | None = None
    needs: np.ndarray | None = None
    combination: str = "scarcest"

    @property
    def n_resources(self) -> int:
        """How many resources each child owns."""
        return 1 if self.amounts is None else self.amounts.shape[1]

    @property
    def resource_per_type(self) -> np.ndarray:
        """``(n_children, n_resources, n_types)``: ``ar[c, r] / (capability[c, t] * R * need[t, r])``.

        A child's amount of resource ``r`` per unit of weight of type ``t``, relative to the type's need of it
        (docs/model.md, "Several resources"). With one resource it is :attr:`type_resources` exactly (no
        division by ``R * need = 1`` is made).
        """
        if self.amounts is None or self.needs is None:
            return self.type_resources_single[:, None, :]
        relative = self.n_resources * self.needs.T  # (R, n_types)
        return self.amounts[:, :, None] / self.capability[:, None, :] / relative[None]

    @property
    def type_resources_single(self) -> np.ndarray:
        """``(n_children, n_types)``: ``ar[c] / capability[c, t]`` for the first resource."""
        return self.resources[:, None] / self.capability

    @property
    def type_resources(self) -> np.ndarray:
        """``(n_children, n_types)``: ``ar[c] / capability[c, t]``, a child's resource per unit of weight of a type.

        Quality ``x' / (x' + h)`` at ``x' = w * ar / f`` equals ``x / (x + h * f)``: scaling the half-saturation by
        ``f`` is scaling the resource by ``1 / f`` (exactly ``ar`` at ``f = 1``). With several resources, the
        resource per unit of weight of one split applied to every resource
        (:func:`mgrao_core.quality.single_split_resource`): what the oracle allocates.
        """
        if self.amounts is None:
            return self.type_resources_single
        from mgrao_core.quality import single_split_resource

        return single_split_resource(self.resource_per_type, self.needs, self.combination)


def draw_world(params: SystemParams, seed: int) -> World:
    """Draw the world of ``seed`` from its ``"world"`` stream."""
    rng = stream(seed, "world")
    keys = rng.random((params.n_composite_types, params.n_types))
    composite_types = np.argsort(keys, axis=1, kind="stable")[:, : params.types_per_composite]
    parent_types = composite_types[np.arange(params.n_parents) % params.n_composite_types]
    profiles = rng.dirichlet(
        np.full(params.types_per_composite, params.value_concentration), size=params.n_parents
    )
    resources = np.clip(
        rng.normal(params.resource_mean, params.resource_sd, params.n_children), RESOURCE_FLOOR, 1.0
    )
    shape = (params.n_children, params.n_types)
    capability = (np.exp(params.capability_spread * stream(seed, "capability").standard_normal(shape))
                  if params.capability_spread > 0 else np.ones(shape))
    if params.n_resources == 1:
        return World(composite_types, np.ascontiguousarray(parent_types), profiles, resources, capability)
    more = np.clip(stream(seed, "resources").normal(params.resource_mean, params.resource_sd,
                                                    (params.n_children, params.n_resources - 1)),
                   RESOURCE_FLOOR, 1.0)
    amounts = np.concatenate([resources[:, None], more], axis=1)
    needs = stream(seed, "needs").dirichlet(np.full(params.n_resources, params.need_concentration),
                                            size=params.n_types)
    needs = np.maximum(needs, NEED_FLOOR)
    needs /= needs.sum(axis=1, keepdims=True)
    return World(composite_types, np.ascontiguousarray(parent_types), profiles, resources, capability,
                 amounts, needs, params.resource_combination)


def draw_links(params: SystemParams, seed: int) -> np.ndarray | None:
    """``(n_parents, children_per_parent)``: the children each parent offers its tasks to, in increasing order.

    docs/model.md ("Sparse worlds"). None in a complete world (every child, and nothing is drawn). Under
    ``topology="ring"`` parents and children sit evenly on one ring, parent ``p`` at ``(p + 1/2) / n_parents`` and
    child ``c`` at ``(c + 1/2) / n_children`` of its length, and a parent's links are the ``k`` children nearest to it
    (the same for every seed); under ``"random"`` they are ``k`` distinct children drawn from the seed's
    ``"topology"`` stream, uniformly among the ``k``-subsets.
    """
    if not params.sparse:
        return None
    n, k, parents = params.n_children, params.children_per_parent, params.n_parents
    if params.topology == "ring":
        # the nearest child's index, then k children centred on the parent's place (the lower one first on a tie)
        place = (np.arange(parents) + 0.5) * n / parents - 0.5
        first = np.ceil(place - k / 2).astype(np.int64)
        return np.sort((first[:, None] + np.arange(k)[None, :]) % n, axis=1)
    rng = stream(seed, "topology")
    if 4 * k >= n:  # a large share of the children: each row a random permutation's first k
        return np.sort(rng.permuted(np.tile(np.arange(n, dtype=np.int64), (parents, 1)), axis=1)[:, :k], axis=1)
    links = np.sort(rng.integers(0, n, size=(parents, k)), axis=1)  # a few of many: draw again where a row repeats
    while True:
        repeated = np.flatnonzero((links[:, 1:] == links[:, :-1]).any(axis=1))
        if not len(repeated):
            return links
        links[repeated] = np.sort(rng.integers(0, n, size=(len(repeated), k)), axis=1)


def composite_periods(params: SystemParams) -> np.ndarray:
    """``(n_composite_types,)`` episodes between two arrivals of each composite type (``frequency_profile``).

    ``two-speed``: the last ``n_composite_types // 2`` types are the slow ones.
    """
    periods = np.ones(params.n_composite_types, dtype=np.int64)
    if params.frequency_profile == "two-speed":
        periods[params.n_composite_types - params.n_composite_types // 2 :] = params.slow_period
    elif params.frequency_profile == "explicit":
        periods[:] = params.composite_periods
    return periods


def is_dynamic(params: SystemParams) -> bool:
    """Whether the task stream changes: periods other than 1, a schedule, or unpredictable parents."""
    return bool(params.schedule) or params.unpredictable_fraction > 0 or bool((composite_periods(params) > 1).any())


def _share(fraction: float, n: int) -> int:
    """How many of ``n`` a ``fraction`` chooses: ``fraction * n`` rounded half up."""
    return int(np.floor(fraction * n + 0.5))


def unpredictable_parents(params: SystemParams, rng: np.random.Generator) -> np.ndarray:
    """The unpredictable parents, in increasing order: ``unpredictable_fraction`` of them, from ``rng``."""
    return np.sort(rng.permutation(params.n_parents)[: _share(params.unpredictable_fraction, params.n_parents)])


def _event_stream(seed: int, index: int) -> np.random.Generator:
    """Event ``index`` of the schedule's own generator: adding an event changes no other event's draws."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence([seed, _STREAM_IDS["schedule"], index])))


class Timeline:
    """The task stream's changes over one seed's episodes: docs/model.md ("Task frequencies", "Changes over time").

    The same mechanism serves scheduled events and unpredictable parents: at the start of an episode a
    parent may take a new value profile (:data:`NEW_PROFILE`) or a new composite type (:data:`NEW_COMPOSITE`),
    and the composite types' periods may change; then each parent's composite task arrives or not.
    Everything here is per seed (no lane changes it), so it is drawn once, outside the kernel, and the
    engine and the reference read the same arrays.
    """

    def __init__(self, params: SystemParams, world: World, seed: int) -> None:
        self._params = params
        self._seed = seed
        self._composite_types = world.composite_types
        self._composite_of = np.arange(params.n_parents) % params.n_composite_types
        self._periods = composite_periods(params)
        self._phases = stream(seed, "arrivals").integers(0, self._periods)
        self._unpredictable_rng = stream(seed, "unpredictable")
        self._unpredictable = unpredictable_parents(params, self._unpredictable_rng)
        order = sorted(range(len(params.schedule)), key=lambda i: params.schedule[i].episode)
        self._events = [(params.schedule[i].episode, i, params.schedule[i]) for i in order]
        self._next_event = 0
        self._episode = 0

    def draw(self, episodes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``changes, event_profiles, event_types, arrives`` of the next ``episodes`` episodes."""
        p = self._params
        changes = np.zeros((episodes, p.n_parents), dtype=np.int8)
        profiles = np.zeros((episodes, p.n_parents, p.types_per_composite))
        types = np.zeros((episodes, p.n_parents, p.types_per_composite), dtype=np.int64)
        arrives = np.zeros((episodes, p.n_parents), dtype=np.bool_)
        alpha = np.full(p.types_per_composite, p.value_concentration)
        for i in range(episodes):
            episode = self._episode + i
            while self._next_event < len(self._events) and self._events[self._next_event][0] == episode:
                _, index, event = self._events[self._next_event]
                self._apply(event, _event_stream(self._seed, index), alpha, changes[i], profiles[i], types[i])
                self._next_event += 1
            periods = self._periods[self._composite_of]
            arrives[i] = episode % periods == self._phases[self._composite_of]
            u = self._unpredictable
            if len(u):
                rng = self._unpredictable_rng
                composites = rng.integers(0, p.n_composite_types, size=len(u))
                profiles[i, u] = rng.dirichlet(alpha, size=len(u))
                arrives[i, u] = rng.random(len(u)) < 1.0 / self._periods[composites]
                self._composite_of[u] = composites
                types[i, u] = self._composite_types[composites]
                changes[i, u] = NEW_PROFILE | NEW_COMPOSITE
        self._episode += episodes
        return changes, profiles, types, arrives

    def _apply(self, event, rng: np.random.Generator, alpha: np.ndarray, changes: np.ndarray, profiles: np.ndarray,
               types: np.ndarray) -> None:
        p = self._params
        if event.change == "frequencies":
            chosen = rng.permutation(p.n_composite_types)[: _share(event.fraction, p.n_composite_types)]
            self._periods[chosen] = event.period
            self._phases[chosen] = rng.integers(0, event.period, size=len(chosen))
            return
        chosen = rng.permutation(p.n_parents)[: _share(event.fraction, p.n_parents)]
        if event.change == "new-profiles":
            profiles[chosen] = rng.dirichlet(alpha, size=len(chosen))
            changes[chosen] |= NEW_PROFILE
        else:  # new-composites
            composites = rng.integers(0, p.n_composite_types, size=len(chosen))
            self._composite_of[chosen] = composites
            types[chosen] = self._composite_types[composites]
            changes[chosen] |= NEW_COMPOSITE


@dataclass(frozen=True)
class EpisodeDraws:
    """The per-episode randomness of one seed for a block of episodes.

    Attributes:
        noise: ``(episodes, n_parents, types_per_composite)`` standard normals for value noise.
        order: ``(episodes, n_parents)`` the random order in which parents return values.
        volatility: ``(episodes, n_parents)`` uniforms deciding leave/rejoin.
        new_profiles: ``(episodes, n_parents, types_per_composite)`` profiles a rejoining parent
            brings under ``rejoin_profile="new"`` (shape ``(episodes, 0, 0)`` otherwise).
        routing: ``(episodes, n_parents, choices, 3)`` uniforms for a parent's choice of child:
            explore or not, which other child, which of tied children. ``choices`` is 1 under
            ``routing="per-composite"`` (one choice per composite task) and ``types_per_composite``
            under ``"per-task"``; where a parent chooses among several children only (shape
            ``(episodes, 0, 0, 3)`` otherwise).
        changes: ``(episodes, n_parents)`` int8: each parent's change at the episode's start, a sum of
            :data:`NEW_PROFILE` and :data:`NEW_COMPOSITE` (scheduled events, unpredictable parents).
        event_profiles: ``(episodes, n_parents, types_per_composite)`` the new profiles of those changes.
        event_types: ``(episodes, n_parents, types_per_composite)`` the new atomic types of those changes.
        arrives: ``(episodes, n_parents)`` whether the parent's composite type arrives in the episode.
            The four have ``n_parents = 0`` (and 0 types) when the task stream never changes
            (:func:`is_dynamic`): every present parent's task then arrives, and nothing is drawn.
    """

    noise: np.ndarray
    order: np.ndarray
    volatility: np.ndarray
    new_profiles: np.ndarray
    routing: np.ndarray
    changes: np.ndarray
    event_profiles: np.ndarray
    event_types: np.ndarray
    arrives: np.ndarray


class EpisodeStreams:
    """Draws :class:`EpisodeDraws` for consecutive blocks of episodes of one seed."""

    def __init__(self, params: SystemParams, seed: int, world: World | None = None) -> None:
        self._params = params
        self._timeline = Timeline(params, world or draw_world(params, seed), seed) if is_dynamic(params) else None
        self._noise = stream(seed, "noise")
        self._order = stream(seed, "order")
        self._volatility = stream(seed, "volatility")
        self._profiles = stream(seed, "profiles")
        self._routing = stream(seed, "routing")

    def draw(self, episodes: int) -> EpisodeDraws:
        """The randomness of the next ``episodes`` episodes."""
        p = self._params
        shape = (episodes, p.n_parents, p.types_per_composite)
        volatile = p.leave_probability > 0 or p.join_probability > 0
        new_profiles = (
            self._profiles.dirichlet(np.full(p.types_per_composite, p.value_concentration), size=shape[:2])
            if volatile and p.rejoin_profile == "new"
            else np.zeros((episodes, 0, 0))
        )
        if self._timeline is None:
            changes, event_profiles, event_types, arrives = (
                np.zeros((episodes, 0), dtype=np.int8), np.zeros((episodes, 0, 0)),
                np.zeros((episodes, 0, 0), dtype=np.int64), np.zeros((episodes, 0), dtype=np.bool_))
        else:
            changes, event_profiles, event_types, arrives = self._timeline.draw(episodes)
        return EpisodeDraws(
            changes=changes, event_profiles=event_profiles, event_types=event_types, arrives=arrives,
            noise=self._noise.standard_normal(shape),
            order=np.argsort(self._order.random(shape[:2]), axis=1, kind="stable"),
            volatility=self._volatility.random(shape[:2]) if volatile else np.ones(shape[:2]),
            new_profiles=new_profiles,
            routing=(
                self._routing.random(shape[:2] + (routing_choices(p), 3))
                if p.children_offered > 1
                else np.zeros((episodes, 0, 0, 3))
            ),
        )

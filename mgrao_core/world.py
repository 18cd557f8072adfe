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

_STREAM_IDS = {"world": 0, "noise": 1, "order": 2, "volatility": 3, "routing": 4, "profiles": 6} | {
    name: number for family in FAMILIES for name, number in family.streams.items()}
"""Each stream's number in its seed sequence: the environment's, then each family's own (the oracle's
``"oracle"``, 5); a number, once used, is never given to another stream."""
RESOURCE_FLOOR = 1e-6


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
    """

    composite_types: np.ndarray
    parent_types: np.ndarray
    profiles: np.ndarray
    resources: np.ndarray


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
    return World(composite_types, np.ascontiguousarray(parent_types), profiles, resources)


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
            under ``"per-task"``; multi-child systems only (shape ``(episodes, 0, 0, 3)`` otherwise).
    """

    noise: np.ndarray
    order: np.ndarray
    volatility: np.ndarray
    new_profiles: np.ndarray
    routing: np.ndarray


class EpisodeStreams:
    """Draws :class:`EpisodeDraws` for consecutive blocks of episodes of one seed."""

    def __init__(self, params: SystemParams, seed: int) -> None:
        self._params = params
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
        return EpisodeDraws(
            noise=self._noise.standard_normal(shape),
            order=np.argsort(self._order.random(shape[:2]), axis=1, kind="stable"),
            volatility=self._volatility.random(shape[:2]) if volatile else np.ones(shape[:2]),
            new_profiles=new_profiles,
            routing=(
                self._routing.random(shape[:2] + (routing_choices(p), 3))
                if p.n_children > 1
                else np.zeros((episodes, 0, 0, 3))
            ),
        )

"""Results of an experiment: every run's episode utilities and final learned weights."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mgrao_core.spec import ExperimentSpec
from mgrao_core.stats import ConfigSummary, episode_band, final_utilities, summarise


@dataclass(frozen=True)
class Run:
    """One (algorithm, seed) run.

    Attributes:
        algorithm: the algorithm label.
        seed: the seed.
        utilities: ``(episodes,)`` system utility of every episode.
        group_weights: ``(n_children, m, n_types)`` each child's final PW matrix (empty for
            uniform and oracle, whose weights are fixed).
        combined_weights: ``(n_children, n_types)`` each child's final combined weights.
        membership: ``(n_children, snapshots, n_parents)`` each parent's group in each recorded
            membership, for an algorithm whose groups change (``mgrao-adaptive:x``, ``mgrao-balance``); None otherwise.
        membership_every: episodes between two recorded memberships (the first is at episode 0).
        resource_weights: with several resources, ``(n_resources, n_children, n_types)`` each child's final
            allocation of each resource (``combined_weights`` is the first's); None with one.
        resource_group_weights: with several resources, ``(n_resources, n_children, m, n_types)`` each
            resource's final PW (MG-RAO keeps one per resource; ``group_weights`` is the first's); None with one.
    """

    algorithm: str
    seed: int
    utilities: np.ndarray
    group_weights: np.ndarray
    combined_weights: np.ndarray
    membership: np.ndarray | None = None
    membership_every: int = 0
    resource_weights: np.ndarray | None = None
    resource_group_weights: np.ndarray | None = None


@dataclass(frozen=True)
class ExperimentResult:
    """All runs of an experiment, in the order algorithms x seeds."""

    spec: ExperimentSpec
    runs: tuple[Run, ...]

    def utilities(self, algorithm: str) -> np.ndarray:
        """``(seeds, episodes)`` utilities of one algorithm, seeds in the spec's order."""
        return np.stack([r.utilities for r in self.runs if r.algorithm == algorithm])

    def summary(self) -> dict[str, ConfigSummary]:
        """Per algorithm: final mean, CI, % from uniform, % of max (see :mod:`mgrao_core.stats`)."""
        finals = {
            a: dict(zip(self.spec.seeds, final_utilities(self.utilities(a)).tolist(), strict=True))
            for a in self.spec.algorithms
        }
        return summarise(finals)

    def episode_bands(self, points: int | None = None) -> dict[str, dict[str, list[float]]]:
        """Per algorithm, the per-episode mean over seeds with its 95% band."""
        return {a: episode_band(self.utilities(a), points) for a in self.spec.algorithms}

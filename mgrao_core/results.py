"""Results of an experiment: every run's episode utilities and final learned weights."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mgrao_core.spec import ExperimentSpec
from mgrao_core.statistics.bands import episode_band
from mgrao_core.statistics.summary import ConfigSummary, final_utilities, summarise


@dataclass(frozen=True)
class TaskCounts:
    """What became of a run's atomic tasks when tasks can fail (``task_need``; docs/model.md, "Tasks that fail").

    Attributes:
        allocated: atomic tasks the parents allocated to children (counted only where a task can fail).
        failed: those that returned a failure, their value lost.
        handed_over: those the hierarchy completed through a neighbouring child (a borrowed share of its
            resource, or the task handed over to it; ``hierarchy``).
    """

    allocated: int = 0
    failed: int = 0
    handed_over: int = 0

    def __add__(self, other: TaskCounts) -> TaskCounts:
        return TaskCounts(self.allocated + other.allocated, self.failed + other.failed,
                          self.handed_over + other.handed_over)

    @property
    def failure_rate(self) -> float:
        """Share of the allocated atomic tasks that failed, in [0, 1]; 0 where none was counted."""
        return self.failed / self.allocated if self.allocated else 0.0

    @property
    def handover_rate(self) -> float:
        """Share of the allocated atomic tasks completed through a neighbour, in [0, 1]; 0 where none was counted."""
        return self.handed_over / self.allocated if self.allocated else 0.0

    def rates(self) -> dict[str, float]:
        """``{"failure_rate": ..., "handover_rate": ...}``, as summaries carry them."""
        return {"failure_rate": self.failure_rate, "handover_rate": self.handover_rate}


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
        tasks: what became of its atomic tasks (:class:`TaskCounts`; all 0 where no task can fail).
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
    tasks: TaskCounts = TaskCounts()


@dataclass(frozen=True)
class ExperimentResult:
    """All runs of an experiment, in the order algorithms x seeds."""

    spec: ExperimentSpec
    runs: tuple[Run, ...]

    def utilities(self, algorithm: str) -> np.ndarray:
        """``(seeds, episodes)`` utilities of one algorithm, seeds in the spec's order."""
        return np.stack([r.utilities for r in self.runs if r.algorithm == algorithm])

    def summary(self) -> dict[str, ConfigSummary]:
        """Per algorithm: final mean, CI, % from uniform, % of max (see :mod:`mgrao_core.statistics.summary`)."""
        finals = {
            a: dict(zip(self.spec.seeds, final_utilities(self.utilities(a)).tolist(), strict=True))
            for a in self.spec.algorithms
        }
        return summarise(finals)

    def task_counts(self) -> dict[str, TaskCounts]:
        """Per algorithm, its runs' :class:`TaskCounts` summed over seeds (rates pooled over every atomic task)."""
        out = {a: TaskCounts() for a in self.spec.algorithms}
        for run in self.runs:
            out[run.algorithm] = out[run.algorithm] + run.tasks
        return out

    def episode_bands(self, points: int | None = None) -> dict[str, dict[str, list[float]]]:
        """Per algorithm, the per-episode mean over seeds with its 95% band."""
        return {a: episode_band(self.utilities(a), points) for a in self.spec.algorithms}

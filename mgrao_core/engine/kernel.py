"""The batched kernel: many (seed, algorithm) lanes through the episodes of a block, in parallel.

Each lane is one run: one seed, one algorithm. Lanes are independent and run in parallel
(``numba.prange``); within a lane everything is sequential and in a fixed order, so a lane's
numbers do not depend on which other lanes run beside it, on the thread count, or on how the
episodes are split into blocks.

An episode follows the paper's five processing steps (section 3), with the child's allocation
fixed at its start (the paper: an allocation cannot change instantly):

1. composite tasks arrive, one per present parent (absent parents leave and rejoin first);
2. each parent decomposes its composite task into atomic tasks (their proportional values);
3. each parent allocates the atomic tasks to children;
4. each child performs its atomic tasks with the resources its allocation gives their types;
5. each composite task completes: its quality counts in the system utility, and the absolute
   values go back, composite by composite in a random order of parents, to the parents'
   estimates of their children and to the children, which learn from them (algorithm 1).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, prange

from mgrao_core.engine.environment import (
    allocate_atomic_tasks,
    parents_leave_and_join,
    perform_composite_task,
    proportional_values,
    update_estimates,
)
from mgrao_core.engine.learning import combined_weights, pw_update, rebase

KIND_UNIFORM = 0
KIND_ORACLE = 1
KIND_MGRAO = 2


class Lanes(NamedTuple):
    """Per-lane inputs and state (updated in place), first axis the lane.

    Attributes:
        seed_index: index of the lane's seed in the block's per-seed arrays.
        kind: ``KIND_UNIFORM``, ``KIND_ORACLE`` or ``KIND_MGRAO``.
        groups: parent groups ``m`` per child (MG-RAO lanes).
        fixed_weights: ``(lanes, children, n_types)`` the weights of uniform and oracle lanes.
        Y, F, H, cs, G, k_since_rebase: each child's lazy PW and trace (see
            :mod:`mgrao_core.engine.learning`), ``(lanes, children, groups[, n_types])``.
        counts: ``(lanes, children, groups)`` parent agent sample counts.
        weights: ``(lanes, children, n_types)`` each child's allocation in this episode.
        estimates, tries: ``(lanes, parents, choices, children)`` each parent's running mean of
            what each child gave back, and how often it tried it.
        active: ``(lanes, parents)`` which parents are present.
        profiles: ``(lanes, parents, types_per_composite)`` each parent's value profile.
    """

    seed_index: np.ndarray
    kind: np.ndarray
    groups: np.ndarray
    fixed_weights: np.ndarray
    Y: np.ndarray
    F: np.ndarray
    H: np.ndarray
    cs: np.ndarray
    G: np.ndarray
    k_since_rebase: np.ndarray
    counts: np.ndarray
    weights: np.ndarray
    estimates: np.ndarray
    tries: np.ndarray
    active: np.ndarray
    profiles: np.ndarray


class Worlds(NamedTuple):
    """What each seed drew once.

    ``parent_types (seeds, parents, types_per_composite)`` and ``resources (seeds, children)``.
    """

    parent_types: np.ndarray
    resources: np.ndarray


class Draws(NamedTuple):
    """The block's randomness per seed, first axes ``(seeds, episodes)``.

    See :class:`mgrao_core.world.EpisodeDraws`.
    """

    noise: np.ndarray
    order: np.ndarray
    volatility: np.ndarray
    new_profiles: np.ndarray
    routing: np.ndarray


@njit(cache=True)
def fix_allocation(Y, F, H, cs, G, k_since_rebase, counts, m, learning, weights, scratch):
    """A learning child fixes its resource weights for the episode.

    Its PW is materialised, then algorithm 2 writes ``weights``. Returns the updates since the
    rebase (now 0).
    """
    n = Y.shape[1]
    rebase(Y, F, H, cs, G, m, n, learning.gamma_pow[k_since_rebase])
    combined_weights(Y, counts, m, n, learning.temperature, weights, scratch)
    return 0


@njit(cache=True, inline="always")
def learn(Y, F, H, cs, G, k_since_rebase, counts, m, group, task_type, value, learning, rebase_due):
    """A learning child receives an atomic task's absolute value from a parent of ``group``.

    The sample count, then algorithm 1 (rebasing first when due). Returns the updates since the
    rebase and whether the next one is due early.
    """
    counts[group] += 1.0
    if rebase_due or k_since_rebase == learning.gamma_pow.shape[0] - 1:
        rebase(Y, F, H, cs, G, m, Y.shape[1], learning.gamma_pow[k_since_rebase])
        k_since_rebase = 0
    k_since_rebase += 1
    due = pw_update(Y, F, H, cs, G, m, k_since_rebase, group, task_type, learning.learning_rate * value,
                    learning.gamma_pow, learning.gamma_inv_pow)
    return k_since_rebase, due


@njit(cache=True, parallel=True)
def run_block(lanes, worlds, draws, env, learning, utilities):
    """Run every lane through the episodes of one block.

    The system utility of each lane and episode goes into ``utilities (lanes, episodes)``.
    """
    n_lanes = lanes.seed_index.shape[0]
    n_episodes = utilities.shape[1]
    n_parents, types_per_composite = worlds.parent_types.shape[1], worlds.parent_types.shape[2]
    n_children = lanes.weights.shape[1]
    for lane in prange(n_lanes):
        s = lanes.seed_index[lane]
        m = lanes.groups[lane]
        learning_lane = lanes.kind[lane] == KIND_MGRAO
        active = lanes.active[lane]
        Y, F, H, cs, G = lanes.Y[lane], lanes.F[lane], lanes.H[lane], lanes.cs[lane], lanes.G[lane]
        k_since_rebase, counts, weights = lanes.k_since_rebase[lane], lanes.counts[lane], lanes.weights[lane]
        child_of = np.zeros((n_parents, types_per_composite), dtype=np.int64)
        ctv = np.zeros((n_parents, types_per_composite))
        values = np.zeros((n_parents, types_per_composite))
        taq = np.zeros(n_parents)
        load = np.ones((n_children, lanes.weights.shape[2]))
        scratch = np.zeros(max(m, 1))
        rebase_due = np.zeros(n_children, dtype=np.bool_)
        for e in range(n_episodes):
            # 1. Composite tasks arrive at the parents present.
            parents_leave_and_join(active, lanes.profiles[lane], draws.volatility[s, e], draws.new_profiles[s, e], env)
            for c in range(n_children):
                if learning_lane:
                    k_since_rebase[c] = fix_allocation(Y[c], F[c], H[c], cs[c], G[c], k_since_rebase[c], counts[c],
                                                       m, learning, weights[c], scratch)
                    rebase_due[c] = False
                else:
                    weights[c, :] = lanes.fixed_weights[lane, c, :]
            # 2-3. Parents decompose their composite tasks and allocate the atomic tasks.
            for p in range(n_parents):
                if active[p]:
                    proportional_values(lanes.profiles[lane, p], draws.noise[s, e, p], env.value_noise, ctv[p])
                    if n_children == 1:  # no choice (and no routing draws to index)
                        child_of[p, :] = 0
                    else:
                        allocate_atomic_tasks(lanes.estimates[lane, p], draws.routing[s, e, p], env, child_of[p])
            if env.load_sharing:
                load[:, :] = 0.0
                for p in range(n_parents):
                    if active[p]:
                        for k in range(types_per_composite):
                            load[child_of[p, k], worlds.parent_types[s, p, k]] += 1.0
            # 4. Children perform the atomic tasks; composite qualities make the system utility.
            utility = 0.0
            for p in range(n_parents):
                if active[p]:
                    taq[p] = perform_composite_task(ctv[p], child_of[p], worlds.parent_types[s, p],
                                                    weights, worlds.resources[s], load, env, values[p])
                    utility += taq[p]
                elif env.absent_counted:
                    utility += env.absent_quality
            utilities[lane, e] = utility
            # 5. Values come back composite by composite, in a random order of parents.
            for i in range(n_parents):
                p = draws.order[s, e, i]
                if not active[p]:
                    continue
                if n_children > 1:
                    update_estimates(lanes.estimates[lane, p], lanes.tries[lane, p], child_of[p], values[p], taq[p],
                                     env.per_composite)
                if learning_lane:
                    group = (p * m) // n_parents
                    for k in range(types_per_composite):
                        c = child_of[p, k]
                        k_since_rebase[c], rebase_due[c] = learn(
                            Y[c], F[c], H[c], cs[c], G[c], k_since_rebase[c], counts[c], m, group,
                            worlds.parent_types[s, p, k], values[p, k], learning, rebase_due[c],
                        )


@njit(cache=True)
def finish(lanes, learning):
    """Materialise every MG-RAO lane's final PW and combined weights (after the last episode)."""
    for lane in range(lanes.kind.shape[0]):
        if lanes.kind[lane] != KIND_MGRAO:
            continue
        m = lanes.groups[lane]
        scratch = np.zeros(m)
        for c in range(lanes.Y.shape[1]):
            lanes.k_since_rebase[lane, c] = fix_allocation(
                lanes.Y[lane, c], lanes.F[lane, c], lanes.H[lane, c], lanes.cs[lane, c], lanes.G[lane, c],
                lanes.k_since_rebase[lane, c], lanes.counts[lane, c], m, learning, lanes.weights[lane, c], scratch,
            )

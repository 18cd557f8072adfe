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
        rows, slot, n_rows: each child's active rows (the first ``n_rows`` of ``rows``), a row's
            place among them (-1: inactive), ``(lanes, children[, groups])``.
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
    rows: np.ndarray
    slot: np.ndarray
    n_rows: np.ndarray
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
def fix_allocation(Y, F, H, cs, G, rows, slot, n_rows, k_since_rebase, counts, m, bounded, learning, weights,
                   scratch):
    """A learning child fixes its resource weights for the episode.

    Its PW is materialised, then algorithm 2 writes ``weights``. Returns the number of active rows
    (the updates since the rebase are now 0).
    """
    n_rows = rebase(Y, F, H, cs, G, rows, slot, n_rows, learning.gamma_pow[k_since_rebase], learning.trace_tail,
                    bounded)
    combined_weights(Y, counts, m, Y.shape[1], learning.temperature, weights, scratch)
    return n_rows


@njit(cache=True, inline="always")
def learn(Y, F, H, cs, G, rows, slot, n_rows, k_since_rebase, counts, rebase_due, c, bounded, group, task_type, value,
          learning):
    """Child ``c`` receives an atomic task's absolute value from a parent of ``group``.

    The sample count, then algorithm 1 (rebasing first when due). The arrays are the lane's, first
    index the child (so that no per-child view is made for every task).
    """
    counts[c, group] += 1.0
    k = k_since_rebase[c]
    if rebase_due[c] or k == learning.gamma_pow.shape[0] - 1:
        n_rows[c] = rebase(Y[c], F[c], H[c], cs[c], G[c], rows[c], slot[c], n_rows[c], learning.gamma_pow[k],
                           learning.trace_tail, bounded)
        k = 0
    k += 1
    k_since_rebase[c] = k
    rebase_due[c] = pw_update(Y, F, H, cs, G, rows, slot, n_rows, c, k, group, task_type,
                              learning.learning_rate * value, learning.gamma_pow, learning.gamma_inv_pow, bounded)


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
        bounded = m > learning.min_bounded_groups
        Y, F, H, cs, G = lanes.Y[lane], lanes.F[lane], lanes.H[lane], lanes.cs[lane], lanes.G[lane]
        rows, slot, n_rows = lanes.rows[lane], lanes.slot[lane], lanes.n_rows[lane]
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
                    n_rows[c] = fix_allocation(Y[c], F[c], H[c], cs[c], G[c], rows[c], slot[c], n_rows[c],
                                               k_since_rebase[c], counts[c], m, bounded, learning, weights[c], scratch)
                    k_since_rebase[c] = 0
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
                        learn(Y, F, H, cs, G, rows, slot, n_rows, k_since_rebase, counts, rebase_due, c, bounded,
                              group, worlds.parent_types[s, p, k], values[p, k], learning)


@njit(cache=True)
def finish(lanes, learning):
    """Materialise every MG-RAO lane's final PW and combined weights (after the last episode)."""
    for lane in range(lanes.kind.shape[0]):
        if lanes.kind[lane] != KIND_MGRAO:
            continue
        m = lanes.groups[lane]
        scratch = np.zeros(m)
        for c in range(lanes.Y.shape[1]):
            lanes.n_rows[lane, c] = fix_allocation(
                lanes.Y[lane, c], lanes.F[lane, c], lanes.H[lane, c], lanes.cs[lane, c], lanes.G[lane, c],
                lanes.rows[lane, c], lanes.slot[lane, c], lanes.n_rows[lane, c], lanes.k_since_rebase[lane, c],
                lanes.counts[lane, c], m, m > learning.min_bounded_groups, learning, lanes.weights[lane, c], scratch,
            )
            lanes.k_since_rebase[lane, c] = 0

"""The batched simulation kernel: many (seed, algorithm) lanes at once, compiled with numba.

Each lane is one run: one seed, one algorithm. Lanes are independent and run in parallel
(``numba.prange``); within a lane everything is sequential and in a fixed order, so a lane's
numbers do not depend on which other lanes run beside it, on the thread count, or on how the
episodes are split into blocks.

Cost per returned value. Algorithm 1 adds ``alpha * atv * E`` to the whole ``PW`` matrix and
sum-normalises every row. Done densely that is O(m * n) per value. Here it is O(m): for every
row ``i`` we keep ``PW[i, j] = cs[i] * (Y[i, j] + F[i, j] * H[i])`` and ``E[i, j] = gamma**k *
F[i, j]``, where ``k`` counts the child's updates since the last *rebase*:

* the trace update touches one entry of ``F`` (replace with ``gamma**-k``; every other entry
  decays implicitly through ``gamma**k``), folding the change into ``Y`` so ``PW`` is unchanged;
* ``PW += a * E`` is ``H[i] += a * gamma**k / cs[i]`` for every row;
* each row sum becomes ``1 + a * gamma**k * G[i]`` with ``G[i] = sum_j F[i, j]``, so
  the row normalisation is ``cs[i] /= 1 + a * gamma**k * G[i]``.

A rebase materialises ``PW`` and ``E`` (O(m * n)) at the start of every episode, where the
combined weights need the whole matrix anyway, and whenever ``gamma**-k`` or ``1 / cs`` grow
large enough to cost precision (see :data:`TRACE_SCALE_LIMIT`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

KIND_UNIFORM = 0
KIND_ORACLE = 1
KIND_MGRAO = 2

_SCALE_LIMIT = 1e-150  # rebase before any cs[i] falls below this


TRACE_SCALE_LIMIT = 64.0
"""Largest ``gamma**-k`` between rebases. ``Y + F * H`` cancels terms of size up to about
``gamma**-k * k * alpha * atv`` times an entry of PW, so this bound keeps the lazy form within
about 1e-13 of the dense update (checked against :mod:`mgrao_core.reference`); with gamma = 0.9
it means a rebase every 39 updates, which costs O(m * n / 39) per update, below the O(m) of the
update itself for n_types up to 39."""


def rebase_interval(trace_decay: float) -> int:
    """Updates between rebases so that ``trace_decay ** -k`` stays below :data:`TRACE_SCALE_LIMIT`."""
    return int(max(1, min(100_000, math.floor(math.log(TRACE_SCALE_LIMIT) / -math.log(trace_decay)))))


@njit(cache=True)
def _rebase(Y, F, H, cs, G, m, n, gamma_k):
    """Materialise PW into Y and E into F for rows ``< m``; reset H, cs and G."""
    for i in range(m):
        total = 0.0
        for j in range(n):
            value = cs[i] * (Y[i, j] + F[i, j] * H[i])
            Y[i, j] = value
            total += value
        trace_sum = 0.0
        for j in range(n):
            Y[i, j] /= total
            F[i, j] *= gamma_k
            trace_sum += F[i, j]
        H[i] = 0.0
        cs[i] = 1.0
        G[i] = trace_sum


@njit(cache=True)
def _combined_weights(PW, counts, m, n, temperature, out, scratch):
    """Algorithm 2 on materialised rows: ``softmax(sumnorm(B) @ PW / temperature)`` into ``out``."""
    kl_total = 0.0
    count_total = 0.0
    for i in range(m):
        kl = 0.0
        for j in range(n):
            w = PW[i, j]
            if w > 0.0:
                kl += w * math.log(w * n)
        if kl < 0.0:
            kl = 0.0
        scratch[i] = kl
        kl_total += kl
        count_total += counts[i]
    blend_total = 0.0
    for i in range(m):
        kl_part = scratch[i] / kl_total if kl_total > 0.0 else 1.0 / m
        count_part = counts[i] / count_total if count_total > 0.0 else 1.0 / m
        scratch[i] = kl_part + count_part
        blend_total += scratch[i]
    top = -np.inf
    for j in range(n):
        v = 0.0
        for i in range(m):
            v += scratch[i] / blend_total * PW[i, j]
        v /= temperature
        out[j] = v
        if v > top:
            top = v
    total = 0.0
    for j in range(n):
        out[j] = math.exp(out[j] - top)
        total += out[j]
    for j in range(n):
        out[j] /= total


@njit(cache=True)
def _choose_child(estimates, u, epsilon, boltzmann_temperature, tie_first):
    """A parent's epsilon-greedy choice of child for one atomic task (multi-child system)."""
    n_children = estimates.shape[0]
    best_value = estimates[0]
    ties = 1
    for c in range(1, n_children):
        if estimates[c] > best_value:
            best_value = estimates[c]
            ties = 1
        elif estimates[c] == best_value:
            ties += 1
    pick = 0 if tie_first else min(int(u[2] * ties), ties - 1)
    best = 0
    for c in range(n_children):
        if estimates[c] == best_value:
            if pick == 0:
                best = c
                break
            pick -= 1
    if n_children == 1 or u[0] >= epsilon:
        return best
    top = -np.inf
    for c in range(n_children):
        if c != best and estimates[c] > top:
            top = estimates[c]
    total = 0.0
    for c in range(n_children):
        if c != best:
            total += math.exp((estimates[c] - top) / boltzmann_temperature)
    target = u[1] * total
    chosen = -1
    for c in range(n_children):
        if c != best:
            chosen = c
            target -= math.exp((estimates[c] - top) / boltzmann_temperature)
            if target < 0.0:
                break
    return chosen


@njit(cache=True)
def _learn(Y, F, H, cs, G, m, n, k, group, task_type, step, gamma_pow, gamma_inv_pow):
    """Algorithm 1 for one returned value; ``step = alpha * atv``; returns True if a rebase is due."""
    f_new = gamma_inv_pow[k]
    f_old = F[group, task_type]
    Y[group, task_type] += (f_old - f_new) * H[group]
    F[group, task_type] = f_new
    G[group] += f_new - f_old
    scale = step * gamma_pow[k]
    due = False
    for i in range(m):
        if G[i] > 0.0:
            H[i] += scale / cs[i]
            cs[i] /= 1.0 + scale * G[i]
            if cs[i] < _SCALE_LIMIT:
                due = True
    return due


@njit(cache=True, parallel=True)
def run_block(
    # static, per lane
    lane_seed, lane_kind, lane_groups, fixed_weights,
    # static, per seed
    parent_types,
    # state, per lane (updated in place)
    Y, F, H, cs, G, k_since_rebase, counts, weights, estimates, tries, active, profiles,
    # randomness of this block, per seed
    noise, order, volatility, new_profiles, routing,
    # parameters
    n_types, quality_at_uniform, quality_floor, value_noise, learning_rate, temperature,
    epsilon, boltzmann_temperature, tie_first, leave, join, rejoin_new,
    gamma_pow, gamma_inv_pow,
    # output: utility per lane and episode of the block
    utilities,
):
    """Run every lane through the episodes of one block (see the module docstring)."""
    n_lanes = lane_seed.shape[0]
    n_episodes = utilities.shape[1]
    n_parents = parent_types.shape[1]
    per_composite = parent_types.shape[2]
    n_children = weights.shape[1]
    rebase_every = gamma_pow.shape[0] - 1
    for lane in prange(n_lanes):
        s = lane_seed[lane]
        kind = lane_kind[lane]
        m = lane_groups[lane]
        child_of = np.zeros((n_parents, per_composite), dtype=np.int64)
        values = np.zeros((n_parents, per_composite))
        ctv = np.zeros(per_composite)
        scratch = np.zeros(max(m, 1))
        rebase_due = np.zeros(n_children, dtype=np.bool_)
        for e in range(n_episodes):
            # Volatility: active parents leave, absent parents rejoin (start of episode).
            if leave > 0.0 or join > 0.0:
                for p in range(n_parents):
                    if active[lane, p]:
                        if volatility[s, e, p] < leave:
                            active[lane, p] = False
                    elif volatility[s, e, p] < join:
                        active[lane, p] = True
                        if rejoin_new:
                            for k in range(per_composite):
                                profiles[lane, p, k] = new_profiles[s, e, p, k]
            # Each child fixes its allocation for the episode from its current model.
            for c in range(n_children):
                if kind == KIND_MGRAO:
                    _rebase(Y[lane, c], F[lane, c], H[lane, c], cs[lane, c], G[lane, c], m, n_types,
                            gamma_pow[k_since_rebase[lane, c]])
                    k_since_rebase[lane, c] = 0
                    rebase_due[c] = False
                    _combined_weights(Y[lane, c], counts[lane, c], m, n_types, temperature,
                                      weights[lane, c], scratch)
                else:
                    for j in range(n_types):
                        weights[lane, c, j] = fixed_weights[lane, c, j]
            # Parents allocate atomic tasks; children perform them; composite qualities.
            utility = 0.0
            for p in range(n_parents):
                if not active[lane, p]:
                    continue
                total = 0.0
                for k in range(per_composite):
                    if n_children == 1:
                        child_of[p, k] = 0
                    else:
                        child_of[p, k] = _choose_child(estimates[lane, p, k], routing[s, e, p, k],
                                                       epsilon, boltzmann_temperature, tie_first)
                    ctv[k] = profiles[lane, p, k] * math.exp(value_noise * noise[s, e, p, k])
                    total += ctv[k]
                taq = 0.0
                for k in range(per_composite):
                    ctv[k] /= total
                    share = weights[lane, child_of[p, k], parent_types[s, p, k]]
                    quality = min(1.0, quality_at_uniform * n_types * share)
                    taq += ctv[k] * max(quality, quality_floor)
                for k in range(per_composite):
                    values[p, k] = taq * ctv[k]
                utility += taq
            utilities[lane, e] = utility
            # Values come back composite by composite, in a random order of parents.
            for i in range(n_parents):
                p = order[s, e, i]
                if not active[lane, p]:
                    continue
                group = (p * m) // n_parents
                for k in range(per_composite):
                    c = child_of[p, k]
                    value = values[p, k]
                    if n_children > 1:
                        tries[lane, p, k, c] += 1
                        if tries[lane, p, k, c] == 1:
                            estimates[lane, p, k, c] = value
                        else:
                            estimates[lane, p, k, c] += (value - estimates[lane, p, k, c]) / tries[lane, p, k, c]
                    if kind != KIND_MGRAO:
                        continue
                    counts[lane, c, group] += 1.0
                    if rebase_due[c] or k_since_rebase[lane, c] == rebase_every:
                        _rebase(Y[lane, c], F[lane, c], H[lane, c], cs[lane, c], G[lane, c], m, n_types,
                                gamma_pow[k_since_rebase[lane, c]])
                        k_since_rebase[lane, c] = 0
                    k_since_rebase[lane, c] += 1
                    rebase_due[c] = _learn(Y[lane, c], F[lane, c], H[lane, c], cs[lane, c], G[lane, c], m,
                                           n_types, k_since_rebase[lane, c], group, parent_types[s, p, k],
                                           learning_rate * value, gamma_pow, gamma_inv_pow)


@njit(cache=True, parallel=True)
def finish(lane_kind, lane_groups, Y, F, H, cs, G, k_since_rebase, counts, weights, temperature, gamma_pow):
    """Materialise every MG-RAO lane's final PW and combined weights (after the last episode)."""
    n_types = Y.shape[3]
    for lane in prange(lane_kind.shape[0]):
        if lane_kind[lane] != KIND_MGRAO:
            continue
        m = lane_groups[lane]
        scratch = np.zeros(m)
        for c in range(Y.shape[1]):
            _rebase(Y[lane, c], F[lane, c], H[lane, c], cs[lane, c], G[lane, c], m, n_types,
                    gamma_pow[k_since_rebase[lane, c]])
            k_since_rebase[lane, c] = 0
            _combined_weights(Y[lane, c], counts[lane, c], m, n_types, temperature, weights[lane, c], scratch)

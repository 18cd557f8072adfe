"""``mgrao-balance``'s compiled steps: MG-RAO's algorithms 1 and 2 on a child's own number of groups, and its splits.

What the kernel (:mod:`mgrao_core.engine.kernel`) calls for a balance lane: :func:`lane_of` (the lane's views,
once), :func:`allocate` (at the start of an episode: MG-RAO's rebase, the decision when it is due, the task share,
then algorithm 2), :func:`learn` (a composite task's values: MG-RAO's algorithm 1 for the parent's group among the
child's) and :func:`finish`. Algorithms 1 and 2 are MG-RAO's own functions
(:mod:`mgrao_core.algorithms.mgrao.compiled`) on the same lazy PW arrays, sized for the bound's ``M`` rows; each
child uses its first ``m`` (``balance_groups``). The rule is stated in :mod:`mgrao_core.algorithms.balance.family`.

A split comes right after the rebase, when every row's PW is materialised in ``Y`` and its trace in ``F``, with no
pending update (``H`` 0, scale 1): copying rows is then exact, and the child's active rows are rebuilt from the
copied traces. A child's rows are in MG-RAO's bounded form when it has more than
:data:`~mgrao_core.algorithms.mgrao.family.MIN_BOUNDED_GROUPS` groups; it can cross that line only at a split,
where both forms hold the same numbers.
"""

from __future__ import annotations

import mgrao_core._numba_cache  # noqa: F401  (first: picks a writable numba cache before numba loads)

# isort: split
import math
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
from numba import njit

from mgrao_core import equations
from mgrao_core.algorithms.adaptive import compiled as adaptive
from mgrao_core.algorithms.balance import family
from mgrao_core.algorithms.mgrao import compiled as mgrao
from mgrao_core.algorithms.state import System

_OWN = ("balance_groups", "balance_last_split", "balance_settled", "episodes_seen", "membership",
        "membership_history", "n_snapshots", "snapshot_stride")
task_share = njit(inline="always")(equations.task_share)
"""The share of resources a child's tasks get (:func:`mgrao_core.equations.task_share`, compiled)."""
smallest_prime_factor = njit(cache=True)(family.smallest_prime_factor)
"""The factor of a split (:func:`mgrao_core.algorithms.balance.family.next_split`), compiled."""


class BalanceLanes(NamedTuple):
    """Every lane's state and the parameters as the kernel reads them: MG-RAO's fields, then the family's.

    One flat tuple (numba's parallel loop takes no nested one). The family's arrays are declared in
    :mod:`mgrao_core.algorithms.balance.family`. ``learned_per_group * m + rule_numbers`` is
    :meth:`~mgrao_core.algorithms.balance.family.Balance.learned_for` ``m`` groups, priced against ``learned_by_max``.
    """

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
    rebase_due: np.ndarray
    row_kl: np.ndarray
    learning_rate: float
    temperature: float
    gamma_pow: np.ndarray
    gamma_inv_pow: np.ndarray
    trace_tail: float
    min_bounded_groups: int
    use_counts: bool
    balance_groups: np.ndarray
    balance_last_split: np.ndarray
    balance_settled: np.ndarray
    episodes_seen: np.ndarray
    membership: np.ndarray
    membership_history: np.ndarray
    n_snapshots: np.ndarray
    snapshot_stride: np.ndarray
    every: int
    threshold: float
    learning_cost: float
    learned_per_group: int
    rule_numbers: int
    learned_by_max: int


def lanes_of(arrays: Mapping[str, np.ndarray], params: System) -> BalanceLanes:
    """The kernel's view of the chunk's balance arrays (by name, as declared) and of a validated parameter set."""
    from mgrao_core.algorithms import learned_by_max

    without_groups = family.FAMILY.learned_for(0, params)  # learned_for(m) is per_group * m + without_groups
    per_group = family.FAMILY.learned_for(1, params) - without_groups
    return BalanceLanes(*mgrao.lanes_of(arrays, params), *(arrays[name] for name in _OWN), int(params.balance_every),
                        params.balance_tolerance * params.learning_cost, params.learning_cost,
                        per_group, without_groups, learned_by_max(params))


@njit(cache=True, inline="always")
def lane_of(bl, lane):
    """Lane ``lane``'s views: MG-RAO's (:func:`mgrao_core.algorithms.mgrao.compiled.lane_of`), then the family's.

    A plain tuple, items 0-11 MG-RAO's, then balance_groups, balance_last_split, balance_settled,
    episodes_seen, membership, membership_history, n_snapshots, snapshot_stride (items 12-19).
    """
    return (bl.Y[lane], bl.F[lane], bl.H[lane], bl.cs[lane], bl.G[lane], bl.rows[lane], bl.slot[lane],
            bl.n_rows[lane], bl.k_since_rebase[lane], bl.counts[lane], bl.rebase_due[lane], bl.row_kl[lane],
            bl.balance_groups[lane], bl.balance_last_split[lane], bl.balance_settled[lane], bl.episodes_seen[lane],
            bl.membership[lane], bl.membership_history[lane], bl.n_snapshots[lane], bl.snapshot_stride[lane])


@njit(cache=True)
def divergence(PW, m, q):
    """``(1/m) sum_rows sum_j (r[j] - mu[j]) log(r[j] / mu[j])``: how far the last split's rows (``q`` siblings) moved.

    ``mu[j]`` is the siblings' mean, summed in row order and divided by ``q``; entries that are not positive add
    nothing (PW's are positive: sum-normalised sums of positive terms).
    """
    n = PW.shape[1]
    total = 0.0
    for i in range(m):
        first = (i // q) * q
        for j in range(n):
            mu = 0.0
            for s in range(first, first + q):
                mu += PW[s, j]
            mu /= q
            r = PW[i, j]
            if r > 0.0 and mu > 0.0:
                total += (r - mu) * math.log(r / mu)
    return total / m


@njit(cache=True)
def split(Y, F, H, cs, G, rows, slot, counts, m, q):
    """Divide each of a child's ``m`` groups into ``q``: copies of its PW row and trace, a ``q``-th of its count.

    Called right after a rebase (every row materialised, nothing pending). Row ``g`` goes to rows ``g * q`` to ``g *
    q + q - 1``, from the last group down so that no row is overwritten before it is copied. The active rows are
    then the rows with a trace, in row order (``H`` 0, scale 1, ``G`` the trace's sum). Returns their number.
    """
    n = Y.shape[1]
    for g in range(m - 1, -1, -1):
        share = counts[g] / q
        for j in range(q - 1, -1, -1):
            i = g * q + j
            if i != g:
                for t in range(n):
                    Y[i, t] = Y[g, t]
                    F[i, t] = F[g, t]
            counts[i] = share
    n_rows = 0
    for i in range(m * q):
        trace_sum = 0.0
        for t in range(n):
            trace_sum += F[i, t]
        if trace_sum > 0.0:
            rows[n_rows] = i
            slot[i] = n_rows
            H[n_rows] = 0.0
            cs[n_rows] = 1.0
            G[n_rows] = trace_sum
            n_rows += 1
        else:
            slot[i] = -1
    return n_rows


@njit(cache=True, inline="always")
def decide(bl, views, bound, c):
    """Child ``c``'s decision, when due (the rows are materialised): split, settle, or nothing; its membership recorded.

    Returns the child's groups after it.
    """
    m = views[12][c]
    if views[14][c] or m >= bound:
        pass
    elif m == 1 or divergence(views[0][c], m, views[13][c]) >= bl.threshold:
        q = smallest_prime_factor(bound // m)
        views[7][c] = split(views[0][c], views[1][c], views[2][c], views[3][c], views[4][c], views[5][c],
                            views[6][c], views[9][c], m, q)
        views[11][c][: m * q] = math.nan  # the rows are copies now: every one's dkl to be computed
        m *= q
        views[12][c] = m
        views[13][c] = q
    else:
        views[14][c] = True
    n_parents = views[16].shape[1]
    for p in range(n_parents):  # through the tuple's item (see MG-RAO's allocate)
        views[16][c][p] = (p * m) // n_parents
    return m


@njit(cache=True, inline="always")
def allocate(bl, views, bound, c, weights, shares):
    """Child ``c`` begins an episode: MG-RAO's rebase, its decision every ``every`` episodes, then its allocation.

    ``bound`` is the lane's ``M``; the child's task share for the episode goes into ``shares[c]``. The views are
    indexed by position (see MG-RAO's :func:`~mgrao_core.algorithms.mgrao.compiled.allocate`).
    """
    m = views[12][c]
    k = views[8][c]
    views[7][c] = mgrao.rebase(views[0][c], views[1][c], views[2][c], views[3][c], views[4][c], views[5][c],
                               views[6][c], views[7][c], bl.gamma_pow[k], bl.trace_tail, m > bl.min_bounded_groups,
                               views[11][c])
    views[8][c] = 0
    views[10][c] = False
    e = views[15][c]
    if e > 0 and e % bl.every == 0:
        m = decide(bl, views, bound, c)
        n, s = adaptive.record(views[17][c], views[18][c], views[19][c], e // bl.every, views[16][c])
        views[18][c] = n
        views[19][c] = s
    views[15][c] = e + 1
    shares[c] = task_share(bl.learning_cost, m * bl.learned_per_group + bl.rule_numbers, bl.learned_by_max)
    Y = views[0][c]
    mgrao.combined_weights(Y, views[9][c], m, Y.shape[1], bl.temperature, weights, views[11][c], views[6][c],
                           bl.use_counts)


@njit(cache=True, inline="always")
def learn(bl, views, p, n_parents, children, task_types, values):
    """The values of parent ``p``'s composite task come back: algorithm 1 on the parent's group among each child's.

    Atomic task ``k``, of type ``task_types[k]``, gives ``values[k]`` to child ``children[k]``, whose ``m`` groups
    put the parent in group ``floor(p * m / n_parents)``.
    """
    Y, F, H, cs, G, rows, slot = views[0], views[1], views[2], views[3], views[4], views[5], views[6]
    n_rows, k_since_rebase, counts, rebase_due, groups = views[7], views[8], views[9], views[10], views[12]
    for k in range(task_types.shape[0]):
        c = children[k]
        m = groups[c]
        mgrao.learn_value(Y, F, H, cs, G, rows, slot, n_rows, k_since_rebase, counts, rebase_due, views[11], c,
                          m > bl.min_bounded_groups, (p * m) // n_parents, task_types[k], values[k], bl)


@njit(cache=True)
def finish(bl, lane, weights):
    """Materialise lane ``lane``'s final PW and combined weights (after the last episode) into ``weights``.

    MG-RAO's final allocation on each child's groups, without a decision (no episode follows).
    """
    views = lane_of(bl, lane)
    for c in range(weights.shape[0]):
        m = views[12][c]
        views[7][c] = mgrao.fix_allocation(views[0][c], views[1][c], views[2][c], views[3][c], views[4][c],
                                           views[5][c], views[6][c], views[7][c], views[9][c], m,
                                           m > bl.min_bounded_groups, bl.gamma_pow[views[8][c]], bl.trace_tail,
                                           bl.temperature, weights[c], views[11][c], bl.use_counts)
        views[8][c] = 0
        views[10][c] = False

"""``mgrao-adaptive:x``'s compiled steps: MG-RAO's algorithms 1 and 2, per-parent statistics, regrouping.

What the kernel (:mod:`mgrao_core.engine.kernel`) calls for an adaptive lane: :func:`lane_of` (the
lane's views, once), :func:`allocate` (at the start of an episode: the regrouping when it is due,
then MG-RAO's allocation), :func:`learn` (a composite task's values: the parent's statistics, then
MG-RAO's algorithm 1 for the row the parent is in) and :func:`finish`. Algorithms 1 and 2 are
MG-RAO's own functions (:mod:`mgrao_core.algorithms.mgrao.compiled`), called on the same lazy PW
arrays; :class:`AdaptiveLanes` has every field of
:class:`~mgrao_core.algorithms.mgrao.compiled.MgraoLanes` (so MG-RAO's steps read it as their own)
and the family's.
"""

from __future__ import annotations

import mgrao_core._numba_cache  # noqa: F401  (first: picks a writable numba cache before numba loads)

# isort: split
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
from numba import njit

from mgrao_core.algorithms.mgrao import compiled as mgrao
from mgrao_core.algorithms.state import System

_OWN = ("membership", "returns", "signature_mean", "signature_m2", "spread_mean", "spread_m2", "episodes_seen",
        "votes", "taken", "membership_history", "n_snapshots", "snapshot_stride")


class AdaptiveLanes(NamedTuple):
    """Every lane's state and the parameters as the kernel reads them: MG-RAO's fields, then the family's.

    One flat tuple (numba's parallel loop takes no nested one). The family's arrays are declared in
    :mod:`mgrao_core.algorithms.adaptive.family`; ``regroup_every`` and ``by_types`` (the
    ``regroup_by`` rule is ``types``) are its parameters.
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
    membership: np.ndarray
    returns: np.ndarray
    signature_mean: np.ndarray
    signature_m2: np.ndarray
    spread_mean: np.ndarray
    spread_m2: np.ndarray
    episodes_seen: np.ndarray
    votes: np.ndarray
    taken: np.ndarray
    membership_history: np.ndarray
    n_snapshots: np.ndarray
    snapshot_stride: np.ndarray
    regroup_every: int
    by_types: bool


def lanes_of(arrays: Mapping[str, np.ndarray], params: System) -> AdaptiveLanes:
    """The kernel's view of the chunk's adaptive arrays (by name, as declared) and of a validated parameter set."""
    return AdaptiveLanes(*mgrao.lanes_of(arrays, params), *(arrays[name] for name in _OWN),
                         int(params.regroup_every), params.regroup_by == "types")


@njit(cache=True, inline="always")
def lane_of(al, lane):
    """Lane ``lane``'s views: MG-RAO's (:func:`mgrao_core.algorithms.mgrao.compiled.lane_of`), then the family's.

    A plain tuple, items 0-11 MG-RAO's, then membership, returns, signature_mean, signature_m2,
    spread_mean, spread_m2, episodes_seen, votes, taken, membership_history, n_snapshots,
    snapshot_stride (items 12-23).
    """
    return (al.Y[lane], al.F[lane], al.H[lane], al.cs[lane], al.G[lane], al.rows[lane], al.slot[lane],
            al.n_rows[lane], al.k_since_rebase[lane], al.counts[lane], al.rebase_due[lane], al.row_kl[lane],
            al.membership[lane], al.returns[lane], al.signature_mean[lane], al.signature_m2[lane],
            al.spread_mean[lane], al.spread_m2[lane], al.episodes_seen[lane], al.votes[lane], al.taken[lane],
            al.membership_history[lane], al.n_snapshots[lane], al.snapshot_stride[lane])


@njit(cache=True)
def grouping_order(returns, signature_mean, signature_m2, spread_m2, by_types):
    """The parents in the rule's order (the family module's docstring): predictable first, ties by parent.

    Sorting stably by the least significant key first, then by the more significant ones, orders
    the parents by (signature variance, signature mean [``by_types``], spread variance, parent); a
    parent never heard from has infinite variances.
    """
    n = returns.shape[0]
    sig_var = np.empty(n)
    spread_var = np.empty(n)
    for p in range(n):
        if returns[p] > 0.0:
            sig_var[p] = signature_m2[p] / returns[p]
            spread_var[p] = spread_m2[p] / returns[p]
        else:
            sig_var[p] = np.inf
            spread_var[p] = np.inf
    order = np.argsort(spread_var, kind="mergesort")
    if by_types:
        order = order[np.argsort(signature_mean[order], kind="mergesort")]
    return order[np.argsort(sig_var[order], kind="mergesort")]


@njit(cache=True)
def regroup(membership, returns, signature_mean, signature_m2, spread_m2, votes, taken, m, by_types):
    """Re-form a child's ``m`` groups: cut the ordered parents into ``m`` runs; each run takes an old row.

    The parent at place ``r`` of :func:`grouping_order` goes to run ``floor(r * m / n)``; run ``g``
    in turn takes the row not yet taken that most of its parents were in (ties: the lower row), so
    rows keep as many of their parents as this greedy matching allows. Writes ``membership``.
    """
    n = membership.shape[0]
    order = grouping_order(returns, signature_mean, signature_m2, spread_m2, by_types)
    taken[:m] = False
    new = np.empty(n, dtype=np.int64)
    start = 0
    for g in range(m):
        end = ((g + 1) * n + m - 1) // m  # places r with floor(r * m / n) == g are start .. end - 1
        votes[:m] = 0
        for r in range(start, end):
            votes[membership[order[r]]] += 1
        best = -1
        for i in range(m):
            if not taken[i] and (best < 0 or votes[i] > votes[best]):
                best = i
        taken[best] = True
        for r in range(start, end):
            new[order[r]] = best
        start = end
    membership[:] = new


@njit(cache=True)
def record(history, n_snapshots, stride, regroups, membership):
    """Record the membership after regroup ``regroups`` if it falls on the stride (halving the records when full).

    Returns the new ``(n_snapshots, stride)``.
    """
    if regroups % stride:
        return n_snapshots, stride
    if n_snapshots == history.shape[0]:
        half = (n_snapshots + 1) // 2
        for i in range(1, half):
            history[i, :] = history[2 * i, :]
        n_snapshots = half
        stride *= 2
        if regroups % stride:
            return n_snapshots, stride
    for p in range(membership.shape[0]):
        history[n_snapshots, p] = membership[p]
    return n_snapshots + 1, stride


@njit(cache=True, inline="always")
def allocate(al, views, m, c, weights):
    """Child ``c`` begins an episode: it regroups every ``regroup_every`` episodes, then fixes its allocation.

    MG-RAO's allocation (:func:`mgrao_core.algorithms.mgrao.compiled.allocate`) on the lane's PW.
    The views are indexed by position (see MG-RAO's :func:`~mgrao_core.algorithms.mgrao.compiled.allocate`).
    """
    e = views[18][c]
    if e > 0 and e % al.regroup_every == 0:
        regroup(views[12][c], views[13][c], views[14][c], views[15][c], views[17][c], views[19], views[20], m,
                al.by_types)
        n, s = record(views[21][c], views[22][c], views[23][c], e // al.regroup_every, views[12][c])
        views[22][c] = n
        views[23][c] = s
    views[18][c] = e + 1
    mgrao.allocate(al, views, m, c, weights)


@njit(cache=True, inline="always")
def welford(count, mean, m2, p, x):
    """Add ``x`` to parent ``p``'s running mean and sum of squared deviations (``count[p]`` already counts it)."""
    delta = x - mean[p]
    mean[p] += delta / count[p]
    m2[p] += delta * (x - mean[p])


@njit(cache=True, inline="always")
def observe(returns, signature_mean, signature_m2, spread_mean, spread_m2, c, p, children, task_types, values):
    """Child ``c``'s statistics of parent ``p`` take in the atomic tasks of its composite that ``c`` performed.

    The type signature is their mean type; the value spread is their largest value over their sum.
    """
    count = 0
    type_sum = 0.0
    value_sum = 0.0
    largest = 0.0
    for k in range(task_types.shape[0]):
        if children[k] == c:
            count += 1
            type_sum += task_types[k]
            value_sum += values[k]
            largest = max(largest, values[k])
    if count == 0:
        return
    returns[c, p] += 1.0
    welford(returns[c], signature_mean[c], signature_m2[c], p, type_sum / count)
    welford(returns[c], spread_mean[c], spread_m2[c], p, largest / value_sum if value_sum > 0.0 else 0.0)


@njit(cache=True, inline="always")
def learn(al, views, m, p, n_parents, children, task_types, values):
    """The values of parent ``p``'s composite task come back: statistics, then algorithm 1 on the parent's row.

    Atomic task ``k``, of type ``task_types[k]``, gives ``values[k]`` to child ``children[k]``.
    """
    bounded = m > al.min_bounded_groups
    Y, F, H, cs, G, rows, slot = views[0], views[1], views[2], views[3], views[4], views[5], views[6]
    n_rows, k_since_rebase, counts, rebase_due, membership = views[7], views[8], views[9], views[10], views[12]
    for c in range(membership.shape[0]):
        observe(views[13], views[14], views[15], views[16], views[17], c, p, children, task_types, values)
    for k in range(task_types.shape[0]):
        c = children[k]
        mgrao.learn_value(Y, F, H, cs, G, rows, slot, n_rows, k_since_rebase, counts, rebase_due, views[11], c,
                          bounded, membership[c, p], task_types[k], values[k], al)


@njit(cache=True)
def finish(al, lane, m, weights):
    """Materialise lane ``lane``'s final PW and combined weights (after the last episode) into ``weights``.

    MG-RAO's final allocation, without a regrouping (no episode follows).
    """
    views = mgrao.lane_of(al, lane)
    for c in range(weights.shape[0]):  # the first children of MG-RAO's learners (one split for every resource)
        mgrao.allocate(al, views, m, c, weights[c])

"""MG-RAO's compiled steps: algorithm 1 (update) applied lazily and algorithm 2 (weighting).

What the kernel (:mod:`mgrao_core.engine.kernel`) calls for an MG-RAO lane: :func:`lane_of` (the
lane's views, once), :func:`allocate` (a child's allocation at the start of an episode),
:func:`learn` (the values of a composite task coming back) and :func:`finish` (the final state).
:class:`MgraoLanes` is the family's state as the kernel reads it, built by :func:`lanes_of` from
the arrays declared in :mod:`mgrao_core.algorithms.mgrao.family`.

Cost per returned value. Algorithm 1 adds ``alpha * atv * E`` to the whole ``PW`` matrix and
sum-normalises every row. Done densely that is O(m * n) per value. Here it is O(active rows): for
every row ``i`` we keep ``PW[i, j] = cs[i] * (Y[i, j] + F[i, j] * H[i])`` and ``E[i, j] = gamma**k *
F[i, j]``, where ``k`` counts the child's updates since the last *rebase*:

* the trace update touches one entry of ``F`` (replace with ``gamma**-k``; every other entry
  decays implicitly through ``gamma**k``), folding the change into ``Y`` so ``PW`` is unchanged;
* ``PW += a * E`` is ``H[i] += a * gamma**k / cs[i]`` for every row;
* each row sum becomes ``1 + a * gamma**k * G[i]`` with ``G[i] = sum_j F[i, j]``, so
  the row normalisation is ``cs[i] /= 1 + a * gamma**k * G[i]``.

A rebase materialises ``PW`` and ``E`` (O(active rows * n)) at the start of every episode, where
the combined weights need the whole matrix anyway, and whenever ``gamma**-k`` or ``1 / cs`` grow
large enough to cost precision (see :data:`TRACE_SCALE_LIMIT`).

Active rows. A row whose trace is still positive is renormalised by every returned value, and a
trace never returns to zero by itself, so with a group per parent every value would touch every
row. But a row's trace shrinks by ``gamma`` per update: once everything it can still add to the
row, over all later updates, is below half a unit in the last place of every weight it would add
to (:func:`trace_is_negligible`), the rebase drops it (the row keeps its weights) and the row
leaves the child's *active rows*, which are the only ones an update visits. A returned value from
its group makes it active again. ``H``, ``cs`` and ``G`` are stored by place among the active rows
(``H[s]`` belongs to row ``rows[s]``), so that the update runs over contiguous memory.

Children with at most :data:`~mgrao_core.algorithms.mgrao.family.MIN_BOUNDED_GROUPS` groups keep every row
active and perform exactly the operations above. A child with more keeps the reciprocal scale in
``cs`` (``PW = (Y + F * H) / cs``; ``H += a * gamma**k * cs``; ``cs *= 1 + a * gamma**k * G``):
multiplications instead of divisions, the same rounding up to the last bit. docs/model.md ("The
engine") gives the argument.
"""

from __future__ import annotations

import mgrao_core._numba_cache  # noqa: F401  (first: picks a writable numba cache before numba loads)

# isort: split
import math
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
from numba import njit

from mgrao_core.algorithms.mgrao import family
from mgrao_core.algorithms.state import System

_SCALE_LIMIT = 1e-150  # rebase before any cs[i] falls below this (a reciprocal scale rises above 1 / it)

TRACE_SCALE_LIMIT = 64.0
"""Largest ``gamma**-k`` between rebases. ``Y + F * H`` cancels terms of size up to about
``gamma**-k * k * alpha * atv`` times an entry of PW, so this bound keeps the lazy form within
about 1e-13 of the dense update (checked against :mod:`mgrao_core.reference`); with gamma = 0.9
it means a rebase every 39 updates, which costs O(rows * n / 39) per update, below the O(rows) of
the update itself for n_types up to 39."""

NEGLIGIBLE = 2.0**-55
"""A dropped trace may change a weight by at most this fraction of it (and the row's sum by this
fraction of 1): less than half a unit in the last place (a weight ``w`` has ``ulp(w) / 2 > w *
2**-54``), so adding it would not change the row in float64."""



class MgraoLanes(NamedTuple):
    """Every lane's MG-RAO state and the parameters, as the kernel reads them.

    One flat tuple: numba's parallel loop takes no tuple nested in an argument.

    Attributes:
        Y, F, H, cs, G, k_since_rebase: each child's lazy PW and trace (see the module docstring),
            ``(lanes, children, groups[, n_types])``.
        rows, slot, n_rows: each child's active rows (the first ``n_rows`` of ``rows``), a row's
            place among them (-1: inactive), ``(lanes, children[, groups])``.
        counts: ``(lanes, children, groups)`` parent agent sample counts.
        rebase_due: ``(lanes, children)`` whether a row's scale came so close to underflow that the
            child rebases before its next update.
        row_kl: ``(lanes, children, groups)`` each row's ``dkl`` (algorithm 2), kept while the row is inactive
            (its PW cannot change), NaN while it is active or since it left the active rows: a child's
            allocation computes ``dkl`` of its active rows and of the rows that left them only, so that a
            child with many groups and few active rows does not take a logarithm of every weight every
            episode (the same numbers, bit for bit).
        learning_rate: alpha.
        temperature: the softmax temperature of algorithm 2 in use.
        gamma_pow: ``trace_decay ** k`` for ``k = 0 .. rebase interval``.
        gamma_inv_pow: ``trace_decay ** -k``, likewise.
        trace_tail: ``alpha * gamma / (1 - gamma)``: the most a trace entry of 1 still adds to its
            weight over all later updates (see :func:`trace_is_negligible`).
        min_bounded_groups: :data:`~mgrao_core.algorithms.mgrao.family.MIN_BOUNDED_GROUPS`.
        use_counts: whether algorithm 2's blend counts the samples (``group_blend = dkl-and-count``).
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


def rebase_interval(trace_decay: float) -> int:
    """Updates between rebases so that ``trace_decay ** -k`` stays below :data:`TRACE_SCALE_LIMIT`."""
    return int(max(1, min(100_000, math.floor(math.log(TRACE_SCALE_LIMIT) / -math.log(trace_decay)))))


def trace_tail(learning_rate: float, trace_decay: float) -> float:
    """``alpha * gamma / (1 - gamma)``: what a trace entry of 1 adds to its weight over all later updates.

    At the ``u``-th update after it, the entry is ``gamma**u`` and adds ``alpha * atv * gamma**u``
    with ``atv <= 1`` (a composite quality times a proportional value, both at most 1).
    """
    return learning_rate * trace_decay / (1.0 - trace_decay)


def lanes_of(arrays: Mapping[str, np.ndarray], params: System) -> MgraoLanes:
    """The kernel's view of the chunk's MG-RAO arrays (by name, as declared) and of a validated parameter set."""
    gamma_pow = params.trace_decay ** np.arange(rebase_interval(params.trace_decay) + 1, dtype=float)
    state = [arrays[name] for name in MgraoLanes._fields[:12]]
    return MgraoLanes(*state, params.learning_rate, params.effective_temperature, gamma_pow, 1.0 / gamma_pow,
                      trace_tail(params.learning_rate, params.trace_decay), family.MIN_BOUNDED_GROUPS,
                      params.group_blend == "dkl-and-count")


@njit(cache=True, inline="always")
def trace_is_negligible(weights, trace, trace_sum, tail):
    """Whether a row's trace can no longer change the row in float64.

    Just after a rebase the trace is ``trace`` (summing to ``trace_sum``). Over all later updates
    it adds at most ``tail * trace[j]`` to ``weights[j]`` and ``tail * trace_sum`` to the row's
    sum; both must stay below :data:`NEGLIGIBLE` of what they are added to.
    """
    if not trace_sum * tail <= NEGLIGIBLE:
        return False
    for j in range(trace.shape[0]):
        if trace[j] > 0.0 and not trace[j] * tail <= NEGLIGIBLE * weights[j]:
            return False
    return True


@njit(cache=True)
def rebase(Y, F, H, cs, G, rows, slot, n_rows, gamma_k, tail, bounded, row_kl):
    """Materialise PW into Y and E into F for the active rows; reset H, cs and G.

    ``H``, ``cs`` and ``G`` of the active row ``rows[s]`` are at ``s``. With ``bounded`` (the
    child's scales are reciprocal; the row sum normalises them away), a row whose trace became
    negligible drops it (``F`` of the row becomes 0, so ``Y`` is its PW) and leaves the active
    rows, its ``row_kl`` to be computed again (NaN). Returns the number of active rows.
    """
    n = Y.shape[1]
    s = n_rows
    while s > 0:
        s -= 1
        i = rows[s]
        total = 0.0
        trace_sum = 0.0
        for j in range(n):  # two running sums side by side: each is a chain of dependent additions
            value = Y[i, j] + F[i, j] * H[s]
            if not bounded:
                value *= cs[s]
            Y[i, j] = value
            total += value
            F[i, j] *= gamma_k
            trace_sum += F[i, j]
        for j in range(n):
            Y[i, j] /= total
        H[s] = 0.0
        cs[s] = 1.0
        G[s] = trace_sum
        if bounded and trace_is_negligible(Y[i], F[i], trace_sum, tail):
            F[i, :] = 0.0
            row_kl[i] = math.nan
            n_rows -= 1
            rows[s] = rows[n_rows]  # rebased already (H 0, cs 1): only its trace sum moves
            G[s] = G[n_rows]
            slot[rows[s]] = s
            slot[i] = -1
    return n_rows


@njit(cache=True)
def combined_weights(PW, counts, m, n, temperature, out, row_kl, slot, use_counts=True):
    """Algorithm 2 on materialised rows: ``softmax(sumnorm(B) @ PW / temperature)`` into ``out``.

    The blending vector is ``B = sumnorm(dkl) + sumnorm(count)``, or ``sumnorm(dkl)`` without
    ``use_counts`` (``group_blend = dkl-only``). A row's ``dkl`` is computed where it is active (``slot[i] >= 0``)
    or not kept (``row_kl[i]`` NaN), else read from ``row_kl``; an inactive row keeps what it computed, an active
    one is left NaN. ``sumnorm(B) @ PW`` accumulates row by row, each type's sum taking the rows in the same order
    as a sum type by type would.
    """
    kl_total = 0.0
    count_total = 0.0
    for i in range(m):
        kl = row_kl[i]
        if slot[i] >= 0 or kl != kl:
            kl = 0.0
            for j in range(n):
                w = PW[i, j]
                if w > 0.0:
                    kl += w * math.log(w * n)
            if kl < 0.0:
                kl = 0.0
            row_kl[i] = kl  # an active row's only until the end of this call
        kl_total += kl
        count_total += counts[i]
    blend_total = 0.0
    for i in range(m):
        blend_total += _blend(row_kl[i], counts[i], m, kl_total, count_total, use_counts)
    for j in range(n):
        out[j] = 0.0
    for i in range(m):
        b = _blend(row_kl[i], counts[i], m, kl_total, count_total, use_counts) / blend_total  # sumnorm(B)
        for j in range(n):
            out[j] += b * PW[i, j]
        if slot[i] >= 0:
            row_kl[i] = math.nan
    top = -np.inf
    for j in range(n):
        out[j] /= temperature
        if out[j] > top:
            top = out[j]
    total = 0.0
    for j in range(n):
        out[j] = math.exp(out[j] - top)
        total += out[j]
    if not (total >= 1.0 and total < np.inf):  # a non-finite top (temperature far below the schema's
        for j in range(n):                       # bounds): fall back to uniform rather than NaN
            out[j] = 1.0
        total = float(n)
    for j in range(n):
        out[j] /= total


@njit(cache=True, inline="always")
def _blend(kl, count, m, kl_total, count_total, use_counts):
    """A row's blend, ``sumnorm(dkl)[i] + sumnorm(count)[i]``, before ``B`` is sum-normalised."""
    kl_part = kl / kl_total if kl_total > 0.0 else 1.0 / m
    if use_counts:
        return kl_part + (count / count_total if count_total > 0.0 else 1.0 / m)
    return kl_part


@njit(cache=True, inline="always")
def pw_update(Y, F, H, cs, G, rows, slot, n_rows, c, k, group, task_type, step, gamma_pow, gamma_inv_pow,
              bounded):
    """Algorithm 1 for one returned value, lazily, for child ``c`` (the first index of every array).

    The eligibility trace update at ``(group, task_type)`` (the row becomes active if it was not),
    then ``PW += step * E`` with every active row sum-normalised (``step = alpha * atv``); an
    inactive row has no trace, so the update would leave it as it is. ``H``, ``cs`` and ``G`` of
    the active row ``rows[c, s]`` are at ``[c, s]``; with ``bounded`` the scales are reciprocal.

    Returns True if a row's scale came so close to underflow that a rebase is due.
    """
    g = slot[c, group]
    if g < 0:
        g = n_rows[c]
        n_rows[c] += 1
        rows[c, g] = group
        slot[c, group] = g
        H[c, g] = 0.0
        cs[c, g] = 1.0
        G[c, g] = 0.0
    f_new = gamma_inv_pow[k]
    f_old = F[c, group, task_type]
    Y[c, group, task_type] += (f_old - f_new) * H[c, g]
    F[c, group, task_type] = f_new
    G[c, g] += f_new - f_old
    scale = step * gamma_pow[k]
    extreme = 0
    if bounded:  # reciprocal scales: multiplications only
        for s in range(n_rows[c]):
            H[c, s] += scale * cs[c, s]
            cs[c, s] *= 1.0 + scale * G[c, s]
            extreme += cs[c, s] > 1.0 / _SCALE_LIMIT
    else:
        for s in range(n_rows[c]):  # branch-free, so that it vectorises: a row without trace keeps H and cs
            H[c, s] += scale / cs[c, s] if G[c, s] > 0.0 else 0.0
            cs[c, s] /= 1.0 + scale * G[c, s]
            extreme += cs[c, s] < _SCALE_LIMIT
    return extreme > 0


@njit(cache=True)
def fix_allocation(Y, F, H, cs, G, rows, slot, n_rows, counts, m, bounded, gamma_k, tail, temperature, weights,
                   row_kl, use_counts=True):
    """A child fixes its resource weights for the episode: its PW is materialised, then algorithm 2 writes ``weights``.

    Returns the number of active rows.
    """
    n_rows = rebase(Y, F, H, cs, G, rows, slot, n_rows, gamma_k, tail, bounded, row_kl)
    combined_weights(Y, counts, m, Y.shape[1], temperature, weights, row_kl, slot, use_counts)
    return n_rows


@njit(cache=True, inline="always")
def allocate(ml, views, m, c, weights):
    """Child ``c`` of the lane whose :func:`lane_of` is ``views`` (``m`` parent groups per child) fixes its allocation.

    The updates since the rebase are now 0. The views are indexed by position (``views[8]`` is
    ``k_since_rebase``): numba's parallel loop keeps a write through a tuple's item alive only when
    it sees the item taken from the tuple.
    """
    k = views[8][c]
    views[7][c] = fix_allocation(views[0][c], views[1][c], views[2][c], views[3][c], views[4][c], views[5][c],
                                 views[6][c], views[7][c], views[9][c], m, m > ml.min_bounded_groups, ml.gamma_pow[k],
                                 ml.trace_tail, ml.temperature, weights, views[11][c], ml.use_counts)
    views[8][c] = 0
    views[10][c] = False


@njit(cache=True, inline="always")
def learn_value(Y, F, H, cs, G, rows, slot, n_rows, k_since_rebase, counts, rebase_due, row_kl, c, bounded, group,
                task_type, value, ml):
    """Child ``c`` receives an atomic task's absolute value from a parent of ``group``.

    The sample count, then algorithm 1 (rebasing first when due). The arrays are the lane's, first
    index the child (so that no per-child view is made for every task).
    """
    counts[c, group] += 1.0
    k = k_since_rebase[c]
    if rebase_due[c] or k == ml.gamma_pow.shape[0] - 1:
        n_rows[c] = rebase(Y[c], F[c], H[c], cs[c], G[c], rows[c], slot[c], n_rows[c], ml.gamma_pow[k], ml.trace_tail,
                           bounded, row_kl[c])
        k = 0
    k += 1
    k_since_rebase[c] = k
    rebase_due[c] = pw_update(Y, F, H, cs, G, rows, slot, n_rows, c, k, group, task_type, ml.learning_rate * value,
                              ml.gamma_pow, ml.gamma_inv_pow, bounded)


@njit(cache=True, inline="always")
def lane_of(ml, lane):
    """Lane ``lane``'s views of the arrays the steps write, made once per lane (as the kernel did before).

    A plain tuple, in this order: Y, F, H, cs, G, rows, slot, n_rows, k_since_rebase, counts,
    rebase_due, row_kl. The kernel unpacks it once per lane for :func:`learn`, around a loop that keeps
    using every view; :func:`allocate` takes its items by position, which numba's parallel loop sees
    as the tuple's (a write through a NamedTuple's field, or through an unpacked item nothing reads
    later, would be dropped as dead there; docs/algorithms.md).
    """
    return (ml.Y[lane], ml.F[lane], ml.H[lane], ml.cs[lane], ml.G[lane], ml.rows[lane], ml.slot[lane],
            ml.n_rows[lane], ml.k_since_rebase[lane], ml.counts[lane], ml.rebase_due[lane], ml.row_kl[lane])


@njit(cache=True, inline="always")
def learn(ml, Y, F, H, cs, G, rows, slot, n_rows, k_since_rebase, counts, rebase_due, row_kl, m, p, n_parents,
          children, task_types, values):
    """The values of parent ``p``'s composite task come back to the children that performed its atomic tasks.

    Atomic task ``k``, of type ``task_types[p, k]``, gives ``values[p, k]`` to child ``children[p, k]``,
    which learns it for the parent's group (of ``m``). ``Y`` to ``rebase_due`` are items 0-10 of the
    lane's :func:`lane_of`, which the kernel unpacks once per lane, and the task arrays come whole, the
    parent's row read here: unpacked here and sliced per composite (``children[p]``: a view, and a
    reference count, per composite) they made the paper's ``large`` system 12% slower
    (``benchmarks/bench_defaults.py``).
    """
    group = (p * m) // n_parents
    bounded = m > ml.min_bounded_groups
    for k in range(task_types.shape[1]):
        learn_value(Y, F, H, cs, G, rows, slot, n_rows, k_since_rebase, counts, rebase_due, row_kl, children[p, k],
                    bounded, group, task_types[p, k], values[p, k], ml)


@njit(cache=True)
def finish(ml, lane, m, weights):
    """Materialise lane ``lane``'s final PW and combined weights (after the last episode) into ``weights``."""
    views = lane_of(ml, lane)
    for c in range(ml.Y.shape[1]):
        allocate(ml, views, m, c, weights[c])


@njit(cache=True)
def finish_resources(ml, lane, m, weights):
    """:func:`finish` with several resources: learner ``c * R + r`` into ``weights[c, r]`` (``(children, R, n)``)."""
    views = lane_of(ml, lane)
    n_resources = weights.shape[1]
    for c in range(weights.shape[0]):
        for r in range(n_resources):
            allocate(ml, views, m, c * n_resources + r, weights[c, r])

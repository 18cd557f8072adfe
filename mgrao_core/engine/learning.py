"""MG-RAO's learning, compiled: algorithm 1 (update) applied lazily and algorithm 2 (weighting).

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
from typing import NamedTuple

import numpy as np
from numba import njit

from mgrao_core.params import SystemParams

_SCALE_LIMIT = 1e-150  # rebase before any cs[i] falls below this

TRACE_SCALE_LIMIT = 64.0
"""Largest ``gamma**-k`` between rebases. ``Y + F * H`` cancels terms of size up to about
``gamma**-k * k * alpha * atv`` times an entry of PW, so this bound keeps the lazy form within
about 1e-13 of the dense update (checked against :mod:`mgrao_core.reference`); with gamma = 0.9
it means a rebase every 39 updates, which costs O(m * n / 39) per update, below the O(m) of the
update itself for n_types up to 39."""


class Learning(NamedTuple):
    """MG-RAO's parameters as the kernel reads them.

    Attributes:
        learning_rate: alpha.
        temperature: the softmax temperature of algorithm 2 in use.
        gamma_pow: ``trace_decay ** k`` for ``k = 0 .. rebase interval``.
        gamma_inv_pow: ``trace_decay ** -k``, likewise.
    """

    learning_rate: float
    temperature: float
    gamma_pow: np.ndarray
    gamma_inv_pow: np.ndarray


def rebase_interval(trace_decay: float) -> int:
    """Updates between rebases so that ``trace_decay ** -k`` stays below :data:`TRACE_SCALE_LIMIT`."""
    return int(max(1, min(100_000, math.floor(math.log(TRACE_SCALE_LIMIT) / -math.log(trace_decay)))))


def learning_of(params: SystemParams) -> Learning:
    """The kernel's view of a validated parameter set."""
    gamma_pow = params.trace_decay ** np.arange(rebase_interval(params.trace_decay) + 1, dtype=float)
    return Learning(params.learning_rate, params.effective_temperature, gamma_pow, 1.0 / gamma_pow)


@njit(cache=True)
def rebase(Y, F, H, cs, G, m, n, gamma_k):
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
def combined_weights(PW, counts, m, n, temperature, out, scratch):
    """Algorithm 2 on materialised rows: ``softmax(sumnorm(B) @ PW / temperature)`` into ``out``.

    The blending vector is ``B = sumnorm(dkl) + sumnorm(count)``.
    """
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
    if not (total >= 1.0 and total < np.inf):  # a non-finite top (temperature far below the schema's
        for j in range(n):                       # bounds): fall back to uniform rather than NaN
            out[j] = 1.0
        total = float(n)
    for j in range(n):
        out[j] /= total


@njit(cache=True, inline="always")
def pw_update(Y, F, H, cs, G, m, k, group, task_type, step, gamma_pow, gamma_inv_pow):
    """Algorithm 1 for one returned value, lazily.

    The eligibility trace update at ``(group, task_type)``, then ``PW += step * E`` with every row
    sum-normalised (``step = alpha * atv``).

    Returns True if a row's scale came so close to underflow that a rebase is due.
    """
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

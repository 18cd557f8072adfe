"""The oracle's Monte-Carlo estimate of the expected proportional values, compiled.

:func:`mgrao_core.oracle.expected_type_values` draws ``value_noise * N`` for many samples of every
parent's composite task, takes ``exp`` of it (numpy's, between the two steps here) and sums each
sample's proportional values ``ctv = sumnorm(profile * exp(value_noise * N))``. The two steps below
draw the same numbers and perform the same floating-point operations in the same order as the
plain numpy expression they replace (``tests/core/test_oracle.py`` keeps it as the reference):

* :func:`draw_scaled_normals` draws from the seed's numpy ``Generator`` itself (numba implements
  numpy's ziggurat on the generator's own bit stream), so the stream advances exactly as
  ``rng.standard_normal(shape)`` would advance it;
* :func:`add_proportional_values` sums each composite task's noisy values in numpy's pairwise order
  (:func:`pairwise_sum`) and adds the samples one after the other, as numpy's reductions over the
  last and the first axis of a C-ordered array do.

Neither function reads a value of another file, so numba's cache of this file alone is sound.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from mgrao_core.engine.cache import load_without_compiler

_PAIRWISE_BLOCK = 128  # numpy's PW_BLOCKSIZE: longer runs are split in two


@njit(cache=True, nogil=True)
def draw_scaled_normals(rng, scale, out):
    """``scale * N(0, 1)`` into ``out`` (C order), drawn from ``rng`` as ``rng.standard_normal(out.shape)``."""
    flat = out.reshape(-1)
    for i in range(flat.shape[0]):
        flat[i] = scale * rng.standard_normal()


@njit(cache=True, inline="always")
def _block_sum(a, start, n):
    """The sum of at most 128 float64 as numpy adds them: 8 running sums of every 8th value, then the rest."""
    if n < 8:
        total = 0.0
        for i in range(start, start + n):
            total += a[i]
        return total
    r0, r1, r2, r3 = a[start], a[start + 1], a[start + 2], a[start + 3]
    r4, r5, r6, r7 = a[start + 4], a[start + 5], a[start + 6], a[start + 7]
    i = start + 8
    end = start + n - n % 8
    while i < end:
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
        i += 8
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < start + n:
        total += a[i]
        i += 1
    return total


@njit(cache=True)
def pairwise_sum(a, start, n):
    """``a[start:start + n].sum()`` in numpy's order for float64.

    numpy sums runs of at most 128 values with :func:`_block_sum` and splits a longer run in two
    (the first part a multiple of 8, about half), adding the two parts' sums. The split is
    evaluated here with an explicit stack: numba cannot cache a recursive function.
    """
    if n <= _PAIRWISE_BLOCK:
        return _block_sum(a, start, n)
    depth = 2
    while (_PAIRWISE_BLOCK << depth) < n:
        depth += 1
    pending = np.empty((2 * depth + 1, 2), dtype=np.int64)  # (start, n) to sum, or (-1, 0): add the top two sums
    sums = np.empty(depth + 1)
    pending[0, 0], pending[0, 1] = start, n
    n_pending, n_sums = 1, 0
    while n_pending:
        n_pending -= 1
        first, count = pending[n_pending, 0], pending[n_pending, 1]
        if first < 0:
            n_sums -= 1
            sums[n_sums - 1] += sums[n_sums]
        elif count <= _PAIRWISE_BLOCK:
            sums[n_sums] = _block_sum(a, first, count)
            n_sums += 1
        else:
            half = count // 2
            half -= half % 8
            pending[n_pending, 0], pending[n_pending, 1] = -1, 0
            pending[n_pending + 1, 0], pending[n_pending + 1, 1] = first + half, count - half
            pending[n_pending + 2, 0], pending[n_pending + 2, 1] = first, half
            n_pending += 3
    return sums[0]


@njit(cache=True, nogil=True)
def add_proportional_values(profiles, factors, first, sums, scratch):
    """Add every sample's proportional values to ``sums``, sample after sample.

    Args:
        profiles: ``(parents, types_per_composite)`` each parent's value profile.
        factors: ``(samples, parents, types_per_composite)`` the noise factors ``exp(value_noise * N)``.
        first: ``sums`` starts with the first sample's values (its earlier content is ignored).
        sums: ``(parents, types_per_composite)``, updated in place.
        scratch: ``(types_per_composite,)`` room for one composite task's noisy values.
    """
    n_parents, per_composite = profiles.shape
    for s in range(factors.shape[0]):
        for p in range(n_parents):
            for k in range(per_composite):
                scratch[k] = profiles[p, k] * factors[s, p, k]
            total = pairwise_sum(scratch, 0, per_composite)
            if first and s == 0:
                for k in range(per_composite):
                    sums[p, k] = scratch[k] / total
            else:
                for k in range(per_composite):
                    sums[p, k] += scratch[k] / total


load_without_compiler([draw_scaled_normals, add_proportional_values])

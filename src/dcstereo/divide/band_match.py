"""Whole-band block match of a band's left pixels: each one's least cost and uniqueness.

The block match that section 2's search (:mod:`.divide_bands`) and the ground control
points (:mod:`.gcp`) read, and ``block``'s winner-take-all, on a band of ``BAND_ROWS``
rows: ``band_block_match`` gives, per left pixel, ``features.block_match``'s least-cost
index and uniqueness ratio, bit for bit, on the band's cost array or on columns made one at
a time; ``_column_wta`` the least cost and its index of one column (``block``).
"""

import numba as nb
import numpy as np

from dcstereo._vector.costs import _keyed_column, _moved_costs_keyed
from dcstereo._vector.simd import BAND_ROWS
from dcstereo.costs.band import _cost_column, _key_shift, _movable, _moved_offsets
from dcstereo.divide.gcp import _gcp_best, _gcp_diagonals


@nb.njit(cache=True, inline="always")
def _first_reaching(pre, ndisp, r, best):
    """Return the first block ``b = k + 1`` (``1..ndisp``) where lane ``r``'s ``pre`` is ``best``.

    ``pre`` holds prefix minima along ``k`` (they do not increase) and ``best`` is lane
    ``r``'s least, ``pre[ndisp]`` (the last block is inf): a binary search without branches,
    the answer in ``b .. b + n - 1``.
    """
    b = 1
    n = ndisp
    while n > 1:
        half = n // 2
        b += half * (pre[(b + half - 1) * BAND_ROWS + r] > best)
        n -= half
    return b


@nb.njit(cache=True, inline="always")
def _key_blocks(ndisp, blocks):
    """Fill ``blocks[i]`` with block ``k + 1`` of flat cell ``i``; return the keys' scale.

    The keyed minima take ``cost * scale + (k + 1)`` (``_column_wta``): ``scale`` is
    the least power of two above the ``ndisp + 2`` blocks, so the keys are exact and
    ordered as ``(cost, k)``. The blocks are a load in the key loops, which costs less
    than the index arithmetic.
    """
    unr = np.uint64(BAND_ROWS)
    for i in range(np.uint64(blocks.shape[0])):
        blocks[i] = np.float64(i // unr)
    return _key_scale(ndisp + 2)


@nb.njit(cache=True, inline="always")
def _key_scale(nblocks):
    """Return the least power of two above ``nblocks``: the keys' scale (``_key_blocks``)."""
    return float(1 << _key_shift(nblocks))


@nb.njit(cache=True)
def band_block_match(
    cost, width, ndisp, x_int_lo, x_int_hi, pre, suf, wta_k, wta_ratio, make_costs=None,
    wanted=None, done=None, fused=None, diagonals=None,
):  # fmt: skip
    """Whole-band block match of every left pixel of the ``R`` rows of a band.

    ``wta_k[x * R + r]`` is the least-cost index ``k`` of column ``x`` of band row ``r``
    (ties: the smallest; -1 when the whole band is inf) and ``wta_ratio[x * R + r]`` its
    uniqueness ratio (0 where the band is empty): the values of ``features.block_match``,
    bit for bit (only comparisons and the same one division).

    In columns ``x_int_lo <= x < x_int_hi``, whose costs must all be integers below
    ``2**31`` or inf (``band_lane_costs``: all but the columns of the truncated windows),
    the minima are taken over keys ``cost * M + (k + 1)``, ``M`` a power of two above the
    cell count: exact, and ordered as ``(cost, k)``, so the least key carries the first
    index of the least cost (``_keyed_column``, the 8 lanes as one vector).

    Elsewhere, one flat pass over the cells (a vector loop, the lanes independent): the
    prefix minima ``pre`` and the suffix minima ``suf`` along ``k`` (float64 scratch,
    ``(ndisp + 2) * R``; the inf padding cells are the empty prefix and suffix). The least
    cost is the last prefix minimum, its first index a binary search of the prefix minima
    (they do not increase), and the second cost, over ``|k - best| > 1``, the least of the
    prefix minimum two cells below the match and the suffix minimum two cells above.

    ``make_costs`` None: ``cost`` is the band's array (``band_lane_costs``). Otherwise it
    is a ``records.CostPass`` (``band_lane_costs``' arguments of the same names), ``cost``
    is scratch of one column (``nk``), and each
    column's costs are made into it (``_cost_column``) and matched while they are in the
    cache: ``dc`` without the band's cost array, which on wide images and disparity ranges
    leaves the caches (the same values). The band's vertical sums are left in ``vs``, so
    that the DP pass after it makes the costs again from them (``SUMS_READY``). (As in
    ``band_forward``, None and a record compile to two functions.)

    ``wanted`` None: every column. Otherwise ``(counts, guard)`` (``band_strong_counts``):
    only the columns within ``guard`` of a column with a strong pixel are matched, the
    only ones the feature tests read (``band_feature_mask``: a candidate's own column and
    its guard columns); the others get -1 and 0, as an empty column (their costs are
    still made).

    ``done`` None: every column. Otherwise (uint8, ``width``) the columns with ``done[x]``
    are left as they are: ``band_lane_costs`` matched them as it made them.

    ``fused`` (with ``make_costs`` only) None: each column is made, then matched.
    Otherwise ``(x_lo, x_hi, shift)``: the columns ``x_lo <= x < x_hi`` that
    ``_moved_costs`` makes are made and matched at once by ``_moved_costs_keyed``, as
    ``band_lane_costs``' ``match`` does for the band's array (the caller checks
    ``_keys_fit``); they are matched whether ``wanted`` or not (the same values: the
    feature tests read only the wanted columns).

    ``diagonals`` (with ``make_costs`` only) None: nothing more. Otherwise ``(least, second,
    best)`` (``_gcp_scratch``) for ``dsi3-gcp`` without the band's cost array: each column
    made is folded into ``least`` and ``second`` (``_gcp_diagonals``; first set to inf
    here) and each matched column's least cost goes to ``best`` (``_gcp_best``; the
    columns left out by ``wanted`` keep what they held), what ``band_row_gcps`` reads.
    """
    nr = BAND_ROWS
    if diagonals is not None:
        for i in range(width * nr):
            diagonals[0][i] = np.inf
            diagonals[1][i] = np.inf
    unr = np.uint64(nr)
    nblocks = ndisp + 2  # cells k = -1 .. ndisp, the two padding ones included
    unk = np.uint64(nblocks * nr)
    top = unk - unr
    inf = np.inf
    scale = _key_scale(nblocks)
    numbers = np.arange(nblocks).astype(np.float64)  # _keyed_column's j
    for x in range(width):
        if done is not None:
            if done[x]:
                continue
        if make_costs is None:
            o = np.uint64(x) * unk
        else:
            o = np.uint64(0)
            left_t, right_t, dmin, radius, spread, vs, incremental, hsum = make_costs
            if fused is not None:
                # as band_lane_costs' match, written out again: one inline helper for both
                # made dc 1.04-1.09x slower in SEARCH and 1.06x in SEARCH_TWICE (A/B in one
                # process), as a helper shared with _moved_column had before
                x_lo, x_hi, shift = fused
                add = x + radius
                sub = x - radius - 1
                if x_lo <= x < x_hi and _movable(add, sub, width, dmin, ndisp, incremental):
                    # made and matched at once
                    width_p = width + 2 * radius
                    nkc = np.uint64(ndisp * nr)
                    o_left, o_right, o_add = _moved_offsets(add, dmin, radius, width_p, nkc)
                    _moved_costs_keyed(
                        left_t, right_t, vs, hsum, cost, o_left, o_right, o_add,
                        np.uint64(sub) * nkc, unr, nkc, width_p, shift, wta_k, wta_ratio,
                        np.uint64(x) * unr,
                    )  # fmt: skip
                    if diagonals is not None:
                        least, second, best = diagonals
                        _gcp_diagonals(cost, o, x, dmin, ndisp, width, least, second)
                        _gcp_best(cost, o, x, wta_k, best)
                    continue
            _cost_column(
                left_t, right_t, x, width, dmin, ndisp, radius, spread, vs, incremental, hsum,
                cost, o,
            )  # fmt: skip
            if diagonals is not None:
                least, second, best = diagonals
                _gcp_diagonals(cost, o, x, dmin, ndisp, width, least, second)
        if wanted is not None:
            counts, guard = wanted
            if counts[min(x + guard + 1, width)] == counts[max(x - guard, 0)]:
                for i in range(np.uint64(x) * unr, np.uint64(x + 1) * unr):
                    wta_k[i] = -1
                    wta_ratio[i] = 0.0
                continue
        if x_int_lo <= x < x_int_hi:
            _keyed_column(cost, o, nblocks, scale, numbers, wta_k, wta_ratio, np.uint64(x) * unr)
            if diagonals is not None:
                _gcp_best(cost, o, x, wta_k, diagonals[2])
            continue
        for i in range(unr):
            pre[i] = cost[o + i]  # the padding cells: inf
            suf[top + i] = cost[o + top + i]
        # one loop, two independent chains: the prefix minima up from the bottom, the
        # suffix minima down from the top
        for i in range(top):
            p = unr + i
            q = top - np.uint64(1) - i
            pre[p] = min(pre[p - unr], cost[o + p])
            suf[q] = min(suf[q + unr], cost[o + q])
        for r in range(nr):
            i = x * nr + r
            best = pre[(nblocks - 1) * nr + r]
            if not best < inf:
                wta_k[i] = -1
                wta_ratio[i] = 0.0
                continue
            b = _first_reaching(pre, ndisp, r, best)
            wta_k[i] = b - 1
            second = min(pre[max(b - 2, 0) * nr + r], suf[min(b + 2, nblocks - 1) * nr + r])
            if best > 0:
                wta_ratio[i] = second / best
            else:
                wta_ratio[i] = inf if second > 0 else 1.0
        if diagonals is not None:
            _gcp_best(cost, o, x, wta_k, diagonals[2])


@nb.njit(cache=True, inline="always")
def _column_wta(cost, ndisp, keyed, scale, blocks, pre, low, first):
    """Find the least cost of each lane of one cost column and its first ``k`` (-1: all inf).

    ``cost`` is a column of ``_cost_column`` (``nk`` cells, the inf padding included);
    ``low[r]``/``first[r]`` get lane ``r``'s least cost and the first ``k`` that has it
    (``rows.match_block_rows``' strict ``<``). As in ``band_block_match``: the prefix
    minima along ``k`` in ``pre`` (one vector chain), over the keys ``cost * scale + (k +
    1)`` in the columns whose costs are all integers or inf (``keyed``; ``blocks[i]`` is
    ``k + 1`` of flat cell ``i``, ``scale`` a power of two above ``ndisp + 2``), where the
    least key carries the first index, and elsewhere over the costs, the first index then
    found by a binary search.
    """
    nr = BAND_ROWS
    unr = np.uint64(nr)
    nblocks = ndisp + 2
    top = np.uint64(nblocks * nr) - unr
    for i in range(unr):
        pre[i] = cost[i]  # the padding cells: inf (and inf is their key)
    if keyed:
        for i in range(top):
            p = unr + i
            pre[p] = min(pre[p - unr], cost[p] * scale + blocks[p])
    else:
        for i in range(top):
            p = unr + i
            pre[p] = min(pre[p - unr], cost[p])
    for r in range(nr):
        best = pre[(nblocks - 1) * nr + r]
        if not best < np.inf:
            low[r] = np.inf
            first[r] = -1
            continue
        if keyed:
            key = best
            best = np.floor(key * (1.0 / scale))
            b = int(key - best * scale)
        else:
            b = _first_reaching(pre, ndisp, r, best)
        low[r] = best
        first[r] = b - 1

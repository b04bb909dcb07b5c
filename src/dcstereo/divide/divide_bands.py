"""Section 2 on a band of ``BAND_ROWS`` scanlines: ``dc``'s feature pairs from the band's costs.

The search of :mod:`.divide` (``divide_row``) with its up-front tests, the settings of
``dc`` by default (the uniqueness test on, no limit on the tries), on the costs, block
match and window variances of a band: ``band_feature_mask`` runs the cheap tests of every
pixel of the band at once (variance floor, uniqueness, range, edge guard), and
``band_row_features`` tests VS and SER (eq. 2, 3) on the survivors of one row and runs
the interval search; its pairs then pin the band DP (:mod:`.band_dp`). The pairs are those
of ``divide_row``, bit for bit.
"""

import numba as nb
import numpy as np

from dcstereo._vector.simd import BAND_ROWS, SSD_SHORT, SSD_WIDE, _window_ssd
from dcstereo.divide.features import (
    _sparse_best,
    _sparse_build,
    _window_variance,
    variance_similarity,
)


@nb.njit(cache=True, inline="always")
def _narrow_sums(span, magnitude, radius):
    """Whether ``_window_ssd``'s sums fit 32-bit lanes (``band_row_features``' ``short_ssd``).

    ``span`` bounds the absolute difference of two signal values, ``magnitude`` a value's
    absolute value (int64, at least 0). The SSD is at most ``win**2 * span**2``, the right
    window's sum of squares ``win**2 * magnitude**2`` (and its sum no more in magnitude):
    both below 2**31, and no partial sum past its total's bound (the terms of the two
    sums of squares are never negative), so the 32-bit lanes hold every sum exactly. On an
    8-bit image's signal (0..4080) windows up to 11 pixels a side fit (the 32-bit form,
    ``SSD_SHORT``, takes windows of at most ``R`` pixels a side).
    """
    win = 2 * radius + 1
    limit = np.int64(46340)  # 46340**2 < 2**31: the products below cannot overflow int64
    if not (0 <= span <= limit and 0 <= magnitude <= limit and win <= limit):
        return False
    top = np.int64(1) << 31
    return win * win * span * span < top and win * win * magnitude * magnitude < top


@nb.njit(cache=True, inline="always")
def _guard_columns(edge_guard):
    """Return how far a candidate's guard columns lie (0: the cell itself, implied tests).

    One rule for ``band_feature_mask``, which reads the guard columns, and for the block
    match's ``wanted`` columns, which must include every column it reads.
    """
    return max(edge_guard, 0)


@nb.njit(cache=True)
def band_strong_counts(var_l, width, var_floor, counts):
    """Count the strong columns of a band: ``counts[x]`` of the columns before ``x``.

    A column is strong where the window variance of some lane reaches the variance floor
    (``var_l[x * R + r] >= var_floor``, as in ``band_feature_mask``; idle lanes count
    too). ``counts`` (int64, ``width + 1``) tells ``band_block_match`` which columns the
    feature tests read.
    """
    nr = BAND_ROWS
    counts[0] = 0
    for x in range(width):
        strong = False
        for r in range(nr):
            strong |= var_l[x * nr + r] >= var_floor
        counts[x + 1] = counts[x] + strong


@nb.njit(cache=True, inline="always")
def _mask_cell(var_l, wta_k, wta_ratio, i, x, i_a, i_b, dmin, radius, width, var_floor, uniq):
    """Return the cheap tests of cell ``i`` (left pixel ``x``; guard cells ``i_a``, ``i_b``)."""
    k = wta_k[i]
    j = x - dmin - k
    k_a = wta_k[i_a]
    k_b = wta_k[i_b]
    return (
        (var_l[i] >= var_floor)
        & (k >= 0)
        & (wta_ratio[i] >= uniq)
        & (j >= radius)
        & (j <= width - 1 - radius)
        & (k_a >= 0)
        & (abs(k_a - k) <= 1)
        & (wta_ratio[i_a] >= uniq)
        & (k_b >= 0)
        & (abs(k_b - k) <= 1)
        & (wta_ratio[i_b] >= uniq)
    )


@nb.njit(cache=True)
def band_feature_mask(var_l, wta_k, wta_ratio, width, dmin, radius, tests, keep):
    """Mark the pixels of a band that pass the cheap up-front tests of ``divide_row``.

    ``keep[x * R + r]`` (uint8) gets 1 where left pixel ``x`` of band row ``r`` passes the
    variance floor, the uniqueness test, the range test (its match ``j`` at least
    ``radius`` inside the image) and the edge guard (``tests``, a ``records.FeatureTests``;
    see ``band_row_features``); 0 elsewhere (the ``radius`` columns at each end included).
    The same comparisons on the same values, without branches: the columns whose guard
    columns lie inside the image are one flat vector loop (the guard cells at fixed
    offsets), the few others clamp them as ``divide_row`` does. VS and SER are left to
    the row search (VS needs the right view's variance at the match: a gather, which
    keeps the loop from being vectorized).
    """
    var_floor, uniq, edge_guard = tests.var_floor, tests.uniqueness, tests.edge_guard
    nr = BAND_ROWS
    for i in range(np.uint64(width * nr)):
        keep[i] = 0
    if width <= 2 * radius:
        return
    guard = _guard_columns(edge_guard)
    x_lo = min(max(radius, guard), width - radius)  # the vector loop's columns
    x_hi = max(min(width - radius, width - guard), x_lo)
    g = np.uint64(guard * nr)
    for i in range(np.uint64(x_lo * nr), np.uint64(x_hi * nr)):
        x = np.int64(i // np.uint64(nr))
        keep[i] = _mask_cell(
            var_l, wta_k, wta_ratio, i, x, i - g, i + g, dmin, radius, width, var_floor, uniq
        )
    for lo, hi in ((radius, x_lo), (x_hi, width - radius)):  # the border columns
        for x in range(lo, hi):
            i_a = max(x - guard, 0) * nr
            i_b = min(x + guard, width - 1) * nr
            for r in range(nr):
                keep[x * nr + r] = _mask_cell(
                    var_l, wta_k, wta_ratio, x * nr + r, x, i_a + r, i_b + r, dmin, radius, width,
                    var_floor, uniq,
                )  # fmt: skip


@nb.njit(cache=True, inline="always")
def _worth_splitting(a, c, b, e, i_lo, i_hi):
    """1 if interval ``(a, c) <-> (b, e)`` has pixels inside and candidates ``i_lo..i_hi``."""
    return int(c - a > 1) & int(e - b > 1) & int(i_lo <= i_hi)


@nb.njit(cache=True, inline="always")
def _candidate_sums(left_p, right_p, y, r, dmin, radius, cand_x, wta_k, m, ssd, sm, sq, form):
    """``_window_ssd`` of candidates ``cand_x[:m]`` of band row ``r`` with their matches.

    To ``ssd[:m]``, ``sm[:m]`` and ``sq[:m]``, in ``form`` (a constant at each call: one
    form compiled in each loop).
    """
    for q in range(m):
        p = cand_x[q]
        j = p - dmin - wta_k[p * BAND_ROWS + r]
        ssd[q], sm[q], sq[q] = _window_ssd(left_p, right_p, y, p, j, radius, form)


@nb.njit(cache=True)
def band_row_features(cost, width, dsi, r, y, left_p, right_p, matches, tests, short_ssd, work,
                      anchors, pairs_row):  # fmt: skip
    """Find the reliable feature pairs of band row ``r`` (image row ``y``), as ``divide_row``.

    ``cost`` is the band's (``band_lane_costs``), ``dsi`` its ``records.Dsi``; ``matches``
    (``records.BandMatches``) its window variances in the left view (``var``,
    ``band_lane_variance``), block match (``wta_k``, ``band_block_match``) and the cheap
    tests' outcome (``keep``); ``left_p``/``right_p`` the padded signals. The right view's
    variances are made at the matches from the sums of the SSD's loads (``_window_ssd``, in
    the form ``SSD_SHORT`` where ``short_ssd``; ``_window_variance``: the same values).
    ``tests``: a ``records.FeatureTests`` (``uniqueness > 0``; no limit on the tries). The
    up-front tests of ``divide_row`` pick the candidates: ``keep`` (``band_feature_mask``) holds
    the outcome of the variance floor, uniqueness, range and guard tests, and VS and SER
    are tested here, on the survivors. The search takes the strongest candidate of each
    interval that lies in its ordering range and passes the left-right test, and splits
    the interval at it; a row whose candidates' matches already increase with ``x``
    (with the left-right check off) accepts them all without it, which relies on the
    mask's range test (every match at least ``radius`` inside the image). Pair
    ``x <-> j`` is written to ``anchors.pins[x * R + r]`` (which must hold -1), and
    ``anchors.pinned[x]`` set (the band's columns with a pin; ``band_forward``). Returns the
    number of pairs ``n``, whose ``(x, j, SER, VS)`` are ``pairs_row[:n]`` in increasing
    ``x`` (float32, ``(width, 4)``; rows from ``n`` on may be overwritten). No fill: the
    pinned band DP does it. Scratch: ``work`` (``records.SearchScratch``).
    """
    dmin, ndisp, radius = dsi
    var_l, wta_k, keep = matches.var, matches.wta_k, matches.keep
    iwork, fwork, stack = work
    pins, pinned = anchors.pins, anchors.pinned
    ser_min, vs_max, vs_relative = tests.ser_min, tests.vs_max, tests.vs_relative
    lr_check, steps = tests.lr_check, tests.signal_steps
    nr = BAND_ROWS
    nk = (ndisp + 2) * nr
    cand_x = iwork[0]
    held = iwork[1]
    cand_k = iwork[2]
    lr_j = iwork[3]
    lr_below = iwork[4]
    lr_above = iwork[5]
    cand_ser = fwork[0]
    cand_vs = fwork[1]
    cand_var = fwork[2]
    cand_live = fwork[3]
    sparse = iwork[6:]
    # the survivors of the cheap tests (band_feature_mask), in order, without branches
    m = 0
    for p in range(radius, width - radius):
        cand_x[m] = p
        m += keep[p * nr + r]
    # SER's scaled SSD: with steps**2 a power of two, total / (ssd / scale) is
    # (total * scale) / ssd exactly (both scalings are exact), one division fewer
    scale = float(steps * steps)
    exact_scale = (steps * steps) & (steps * steps - 1) == 0
    # whether the candidates that pass VS and SER are in order: their right pixels
    # strictly increasing with x (the mask's range test put each inside the windows), and
    # no left-right check, which can hold a candidate back
    ordered = not lr_check
    j_last = -1
    n = 0
    n_win = (2 * radius + 1) ** 2
    norm = float(n_win) * float(n_win) * float(steps) * float(steps)
    # the SSD and the right window's sums of every candidate, in a pass of their own (many
    # candidates' loads in flight) and in the form the window and the signals allow (sums
    # to cand_live, lr_below and lr_above, scratch until the search)
    if short_ssd:
        _candidate_sums(left_p, right_p, y, r, dmin, radius, cand_x, wta_k, m, cand_live,
                        lr_below, lr_above, SSD_SHORT)  # fmt: skip
    else:
        _candidate_sums(left_p, right_p, y, r, dmin, radius, cand_x, wta_k, m, cand_live,
                        lr_below, lr_above, SSD_WIDE)  # fmt: skip
    # VS and SER of every candidate, without branches (whether each passes to held) ...
    for q in range(m):
        v_l = var_l[cand_x[q] * nr + r]
        v_r = _window_variance(lr_below[q], lr_above[q], n_win, norm)
        vs = variance_similarity(v_l, v_r, vs_relative)
        total = v_l + v_r
        ssd = cand_live[q]
        if exact_scale:
            ser = (total * scale) / ssd if ssd > 0 else np.inf
        else:
            ser = total / (ssd / scale) if ssd > 0 else np.inf
        cand_ser[q] = ser
        cand_vs[q] = vs
        cand_var[q] = v_l
        held[q] = (vs <= vs_max) & (ser >= ser_min)
    # ... and those that pass, moved to the front in order (each writes the next entry, and
    # only one that passes keeps it)
    for q in range(m):
        p = cand_x[q]
        best_k = wta_k[p * nr + r]
        j = p - dmin - best_k
        passed = held[q] != 0
        cand_x[n] = p
        cand_k[n] = best_k
        cand_ser[n] = cand_ser[q]
        cand_vs[n] = cand_vs[q]
        cand_var[n] = cand_var[q]
        ordered &= (j > j_last) | (not passed)
        j_last = j if passed else j_last
        n += passed
    if ordered:
        # then the search accepts every candidate, and none is tried twice: each is the
        # strongest of the interval between the stronger pairs around it, whose right
        # pixels bound its own on both sides. So the pins are set here and the work list
        # starts empty (no sparse table: most rows of the Middlebury scenes with the
        # default tests, where a row rejects 0.1 on average)
        for i in range(n):
            p = cand_x[i]
            pins[p * nr + r] = p - dmin - cand_k[i]
            pinned[p] = True
    else:
        for i in range(n):
            cand_live[i] = cand_var[i]
            lr_j[i] = -1
        _sparse_build(cand_var, n, sparse)
    # the work list holds only intervals with room and candidates: each push writes the
    # next entry and keeps it only then (no branch; an empty interval was a push, a pop
    # and a mispredicted test)
    stack[0, 0] = -1
    stack[0, 1] = width
    stack[0, 2] = -1
    stack[0, 3] = width
    stack[0, 4] = 0
    stack[0, 5] = n - 1
    top = _worth_splitting(-1, width, -1, width, 0, n - 1) & int(not ordered)
    while top > 0:
        top -= 1
        a = stack[top, 0]
        c = stack[top, 1]
        b = stack[top, 2]
        e = stack[top, 3]
        i_lo = stack[top, 4]
        i_hi = stack[top, 5]
        nheld = 0
        while True:
            i = _sparse_best(cand_var, sparse, i_lo, i_hi)
            if not cand_live[i] > -np.inf:
                i = -1
                strongest = -np.inf
                for q in range(i_lo, i_hi + 1):
                    if cand_live[q] > strongest:
                        strongest = cand_live[q]
                        i = q
            if i < 0:
                break
            p = cand_x[i]
            cand_live[i] = -np.inf
            k_lo = max(0, p - min(e - 1, width - 1 - radius) - dmin)
            k_hi = min(ndisp - 1, p - max(b + 1, radius) - dmin)
            best_k = cand_k[i]
            if not k_lo <= best_k <= k_hi:
                continue  # the sub-problems' ranges nest: retired
            j = p - dmin - best_k
            if lr_check:
                best = cost[p * nk + (best_k + 1) * nr + r]
                if lr_j[i] != j:
                    # the other left pixels x of the interval whose cost with j is at most
                    # best: the nearest on each side of p, or the interval's ends, a and c
                    # (selects: the loads do not wait on branches). Only hits inside (a, c)
                    # decide, here and in every later try of this candidate: it is tried
                    # again only in the sub-intervals of this one.
                    lr_j[i] = j
                    below = a
                    above = c
                    k0 = max(0, -(j + dmin), a + 1 - j - dmin)
                    k1 = min(ndisp, width - j - dmin, c - j - dmin)
                    o = np.uint64((j + dmin + k0) * nk + (k0 + 1) * nr + r)
                    for k in range(k0, k1):
                        x = j + dmin + k
                        hit = cost[o] <= best
                        below = x if hit & (x < p) else below
                        above = min(above, x) if hit & (x > p) else above
                        o += np.uint64(nk + nr)
                    lr_below[i] = below
                    lr_above[i] = above
                if lr_below[i] > a or lr_above[i] < c:
                    held[nheld] = i  # a narrower interval may let it pass
                    nheld += 1
                    continue
            pins[p * nr + r] = j
            pinned[p] = True
            stack[top, 0] = a
            stack[top, 1] = p
            stack[top, 2] = b
            stack[top, 3] = j
            stack[top, 4] = i_lo
            stack[top, 5] = i - 1
            top += _worth_splitting(a, p, b, j, i_lo, i - 1)
            stack[top, 0] = p
            stack[top, 1] = c
            stack[top, 2] = j
            stack[top, 3] = e
            stack[top, 4] = i + 1
            stack[top, 5] = i_hi
            top += _worth_splitting(p, c, j, e, i + 1, i_hi)
            break
        for h in range(nheld):
            cand_live[held[h]] = cand_var[held[h]]
    # the accepted candidates, in increasing x (as cand_x), without branches: each writes
    # the next row, and only an accepted one keeps it
    found = 0
    for i in range(n):
        p = cand_x[i]
        j = pins[p * nr + r]
        pairs_row[found, 0] = p
        pairs_row[found, 1] = j
        pairs_row[found, 2] = cand_ser[i]
        pairs_row[found, 3] = cand_vs[i]
        found += j >= 0
    return found

"""Section 2 of the paper: divide-and-conquer global matching, one scanline at a time.

The home of the paper's section 2 (``../shared/paper/NOTES.md``): the problem of a
scanline is to match a left interval ``(A, C)`` with a right interval ``(B, D)`` whose
ends are matched already (the first problem is the whole scanline). The candidate of
highest window variance inside ``(A, C)`` is block-matched inside ``(B, D)`` (the
ordering constraint) and the disparity range; a reliable pair (SER and VS, eq. 2 and 3,
and this project's optional uniqueness, left-right and edge tests) splits the problem in
two, solved the same way; an interval without a reliable pair is filled by the DP of
section 3 (:mod:`.dp`) forced through its ends, or by linear interpolation
(``dc-linear``). ``divide_row`` runs it on one scanline, ``match_dc_rows`` on every row.

The measures the search takes (variance, SSD, SER, VS, the uniqueness ratio, the block
match) are :mod:`.features`. For the default settings (the uniqueness test on, no limit
on the tries) ``dc`` runs the same search on bands of ``BAND_ROWS`` rows
(:mod:`.divide_bands`), whose pairs then pin the band DP (:mod:`.band_dp`): the same pairs
and maps, bit for bit. The row form here runs the other settings (``max_candidates``,
``uniqueness=0``, ``dc-linear``) and images too wide for the band's cost array.
"""

import numba as nb
import numpy as np

from dcstereo._records import DivideScratch, RowOutputs
from dcstereo.costs.window import _row_costs_any
from dcstereo.divide.features import (
    NOT_MATCHED,
    _argmin_row,
    _edge_guarded,
    _pair_reliability,
    _sparse_best,
    _sparse_build,
    _tree_best,
    _tree_pull,
    _tree_set,
    block_match,
    variance_similarity,
    window_variance_row,
)
from dcstereo.result import FLAG_BORDER
from dcstereo.scanline.dp import apply_path, path_scratch, scanline_dp
from dcstereo.scanline.rows import chunk_bounds


@nb.njit(cache=True)
def divide_row(cost, left_p, right_p, y, dsi, step_costs, tests, var_l, var_r, wta_k, wta_ratio,
               work, row):  # fmt: skip
    """Section 2 on one scanline: pin reliable feature pairs, fill between them.

    ``cost``: the row's window costs (``costs.row_costs``); ``left_p``/``right_p``: the
    padded signals, row ``y``; ``dsi`` (``records.Dsi``): the disparities and the window;
    ``step_costs`` (``records.StepCosts``): the fill's DP; ``tests``
    (``records.FeatureTests``): the tests below (``ser_min``, ``vs_max``, ...); ``work``:
    the row's scratch (``divide_scratch``); ``row`` (``records.RowOutputs``): the row's
    outputs.

    A work list (``work.stack``, shape (>= width + 2, 6)) of problems ``(A, C, B, D)``: match
    left pixels strictly inside ``(A, C)`` with right pixels strictly inside ``(B, D)``.
    The candidate of highest left window variance (``var_l``, of row ``y``; ``var_r``
    is that of the right view) is
    block-matched inside the band and the right interval (the ordering constraint);
    accepted when ``SER >= ser_min`` and ``VS <= vs_max`` (eq. 2 and 3, see
    ``reliability``), it splits the problem in two; otherwise the next strongest candidate
    is tried, down to ``var_floor`` and at most ``max_candidates`` (0: no limit). Only
    pixels whose whole window lies inside the image, in both views, are candidates.

    Beyond the paper, a candidate must also pass

    * the left-right check (``lr_check``): its right pixel, block-matched back inside
      ``(A, C)``, chooses it again;
    * the uniqueness test (``uniqueness > 0``): the whole-band block match lies inside
      the interval's range (so it is the match) with a ``uniqueness_ratio`` of at least
      ``uniqueness``. The ranges of the sub-problems nest, so a candidate that fails this
      test, the guard, SER or VS fails them in every sub-problem: it is retired for the
      row, and only a left-right failure is retried in the sub-problems;
    * the discontinuity guard (``edge_guard > 0``): the left pixels ``edge_guard`` columns
      to each side block-match, over the whole band, within one disparity of the
      candidate, with uniqueness ratios of at least ``uniqueness``.

    ``wta_k`` and ``wta_ratio`` hold the whole-band block match of the left pixels and
    its uniqueness ratio, computed on first use (``block_match``; set ``wta_k`` to
    ``NOT_MATCHED`` for a new row). A problem without a reliable pair is filled
    by ``fill_interval`` (``linear``: ``dc-linear``). An accepted pair ``p <-> j`` writes
    ``row.disparity[p] = p - j``, ``row.partner[p] = j``, ``row.ser[p]`` and ``row.vs[p]``.
    Returns the doubled total cost of the fill paths.
    """
    dmin, _, radius = dsi
    ser_min, vs_max, vs_relative, var_floor, lr_check, uniqueness, edge_guard, signal_steps, \
        max_candidates, linear = tests  # fmt: skip
    path, stack, tree_v, tree_i, iwork, fwork = work
    disp_row, flag_row, partner_row, ser_row, vs_row = row
    width, ndisp = cost.shape
    # With the uniqueness test and no limit on the tries, a candidate's match, guard, SER
    # and VS do not depend on the interval (the match is the whole-band one), and a failure
    # of any of them retires it for the row: those tests run once per pixel, up front, and
    # only the candidates that pass them enter the search. The intervals then only check
    # the ordering range and the left-right test. The pairs accepted are the same: a
    # candidate left out would have been tried and refused (never accepted), and without a
    # limit the tries it used to take change nothing.
    prefilter = uniqueness > 0 and max_candidates == 0
    # the candidates, by column: a whole window inside the image, variance at least the
    # floor (and, with the prefilter, passing the tests above); per candidate i: its
    # column, its match and reliability (prefilter), its left-right state (see below)
    cand_x = iwork[0]
    held = iwork[1]  # left out of this interval only
    cand_k = iwork[2]
    lr_j = iwork[3]
    lr_below = iwork[4]
    lr_above = iwork[5]
    cand_ser = fwork[0]
    cand_vs = fwork[1]
    cand_var = fwork[2]  # the candidates' variances
    cand_live = fwork[3]  # the same, -inf once tried in this problem or retired
    sparse = iwork[6:]
    n = 0
    for p in range(radius, width - radius):
        if not var_l[p] >= var_floor:
            continue
        if prefilter:
            best_k = block_match(cost, p, wta_k, wta_ratio)
            if best_k < 0 or wta_ratio[p] < uniqueness:
                continue
            j = p - dmin - best_k
            if j < radius or j > width - 1 - radius:
                continue  # outside the range of every interval
            # the cheap test first: VS needs no window sums
            if not variance_similarity(var_l[p], var_r[j], vs_relative) <= vs_max:
                continue
            if edge_guard > 0 and not _edge_guarded(
                cost, p, best_k, edge_guard, wta_k, wta_ratio, uniqueness
            ):
                continue
            ser, vs = _pair_reliability(
                left_p, right_p, y, p, j, radius, var_l, var_r, signal_steps, vs_relative
            )
            if not (ser >= ser_min and vs <= vs_max):
                continue
            cand_k[n] = best_k
            cand_ser[n] = ser
            cand_vs[n] = vs
        cand_x[n] = p
        lr_j[n] = -1
        n += 1
    # the strongest candidate still in play inside an interval (ties: leftmost first),
    # without scanning the interval. With the prefilter nearly every candidate tried is
    # accepted (splits the interval, and is outside both halves): a static sparse table of
    # range maxima answers in O(1), and only when its answer is out of play (retired, or
    # tried in this problem) is the interval scanned. Otherwise a segment tree, updated
    # as candidates go out of play and come back.
    for i in range(n):
        cand_var[i] = var_l[cand_x[i]]
        cand_live[i] = cand_var[i]
    size = 1
    if prefilter:
        _sparse_build(cand_var, n, sparse)
    else:
        while size < n:
            size *= 2
        for i in range(n):
            tree_v[size + i] = cand_var[i]
            tree_i[size + i] = i
        for i in range(n, size):
            tree_v[size + i] = -np.inf
            tree_i[size + i] = -1
        for node in range(size - 1, 0, -1):
            _tree_pull(tree_v, tree_i, node)
    # the left-right check of a pair p <-> j depends on the interval only through the
    # nearest competing left pixels below and above p (computed once per pair, kept)
    total = 0.0
    top = 1
    stack[0, 0] = -1
    stack[0, 1] = width
    stack[0, 2] = -1
    stack[0, 3] = width
    stack[0, 4] = 0  # the candidates strictly inside (A, C): indices 4..5
    stack[0, 5] = n - 1
    while top > 0:
        top -= 1
        a = stack[top, 0]
        c = stack[top, 1]
        b = stack[top, 2]
        e = stack[top, 3]
        i_lo = stack[top, 4]
        i_hi = stack[top, 5]
        found = False
        if c - a > 1 and e - b > 1 and i_lo <= i_hi:
            tries = 0
            nheld = 0
            while not (max_candidates > 0 and tries >= max_candidates):
                if prefilter:
                    i = _sparse_best(cand_var, sparse, i_lo, i_hi)
                    if not cand_live[i] > -np.inf:
                        i = -1
                        strongest = -np.inf
                        for q in range(i_lo, i_hi + 1):
                            if cand_live[q] > strongest:
                                strongest = cand_live[q]
                                i = q
                else:
                    i = _tree_best(tree_v, tree_i, size, i_lo, i_hi)
                if i < 0:
                    break
                p = cand_x[i]
                tries += 1
                # a candidate that fails is either retired for the row (out of play for
                # good) or held out of this interval only
                if prefilter:
                    cand_live[i] = -np.inf
                else:
                    _tree_set(tree_v, tree_i, size, i, -np.inf)
                # right pixels strictly inside (B, D), their whole window inside the image
                k_lo = max(0, p - min(e - 1, width - 1 - radius) - dmin)
                k_hi = min(ndisp - 1, p - max(b + 1, radius) - dmin)
                if prefilter:
                    best_k = cand_k[i]
                    if not k_lo <= best_k <= k_hi:
                        continue  # the sub-problems' ranges nest: retired
                elif uniqueness > 0:
                    # only the whole-band match can be unique; the ranges of the sub-problems
                    # nest, so a candidate that fails here fails in all of them: retired
                    best_k = block_match(cost, p, wta_k, wta_ratio)
                    if not k_lo <= best_k <= k_hi or wta_ratio[p] < uniqueness:
                        continue
                else:
                    best_k = _argmin_row(cost, p, k_lo, k_hi)
                    if best_k < 0:
                        held[nheld] = i
                        nheld += 1
                        continue
                if edge_guard > 0 and not prefilter:
                    if not _edge_guarded(cost, p, best_k, edge_guard, wta_k, wta_ratio, uniqueness):
                        if uniqueness <= 0:
                            held[nheld] = i
                            nheld += 1
                        continue
                best = cost[p, best_k]
                j = p - dmin - best_k
                if lr_check:
                    # the right pixel, matched back inside (A, C), must choose p again: no
                    # other left pixel of the interval may cost as little as p with it
                    if lr_j[i] != j:
                        lr_j[i] = j
                        lr_below[i] = -1
                        lr_above[i] = width
                        for k in range(ndisp):
                            x = j + dmin + k
                            if x < 0 or x >= width or x == p or not cost[x, k] <= best:
                                continue
                            if x < p:
                                lr_below[i] = max(lr_below[i], x)
                            else:
                                lr_above[i] = min(lr_above[i], x)
                    if lr_below[i] > a or lr_above[i] < c:
                        held[nheld] = i  # a narrower interval may let it pass
                        nheld += 1
                        continue
                if prefilter:
                    ser = cand_ser[i]
                    vs = cand_vs[i]
                else:
                    ser, vs = _pair_reliability(
                        left_p, right_p, y, p, j, radius, var_l, var_r, signal_steps, vs_relative
                    )
                if ser >= ser_min and vs <= vs_max:
                    found = True  # p is an anchor from now on (retired)
                    disp_row[p] = p - j
                    flag_row[p] = 0
                    partner_row[p] = j
                    ser_row[p] = ser
                    vs_row[p] = vs
                    stack[top, 0] = a
                    stack[top, 1] = p
                    stack[top, 2] = b
                    stack[top, 3] = j
                    stack[top, 4] = i_lo
                    stack[top, 5] = i - 1
                    stack[top + 1, 0] = p
                    stack[top + 1, 1] = c
                    stack[top + 1, 2] = j
                    stack[top + 1, 3] = e
                    stack[top + 1, 4] = i + 1
                    stack[top + 1, 5] = i_hi
                    top += 2
                    break
                if uniqueness <= 0:
                    held[nheld] = i  # with uniqueness, same pair and SER/VS everywhere: retired
                    nheld += 1
            for h in range(nheld):
                i = held[h]
                if prefilter:
                    cand_live[i] = cand_var[i]
                else:
                    _tree_set(tree_v, tree_i, size, i, cand_var[i])
        if not found:
            total += fill_interval(
                cost, dmin, step_costs, a, c, b, e, width, linear, path, disp_row, flag_row
            )
    return total


@nb.njit(cache=True)
def fill_interval(cost, dmin, step_costs, a, c, b, e, width, linear, path, disp_row, flag_row):
    """Fill the left pixels strictly between anchors ``a <-> b`` and ``c <-> e``.

    ``a == -1`` (and ``b == -1``) is the free start of the scanline, ``c == width`` (and
    ``e == width``) its free end: there the whole-scanline boundary rules apply. With
    ``linear`` and two real anchors the disparities are interpolated linearly; otherwise
    the DP runs inside the rectangle with its path forced through the anchors
    (``dp.scanline_dp`` with ``step_costs`` and its scratch ``path``). Returns the doubled
    cost of the DP path (0 for interpolation): from the start anchor, which costs nothing
    here (its interval on the left counted it), to the end anchor, its match included. An
    interval with no left pixel inside still has that cost (the end anchor's match, and
    the right pixels skipped before it), so that the sum over a row's intervals is the
    cost of the whole path through its pairs, as the band DP counts it.
    """
    anchor_start = a >= 0
    anchor_end = c < width
    if linear and anchor_start and anchor_end:
        if c - a <= 1:
            return 0.0
        d_a = a - b
        d_c = c - e
        for x in range(a + 1, c):
            disp_row[x] = d_a + (d_c - d_a) * (x - a) / (c - a)
            flag_row[x] = 0
        return 0.0
    x_lo = a if anchor_start else 0
    j_lo = b if anchor_start else 0
    x_hi = c if anchor_end else width - 1
    j_hi = e if anchor_end else width - 1
    n, t = scanline_dp(cost, dmin, step_costs, x_lo, x_hi, j_lo, j_hi, anchor_start, anchor_end,
                       path)  # fmt: skip
    apply_path(path, n, dmin, disp_row, flag_row)
    return t


@nb.njit(cache=True)
def divide_scratch(width, ndisp):
    """Return the ``records.DivideScratch`` of ``divide_row`` for rows of ``width`` pixels.

    So that a row allocates nothing: ``path`` (``dp.path_scratch``), the work list
    ``stack`` (int64, (width + 2, 6)), the segment tree ``tree_v`` (float64) and ``tree_i``
    (int64) of length ``2 * size``, ``size`` the least power of two ``>= width``, ``iwork``
    (int64, (6 + levels, width), ``2**(levels - 1) >= width``) and ``fwork`` (float64,
    (4, width)).
    """
    size = 1
    while size < width:
        size *= 2
    levels = 1
    while (1 << (levels - 1)) < width:
        levels += 1
    return DivideScratch(
        path_scratch(width, ndisp),
        np.empty((width + 2, 6), dtype=np.int64),
        np.empty(2 * size, dtype=np.float64),
        np.empty(2 * size, dtype=np.int64),
        np.empty((6 + levels, width), dtype=np.int64),
        np.empty((4, width), dtype=np.float64),
    )


@nb.njit(parallel=True, cache=True)
def match_dc_rows(left_p, right_p, dsi, bt, step_costs, tests, nchunks, out):
    """Divide-and-conquer matching of every row; rows are the only parallel loop.

    ``dsi``, ``step_costs``, ``tests``: those of ``divide_row`` (``records``); ``bt``: the
    Birchfield-Tomasi cost (``row_costs_bt``) instead of the SAD of eq. 4. Outputs
    (``records.Outputs``) per pixel: ``disparity``, ``flags``; per accepted feature pair
    ``(y, x) <-> (y, j)``: ``partner[y, x] = j`` and its ``ser`` and ``vs`` (-1 and NaN
    elsewhere); per row, the doubled cost of the fill paths in ``total``.
    """
    dmin, ndisp, radius = dsi
    signal_steps = tests.signal_steps
    disp, flags, total = out.disparity, out.flags, out.total
    partner, ser, vs = out.partner, out.ser, out.vs
    height, width = disp.shape
    wp = left_p.shape[1]
    for ch in nb.prange(nchunks):
        y0, y1 = chunk_bounds(height, nchunks, ch)
        cost = np.empty((width, ndisp), dtype=np.float64)
        vcol = np.empty((width, ndisp), dtype=np.int32)
        colsum = np.empty(wp, dtype=np.int64)
        colsq = np.empty(wp, dtype=np.int64)
        colsum_r = np.empty(wp, dtype=np.int64)
        colsq_r = np.empty(wp, dtype=np.int64)
        var_l = np.empty(width, dtype=np.float64)
        var_r = np.empty(width, dtype=np.float64)
        wta_k = np.empty(width, dtype=np.int64)
        wta_ratio = np.empty(width, dtype=np.float64)
        work = divide_scratch(width, ndisp)
        for y in range(y0, y1):
            _row_costs_any(left_p, right_p, y, dmin, ndisp, radius, vcol, cost, y > y0, bt)
            window_variance_row(left_p, y, radius, signal_steps, colsum, colsq, var_l, y > y0)
            window_variance_row(right_p, y, radius, signal_steps, colsum_r, colsq_r, var_r, y > y0)
            for x in range(width):
                wta_k[x] = NOT_MATCHED
                disp[y, x] = np.nan
                flags[y, x] = FLAG_BORDER
                partner[y, x] = -1
                ser[y, x] = np.nan
                vs[y, x] = np.nan
            row = RowOutputs(disp[y], flags[y], partner[y], ser[y], vs[y])
            total[y] = divide_row(cost, left_p, right_p, y, dsi, step_costs, tests, var_l, var_r,
                                  wta_k, wta_ratio, work, row)  # fmt: skip


@nb.njit(cache=True)
def collect_pairs(pairs, counts, flag, flags):
    """Return the pairs ``(row, x_left, x_right, SER, VS)`` of rows stored compactly.

    Row ``y``'s ``counts[y]`` pairs are ``pairs[y, :counts[y]]`` (``x``, ``j``, SER, VS,
    float32, in increasing ``x``; ``bands.match_band_rows``' ``dc`` output).
    Float64, (n, 5), in row-major order, the table ``collect_features`` makes of the
    same pairs stored per pixel; each pair's pixel gets ``flag`` in ``flags``. It reads
    the pairs only, not a whole per-pixel map (which, just written by the kernel, is no
    longer in the caches: on venus 0.5 ms of a 15 ms ``dc`` call went to that scan).
    """
    height = counts.shape[0]
    out = np.empty((counts.sum(), 5))
    n = 0
    for y in range(height):
        for i in range(counts[y]):
            x = np.int64(pairs[y, i, 0])
            out[n, 0] = y
            out[n, 1] = x
            out[n, 2] = pairs[y, i, 1]
            out[n, 3] = pairs[y, i, 2]
            out[n, 4] = pairs[y, i, 3]
            flags[y, x] |= flag
            n += 1
    return out


@nb.njit(cache=True, parallel=True)
def collect_features(partner, ser, vs, flag, flags):
    """Return the pairs ``(row, x_left, x_right, SER, VS)`` where ``partner >= 0``.

    Float64, (n, 5), in row-major order. ``ser``/``vs`` of shape (0, 0): NaN. Each pair's
    pixel gets ``flag`` in ``flags``. Rows in parallel: a count per row, then each row
    writes its pairs from its own start.
    """
    height, width = partner.shape
    given = ser.shape[0] > 0
    # no array expressions in a parallel function: numba makes each one a parallel loop
    # of its own (compile time); the loops below write every entry
    starts = np.empty(height + 1, dtype=np.int64)
    starts[0] = 0
    for y in nb.prange(height):
        count = 0
        for x in range(width):
            count += partner[y, x] >= 0
        starts[y + 1] = count
    for y in range(height):
        starts[y + 1] += starts[y]
    out = np.empty((starts[height], 5))
    for y in nb.prange(height):
        n = starts[y]
        for x in range(width):
            j = partner[y, x]
            if j < 0:
                continue
            out[n, 0] = y
            out[n, 1] = x
            out[n, 2] = j
            out[n, 3] = ser[y, x] if given else np.nan
            out[n, 4] = vs[y, x] if given else np.nan
            flags[y, x] |= flag
            n += 1
    return out

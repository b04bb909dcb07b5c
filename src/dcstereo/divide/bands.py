"""The band drivers: ``dsi3``, ``dsi5``, ``dc``, ``dsi3-gcp`` and ``block`` on bands of rows.

``match_band_rows`` runs, per band of ``BAND_ROWS`` rows, the costs (:mod:`.band_costs`),
for ``dc`` and ``dsi3-gcp`` the block match (:mod:`.band_match`) and the search
(:mod:`.divide_bands`, :mod:`.gcp`), and the DP (:mod:`.band_dp`), free or through the
pins; ``match_block_bands`` the winner-take-all of ``block``. The only parallel loop is
over chunks of bands; each chunk allocates its scratch once, every array at its own
offset within a page (:mod:`.scratch`).

The rows of a band are not consecutive: in each parallel chunk, band row ``r`` runs down
its own run of consecutive rows, so that the integer vertical window sums of each lane are
moved down one row per band (add the entering row, subtract the leaving one) instead of
being summed afresh from the ``2 radius + 1`` window rows.
"""

import numba as nb
import numpy as np

from dcstereo._records import Anchors, BandMatches, CostPass, SearchScratch
from dcstereo._vector.scratch import _placed
from dcstereo._vector.simd import BAND_ROWS, cycle_counter
from dcstereo.costs.band import (
    SUMS_AFRESH,
    SUMS_MOVED,
    SUMS_READY,
    _cost_column,
    _integer_columns,
    _key_shift,
    _keys_fit,
    band_lane_costs,
    band_lane_costs_bt,
    band_lane_signals,
    band_lane_variance,
)
from dcstereo.divide.band_match import _column_wta, _key_blocks, band_block_match
from dcstereo.divide.divide_bands import (
    _guard_columns,
    _narrow_sums,
    band_feature_mask,
    band_row_features,
    band_strong_counts,
)
from dcstereo.divide.gcp import _gcp_scratch, band_row_gcps
from dcstereo.result import FLAG_BORDER
from dcstereo.scanline.band_dp import band_backtrack_row, band_forward
from dcstereo.scanline.rows import chunk_bounds

#: The stages of ``match_band_rows`` that its ``clock`` times, in that order (``costs``:
#: the band's cost array, made before the search, and in ``dc`` the block match of the
#: columns it moves down a row; in free mode the forward pass makes the costs, in
#: ``SEARCH_TWICE`` the block match and the forward pass do; ``block match``: the other
#: columns', with ``band_strong_counts``; ``search``: the feature pairs of the band's rows,
#: or its pins read from ``partner``, and the pinned columns).
CLOCK_STAGES = (
    "signals", "costs", "variances", "block match", "mask", "search", "forward", "backtrack",
)  # fmt: skip
(
    _CLOCK_SIGNALS, _CLOCK_COSTS, _CLOCK_VARIANCES, _CLOCK_BLOCK, _CLOCK_MASK, _CLOCK_SEARCH,
    _CLOCK_FORWARD, _CLOCK_BACKTRACK,
) = range(len(CLOCK_STAGES))  # fmt: skip


@nb.njit(cache=True, inline="always")
def _clock_mark(clock):
    """Return the counter now, or 0 without a clock (``clock`` None: nothing is compiled)."""
    if clock is None:
        return 0
    return cycle_counter()


@nb.njit(cache=True, inline="always")
def _clock_add(clock, ch, stage, mark):
    """Add the counts since ``mark`` to ``clock[ch, stage]``; return the counter now."""
    if clock is None:
        return 0
    now = cycle_counter()
    clock[ch, stage] += now - mark
    return now


@nb.njit(cache=True, inline="always")
def _chunk_lanes(height, nchunks, ch):
    """Return ``(y_a, n, run)``: chunk ``ch`` has ``n`` rows from ``y_a``.

    The ``ceil(height / R)`` bands are split as evenly as they go; lane ``r`` takes row
    ``y_a + r * run + t`` at band step ``t``.
    """
    nr = BAND_ROWS
    b0, b1 = chunk_bounds((height + nr - 1) // nr, nchunks, ch)
    y_a = b0 * nr
    n = max(0, min(height, b1 * nr) - y_a)
    return y_a, n, (n + nr - 1) // nr


@nb.njit(cache=True, inline="always")
def _cost_scratch(width, ndisp, radius):
    """Return a chunk's scratch for the cost passes, in slots 0-5 of ``_placed``.

    ``(left_t, right_t, rows, spread, vs, hsum)``: ``band_lane_signals``' rows of the two
    views and their row numbers, and ``band_lane_costs``' scratch.
    """
    nr = BAND_ROWS
    width_p = width + 2 * radius
    nt = max(2 * radius + 1, 2)
    return (
        _placed(nt * width_p * nr, np.int32, 0),
        _placed(nt * width_p * nr, np.int32, 1),
        _placed(nt * nr, np.int64, 2),
        _placed(2 * ndisp * nr, np.int32, 3),
        _placed(width * ndisp * nr, np.int32, 4),
        _placed(ndisp * nr, np.int32, 5),
    )


@nb.njit(cache=True, inline="always")
def _lane_rows(t, y_a, run, n, radius, height_p, rows):
    """Write the padded rows ``band_lane_signals`` loads at band step ``t``; return how many.

    Lane ``r`` of a chunk of ``n`` rows from ``y_a`` takes row ``y_a + r * run + t`` (see
    ``match_band_rows``). At ``t = 0`` the ``2 radius + 1`` window rows of each lane's first
    row (past the image: any rows), then the row leaving and the row entering each lane's
    window (idle lanes: row 0).
    """
    nr = BAND_ROWS
    if t == 0:
        win = 2 * radius + 1
        for tt in range(win):
            for r in range(nr):
                rows[tt * nr + r] = min(y_a + r * run + tt, height_p - 1)
        return win
    for r in range(nr):
        if r * run + t < n:
            rows[r] = y_a + r * run + t - 1
            rows[nr + r] = y_a + r * run + t + 2 * radius
        else:
            rows[r] = 0
            rows[nr + r] = 0
    return 2


@nb.njit(cache=True)
def _signal_bounds(left_p, right_p):
    """Return the least and the largest value of the two views (int64).

    Indexed loops in the views' own type: vector minima and maxima (on tsukuba's padded
    pair 19 us, against 36 us for the parallel reductions this replaced and 113 us for a
    loop over an iterator).
    """
    low = left_p[0, 0]
    high = low
    for view in (left_p, right_p):
        flat = view.ravel()
        for i in range(flat.size):
            low = min(low, flat[i])
            high = max(high, flat[i])
    return np.int64(low), np.int64(high)


#: How ``match_band_rows`` runs (its ``mode``).
FREE = 0  # the whole-scanline DP of every row, no pins (dsi3, dsi5)
PINS_GIVEN = 1  # the DP through pins given in ``out.partner``
SEARCH = 2  # a search on the band's cost array (dc's pairs, dsi3-gcp's points), the DP through it
SEARCH_TWICE = 3  # SEARCH without the band's cost array: its costs made twice (SAD only)

# The compiled variants of the band kernels' optional parts, by the type of their argument:
# numba compiles a kernel once per argument type, so an argument that is None compiles a
# version without the part (no branch left in its loops), and one that is True a version
# with it. Named here so that no caller passes a bare None or True.
#: ``bt``: the Birchfield-Tomasi cost (its bounds and spread arrays made first).
BT_COST = True
#: ``bt``: the SAD cost, compiled without the Birchfield-Tomasi code.
SAD_COST = None
#: ``gcp``: ``dsi3-gcp``'s ground control points instead of ``dc``'s feature search.
GCP_POINTS = True
#: ``gcp``: ``dc``'s feature search (or no search), compiled without the points.
FEATURE_SEARCH = None


@nb.njit(parallel=True, cache=True)
def match_band_rows(left_p, right_p, dsi, step_costs, mode, tests, nchunks, out, clock=None,
                    bt=None, gcp=None):  # fmt: skip
    """Run the whole-scanline DP of every row, ``BAND_ROWS`` rows at a time.

    The results of ``rows.match_dsi_rows`` with ``bt=False``, bit for bit. The only
    parallel loop is over ``nchunks`` runs of consecutive rows (the ``ceil(height / R)``
    bands split as evenly as they go). In a chunk of ``n`` rows from ``y_a``, band row
    (lane) ``r`` runs down rows ``y_a + r * run + t``, ``run = ceil(n / R)``, at band step
    ``t``, so that each lane's row moves down by one from band to band and the vertical
    window sums are updated (``band_lane_costs``: two absolute differences per cell) after
    the chunk's first band (computed afresh). Lanes past the chunk's rows are idle: their
    sums stay those of their last row (or of clamped rows), no pins, results not written.

    ``dsi`` (``records.Dsi``): the disparities and the window; ``step_costs``
    (``records.StepCosts``): the DP's; ``out`` (``records.Outputs``): ``disparity``,
    ``flags`` and ``total`` are written in every mode, the others as said below.

    ``mode`` ``FREE``: no pins (``out.partner``, ``out.pairs``, ``out.counts`` and ``tests``
    are not used). ``PINS_GIVEN``: ``out.partner[y, x] = j`` pins left pixel ``(y, x)`` to
    right pixel ``(y, j)`` (-1: no pin; along a row increasing in both ``x`` and ``j``, each
    pair inside the disparity range), and each row gets the result of ``gcp.gcp_row``'s
    segment-by-segment DP through its pins, with the five- or three-step model
    (``step_costs.five``). ``SEARCH``: ``dc``: the pins are the reliable feature pairs of
    ``band_row_features`` (``tests``, ``records.FeatureTests``; the window variances of the
    two views from ``band_lane_variance``; ``partner`` is not used), and then as
    ``PINS_GIVEN``; the cost pass block-matches the columns it moves down a row as it makes
    them (``band_lane_costs``' ``match``) where the signals' span lets 32-bit keys hold
    every cost (``_keys_fit``), ``band_block_match`` the rest. Row ``y``'s ``counts[y]``
    pairs are ``pairs[y, :counts[y]]`` (float32 ``(height, width, 4)``: ``x``, ``j``, SER,
    VS, in increasing ``x``; the rest of each row is scratch). ``SEARCH_TWICE``: as
    ``SEARCH``, without the band's cost array (for wide images and disparity ranges, whose
    band costs leave the caches): the block match makes the costs a column at a time
    (``band_block_match``'s ``make_costs``; the columns it moves down a row made and matched
    at once where the keys fit, its ``fused``) and the DP pass makes them again from the
    vertical sums it left. The search then has no costs to read: the left-right check
    (``tests.lr_check``) must be off.

    ``tests`` None (with ``FREE`` only): the search and the band cost array are
    left out of the compiled function (numba prunes the ``tests is not None`` branches),
    so that ``dsi3`` and ``dsi5`` do not compile ``dc``'s code on their first call.

    ``clock`` None: not timed. Otherwise int64, ``(nchunks, len(CLOCK_STAGES))``: each
    chunk adds the cycle counts of its stages (``CLOCK_STAGES``) to its row (for
    ``benchmarks/bench_stages.py``; None compiles to the function without the counter).

    ``bt`` None: the SAD cost of eq. 4. Otherwise (``True``) the Birchfield-Tomasi cost
    (``band_lane_costs_bt``, the values of ``costs.row_costs_bt``), in every mode but
    ``SEARCH_TWICE``: the band's cost array is made first, and the search and the DP read it; its
    half-integer costs are never keyed (``band_block_match``'s generic pass). The results
    are those of ``rows.match_dsi_rows`` and ``match_dc_rows`` with ``bt=True`` (or
    ``gcp_row``'s DP through the pins), bit for bit. None compiles to the function
    without the BT code.

    ``gcp`` None: as above. Otherwise (``True``, with ``SEARCH`` or ``SEARCH_TWICE``)
    ``dsi3-gcp``: the pins of each row are its ground control points (``band_row_gcps``, the
    points of ``gcp.select_gcps``; ``tests`` with the points' variance floor and uniqueness
    and no guard), written to ``out.partner`` (as ``gcp.match_gcp_rows``; ``pairs`` and
    ``counts`` are not used), then as ``PINS_GIVEN``. Their left-right check walks the
    band's array in ``SEARCH``; in ``SEARCH_TWICE`` it reads the two least costs of each
    right pixel, which the block match folds in as it makes each column
    (``band_block_match``' ``diagonals``). None compiles to the function without that
    search.
    """
    if bt is not None and mode == SEARCH_TWICE:
        raise ValueError("the Birchfield-Tomasi cost needs the band's cost array (no SEARCH_TWICE)")
    search = mode == SEARCH or mode == SEARCH_TWICE
    if gcp is not None and not search:
        raise ValueError("the ground control points are a search (SEARCH or SEARCH_TWICE)")
    dmin, ndisp, radius = dsi
    disp, flags, total = out.disparity, out.flags, out.total
    partner, pairs, counts = out.partner, out.pairs, out.counts
    height, width = disp.shape
    height_p, width_p = left_p.shape
    nr = BAND_ROWS
    nk = (ndisp + 2) * nr
    # the columns band_block_match's keyed search may take
    x_int_lo, x_int_hi = _integer_columns(width, dmin, ndisp, radius)
    if bt is not None:  # half-integer costs: no column is keyed
        x_int_hi = x_int_lo
    # dc: the pass that makes the costs (with the band's cost array, the cost pass; without,
    # the block match) block-matches these columns as it makes them (those it moves down a
    # row), where the 32-bit keys hold every cost
    key_shift = _key_shift(ndisp + 2)
    fused_hi = x_int_lo  # none
    short_ssd = False  # the search's SSD in its short form (SSD_SHORT)
    if tests is not None and search:
        # a loop, not the views' max() and min(): numba makes each array expression of a
        # parallel function a parallel loop of its own, seconds of compile
        low, high = _signal_bounds(left_p, right_p)
        span = high - low
        if _keys_fit(span, radius, key_shift):
            fused_hi = x_int_hi
        short_ssd = 2 * radius + 1 <= nr and _narrow_sums(span, max(abs(low), abs(high)), radius)
    for ch in nb.prange(nchunks):
        # the chunk's rows; lane r takes rows y_a + r * run + t at band step t
        y_a, n, run = _chunk_lanes(height, nchunks, ch)
        # scratch at chosen offsets within a page (see _placed), one slot per array
        left_t, right_t, rows, spread, vs, hsum = _cost_scratch(width, ndisp, radius)
        anchored = mode != FREE
        made = mode == FREE or mode == SEARCH_TWICE  # no band cost array
        if bt is not None:
            made = False
            bt_bounds = _placed(12 * width_p * nr, np.int32, 28).reshape((12, width_p * nr))
            bt_spread = _placed(3 * ndisp * nr, np.int32, 29)
        # FREE and SEARCH_TWICE make each column's costs inside the passes: two columns
        cost = _placed((2 if made else width) * nk, np.float64, 6)
        step_bits = _placed(width * (ndisp + 2), np.uint32, 7)
        ring = _placed(3 * nk, np.float64, 9).reshape((3, nk))
        ends = _placed(2 * ndisp * nr, np.float64, 10)
        # no fill: free mode reads neither, and the anchored modes write both each band
        pins = _placed(width * nr, np.int64, 11)
        pinned = _placed(width, np.bool_, 12)
        anchor_total = _placed(width * nr, np.float64, 13)
        anchor_steps = _placed(width * nr, np.int64, 14)
        anchors = Anchors(pins, pinned, anchor_total, anchor_steps)
        anchor_x = np.empty(width, dtype=np.int64)
        nwork = width if search else 1
        pre = _placed(nk if search else 1, np.float64, 15)
        suf = _placed(nk if search else 1, np.float64, 16)
        wta_k = _placed(nwork * nr, np.int64, 17)
        wta_ratio = _placed(nwork * nr, np.float64, 18)
        keep = _placed(nwork * nr, np.uint8, 19)
        nvar = width_p * nr if search else 1
        colsum = _placed(nvar, np.float64, 20)
        colsq = _placed(nvar, np.float64, 21)
        hwork = _placed(2 * nwork * nr, np.float64, 22).reshape((2, nwork * nr))
        var_band = _placed(nwork * nr, np.float64, 23)
        steps = 1 if tests is None else tests.signal_steps
        levels = 1
        while (1 << (levels - 1)) < width:
            levels += 1
        iwork = _placed((6 + levels) * nwork, np.int64, 24).reshape((6 + levels, nwork))
        fwork = _placed(4 * nwork, np.float64, 25).reshape((4, nwork))
        stack = _placed((nwork + 2) * 6, np.int64, 26).reshape((nwork + 2, 6))
        work = SearchScratch(iwork, fwork, stack)
        matches = BandMatches(var_band, wta_k, wta_ratio, keep)
        strong = _placed(nwork + 1, np.int64, 8)
        done = _placed(width, np.uint8, 27)  # columns the cost pass matched
        # dsi3-gcp's left-right check without the band's array (None for dc: a variable of
        # one type per compiled version, so that each compiles one form of the block match;
        # numba prunes a test of gcp only where it is None, and the gcp version compiled
        # both forms, 20 s more on its first call)
        diagonals = _gcp_scratch(gcp, nwork * nr if made else 1)
        for t in range(run):
            sums = SUMS_MOVED if t > 0 else SUMS_AFRESH  # the vertical sums of this band
            mark = _clock_mark(clock)
            nt = _lane_rows(t, y_a, run, n, radius, height_p, rows)
            band_lane_signals(left_p, right_p, rows, nt, left_t, right_t)
            mark = _clock_add(clock, ch, _CLOCK_SIGNALS, mark)
            if bt is not None:
                band_lane_costs_bt(
                    left_t, right_t, width, dmin, ndisp, radius, bt_bounds, bt_spread, vs,
                    t > 0, hsum, cost,
                )  # fmt: skip
                if search:
                    for x in range(width):
                        done[x] = 0  # the block match takes every column
                mark = _clock_add(clock, ch, _CLOCK_COSTS, mark)
            elif tests is not None and not made:  # the search and pins read them before the DP
                band_lane_costs(
                    left_t, right_t, width, dmin, ndisp, radius, spread, vs, sums, hsum, cost,
                    (x_int_lo, fused_hi, key_shift, wta_k, wta_ratio, done),
                )  # fmt: skip
                mark = _clock_add(clock, ch, _CLOCK_COSTS, mark)
            if tests is not None and search:
                band_lane_variance(
                    left_t, width, radius, steps, t > 0, colsum, colsq, hwork[0], hwork[1],
                    var_band,
                )  # fmt: skip
                mark = _clock_add(clock, ch, _CLOCK_VARIANCES, mark)
                # the block match only where the feature tests read it
                band_strong_counts(var_band, width, tests.var_floor, strong)
                wanted = (strong, _guard_columns(tests.edge_guard))
                if made:
                    band_block_match(
                        cost, width, ndisp, x_int_lo, x_int_hi, pre, suf, wta_k, wta_ratio,
                        CostPass(left_t, right_t, dmin, radius, spread, vs, sums, hsum), wanted,
                        None, (x_int_lo, fused_hi, key_shift), diagonals,
                    )  # fmt: skip
                else:
                    band_block_match(
                        cost, width, ndisp, x_int_lo, x_int_hi, pre, suf, wta_k, wta_ratio, None,
                        wanted, done,
                    )  # fmt: skip
                mark = _clock_add(clock, ch, _CLOCK_BLOCK, mark)
                band_feature_mask(var_band, wta_k, wta_ratio, width, dmin, radius, tests, keep)
                mark = _clock_add(clock, ch, _CLOCK_MASK, mark)
                for i in range(width * nr):
                    pins[i] = -1
                for x in range(width):
                    pinned[x] = False
                for r in range(nr):
                    if r * run + t >= n:
                        continue
                    y = y_a + r * run + t
                    if gcp is not None:
                        for x in range(width):
                            partner[y, x] = -1
                        band_row_gcps(cost, width, dsi, r, wta_k, keep, iwork, anchors, partner[y],
                                      diagonals, made)  # fmt: skip
                        continue
                    counts[y] = band_row_features(
                        cost, width, dsi, r, y, left_p, right_p, matches, tests, short_ssd, work,
                        anchors, pairs[y],
                    )  # fmt: skip
            elif anchored:
                for x in range(width):
                    for r in range(nr):
                        pins[x * nr + r] = partner[y_a + r * run + t, x] if r * run + t < n else -1
                for x in range(width):
                    pinned[x] = False
                    for r in range(nr):
                        if pins[x * nr + r] >= 0:
                            pinned[x] = True
            if anchored:
                mark = _clock_add(clock, ch, _CLOCK_SEARCH, mark)
            # two call sites: the forward pass with the band's costs, and the one that
            # makes them (a None or a record argument: two compiled versions); after the
            # block match of SEARCH_TWICE the band's vertical sums are ready
            if bt is not None:
                band_forward(cost, width, dsi, step_costs, anchored, anchors, ring, step_bits,
                             ends, None)  # fmt: skip
            elif tests is not None and not made:
                band_forward(cost, width, dsi, step_costs, True, anchors, ring, step_bits, ends,
                             None)  # fmt: skip
            else:
                ready = SUMS_READY if search else sums
                band_forward(cost, width, dsi, step_costs, anchored, anchors, ring, step_bits,
                             ends, CostPass(left_t, right_t, dmin, radius, spread, vs, ready,
                                            hsum))  # fmt: skip
            mark = _clock_add(clock, ch, _CLOCK_FORWARD, mark)
            for r in range(nr):
                if r * run + t >= n:
                    continue
                y = y_a + r * run + t
                for x in range(width):
                    disp[y, x] = np.nan
                    flags[y, x] = FLAG_BORDER
                # the row's anchor columns: its pairs, or the pins given (a scan without
                # branches: each column writes the next entry, a pinned one keeps it)
                nanchors = 0
                if search and gcp is None:
                    nanchors = counts[y]
                    for i in range(nanchors):
                        anchor_x[i] = np.int64(pairs[y, i, 0])
                elif anchored:
                    for x in range(width):
                        anchor_x[nanchors] = x
                        nanchors += pins[x * nr + r] >= 0
                total[y] = band_backtrack_row(step_bits, ends, width, dsi, r, anchor_x, nanchors,
                                              anchors, disp[y], flags[y])  # fmt: skip
            _clock_add(clock, ch, _CLOCK_BACKTRACK, mark)


@nb.njit(parallel=True, cache=True)
def match_block_bands(left_p, right_p, dsi, nchunks, out, bt=None):
    """Winner-take-all block matching, ``BAND_ROWS`` rows at a time.

    The results of ``rows.match_block_rows``, bit for bit: per pixel the first
    disparity of least window cost (NaN and ``FLAG_BORDER`` where every cell is inf), and
    per row the sum of the least costs in ``x`` order. The chunks and lanes are those of
    ``match_band_rows``. SAD (``bt`` None): each column's costs are made as in its free
    mode (``_cost_column``) and matched at once (``_column_wta``, the prefix minima of
    ``band_block_match``), so no band cost array is kept. Birchfield-Tomasi (``bt``
    True): the band's cost array is made first (``band_lane_costs_bt``) and its columns
    matched, never keyed (half-integer costs). ``dsi``: ``records.Dsi``; ``out``
    (``records.Outputs``): ``disparity``, ``flags`` and ``total`` are written.
    """
    dmin, ndisp, radius = dsi
    disp, flags, total = out.disparity, out.flags, out.total
    height, width = disp.shape
    height_p = left_p.shape[0]
    width_p = width + 2 * radius
    nr = BAND_ROWS
    nk = (ndisp + 2) * nr
    x_int_lo, x_int_hi = _integer_columns(width, dmin, ndisp, radius)  # keyed columns
    if bt is not None:
        x_int_hi = x_int_lo
    for ch in nb.prange(nchunks):
        y_a, n, run = _chunk_lanes(height, nchunks, ch)
        left_t, right_t, rows, spread, vs, hsum = _cost_scratch(width, ndisp, radius)
        cost = _placed(nk, np.float64, 6)
        pre = _placed(nk, np.float64, 7)
        blocks = _placed(nk, np.float64, 8)
        scale = _key_blocks(ndisp, blocks)
        low = _placed(nr, np.float64, 9)
        first = _placed(nr, np.int64, 10)
        sums = _placed(nr, np.float64, 11)
        if bt is not None:
            band_cost = _placed(width * nk, np.float64, 12)
            bt_bounds = _placed(12 * width_p * nr, np.int32, 13).reshape((12, width_p * nr))
            bt_spread = _placed(3 * ndisp * nr, np.int32, 14)
        for t in range(run):
            nt = _lane_rows(t, y_a, run, n, radius, height_p, rows)
            band_lane_signals(left_p, right_p, rows, nt, left_t, right_t)
            if bt is not None:
                band_lane_costs_bt(
                    left_t, right_t, width, dmin, ndisp, radius, bt_bounds, bt_spread, vs,
                    t > 0, hsum, band_cost,
                )  # fmt: skip
            for r in range(nr):
                sums[r] = 0.0
            for x in range(width):
                keyed = x_int_lo <= x < x_int_hi
                if bt is not None:
                    _column_wta(
                        band_cost[x * nk : (x + 1) * nk], ndisp, keyed, scale, blocks, pre, low,
                        first,
                    )  # fmt: skip
                else:
                    _cost_column(
                        left_t, right_t, x, width, dmin, ndisp, radius, spread, vs,
                        SUMS_MOVED if t > 0 else SUMS_AFRESH, hsum, cost, np.uint64(0),
                    )  # fmt: skip
                    _column_wta(cost, ndisp, keyed, scale, blocks, pre, low, first)
                for r in range(nr):
                    if r * run + t >= n:
                        continue
                    y = y_a + r * run + t
                    if first[r] < 0:
                        disp[y, x] = np.nan
                        flags[y, x] = FLAG_BORDER
                    else:
                        disp[y, x] = dmin + first[r]
                        flags[y, x] = 0
                        sums[r] += low[r]
            for r in range(nr):
                if r * run + t < n:
                    total[y_a + r * run + t] = sums[r]

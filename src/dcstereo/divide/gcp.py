"""Intille and Bobick's ground control points, and the three-step DP through them (``dsi3-gcp``).

Per scanline, the left pixels whose whole-band match is textured, unambiguous and
left-right consistent, of which the longest run increasing in both ``x`` and ``j`` (the
ordering constraint) are kept (``select_gcps``); the DP of section 3 with the three steps
then runs from each to the next (``gcp_row``), as ``dc`` fills between its feature pairs.
The band form (``band_row_gcps``, the points of ``BAND_ROWS`` rows on the band's costs,
whose DP is :mod:`.band_dp`'s) gives the same points and maps, bit for bit; the row form
runs the Birchfield-Tomasi cost on images too wide for the band's cost array.
"""

import numba as nb
import numpy as np
from numba.core import types
from numba.extending import overload

from dcstereo._vector.scratch import _placed
from dcstereo._vector.simd import BAND_ROWS
from dcstereo.costs.window import _row_costs_any
from dcstereo.divide.features import _argmin_row, uniqueness_ratio, window_variance_row
from dcstereo.result import FLAG_BORDER
from dcstereo.scanline.dp import apply_path, path_scratch, scanline_dp
from dcstereo.scanline.rows import chunk_bounds


@nb.njit(cache=True)
def _run_lengths(cand_j, m, length, tails):
    """``length[i]``: the longest run strictly increasing in ``cand_j`` from candidate ``i``.

    Returns the longest of all. O(m log m): from the last candidate back, ``tails[L - 1]``
    is the largest ``j`` that starts a run of length ``L`` among the candidates after
    ``i``, strictly decreasing in ``L`` (a run's second element starts a shorter one with
    a larger ``j``), so the runs that ``i`` can start are a binary search away. The same
    lengths as ``max(length[i2] for i2 > i with cand_j[i2] > cand_j[i]) + 1``, which
    became O(m^2) on wide textured rows (thousands of candidates). ``tails``: scratch of
    ``m``.
    """
    longest = 0
    for i in range(m - 1, -1, -1):
        v = cand_j[i]
        lo = 0  # the count of tails above v: a prefix
        hi = longest
        while lo < hi:
            mid = (lo + hi) // 2
            if tails[mid] > v:
                lo = mid + 1
            else:
                hi = mid
        length[i] = lo + 1
        tails[lo] = v  # tails[lo] <= v, or a new length
        if lo == longest:
            longest += 1
    return longest


@nb.njit(cache=True)
def _longest_run(cand_j, m, length, kept):
    """Keep the longest run of candidates ``0..m-1`` strictly increasing in ``cand_j``.

    Of the runs of that length, the first in lexicographic order of the candidates'
    indices; its indices go to ``kept[:n]``, in order, and ``n`` is returned. ``length``
    and ``kept`` (int64, at least ``m``) are scratch (``_run_lengths``' ``length`` and
    ``tails``).
    """
    longest = _run_lengths(cand_j, m, length, kept)
    n = 0
    need = longest
    last_j = -1
    for i in range(m):
        if need == 0:
            break
        if length[i] == need and cand_j[i] > last_j:
            kept[n] = i  # n <= i: the tails are read no more
            last_j = cand_j[i]
            n += 1
            need -= 1
    return n


@nb.njit(cache=True)
def select_gcps(cost, var_l, dmin, radius, uniqueness, var_floor, gcp_x, gcp_j):
    """Ground control points of one scanline (Intille and Bobick): returns their number.

    A left pixel ``x`` with its whole-band least-cost match ``j = x - dmin - k``
    (``_argmin_row``, the first of equal costs) is a candidate when

    * both windows lie inside the image: ``radius <= x, j < width - radius``;
    * it is textured: its window variance ``var_l[x]`` is at least ``var_floor``;
    * it is unambiguous: ``uniqueness_ratio(cost, x, k) >= uniqueness``;
    * it is left-right consistent: over the right pixel's band, ``x`` is the one left
      pixel of least cost (every other ``x2 = j + dmin + k2`` costs strictly more).

    Each right pixel then has at most one candidate. Of the candidates (in increasing
    ``x``), the kept ones are the longest subsequence strictly increasing in ``j`` as
    well (the ordering constraint), and of those of that length the first in
    lexicographic order of the candidates' indices. They go to ``gcp_x[:n]``,
    ``gcp_j[:n]``, increasing in both.
    """
    width, ndisp = cost.shape
    cand_x = np.empty(width, dtype=np.int64)
    cand_j = np.empty(width, dtype=np.int64)
    m = 0
    for x in range(radius, width - radius):
        if not var_l[x] >= var_floor:
            continue
        k = _argmin_row(cost, x, 0, ndisp - 1)
        if k < 0:
            continue
        j = x - dmin - k
        if j < radius or j >= width - radius:
            continue
        if uniqueness_ratio(cost, x, k) < uniqueness:
            continue
        best = cost[x, k]
        back = True
        for k2 in range(ndisp):
            x2 = j + dmin + k2
            if x2 == x or x2 < 0 or x2 >= width:
                continue
            if cost[x2, k2] <= best:
                back = False
                break
        if not back:
            continue
        cand_x[m] = x
        cand_j[m] = j
        m += 1
    # the longest subsequence strictly increasing in j, lexicographically first
    kept = np.empty(m, dtype=np.int64)
    n = _longest_run(cand_j, m, np.empty(m, dtype=np.int64), kept)
    for q in range(n):
        gcp_x[q] = cand_x[kept[q]]
        gcp_j[q] = cand_j[kept[q]]
    return n


@nb.njit(cache=True)
def gcp_row(cost, var_l, dsi, step_costs, tests, path, gcp_x, gcp_j, disp_row, flag_row,
            partner_row):  # fmt: skip
    """Run the three-step DP of one scanline, forced through its ground control points.

    ``select_gcps`` picks the points (``tests.uniqueness`` and ``tests.var_floor``; scratch
    ``gcp_x`` and ``gcp_j``, int64 of ``width``); between consecutive ones (and from the
    scanline's free start to the first, from the last to its free end) ``scanline_dp``
    runs with ``step_costs`` (``dsi3-gcp``: the three steps) and its scratch ``path``, with
    anchored ends, as ``fill_interval`` does for ``dc`` (also between
    neighbouring points, so that the right pixels skipped between them pay their
    occlusions). Without any point it is exactly the whole-scanline ``dsi3`` DP. A point
    ``x <-> j`` writes ``disp_row[x] = x - j`` and ``partner_row[x] = j``. Returns the
    doubled path cost.
    """
    dmin, _, radius = dsi
    width = cost.shape[0]
    n = select_gcps(cost, var_l, dmin, radius, tests.uniqueness, tests.var_floor, gcp_x, gcp_j)
    total = 0.0
    a = -1
    b = -1
    for i in range(n + 1):
        if i < n:
            c = gcp_x[i]
            e = gcp_j[i]
        else:
            c = width
            e = width
        if c < width or a < width - 1:  # else the last point ends the row: nothing left
            anchor_start = a >= 0
            anchor_end = c < width
            n_path, t = scanline_dp(
                cost,
                dmin,
                step_costs,
                a if anchor_start else 0,
                c if anchor_end else width - 1,
                b if anchor_start else 0,
                e if anchor_end else width - 1,
                anchor_start,
                anchor_end,
                path,
            )
            apply_path(path, n_path, dmin, disp_row, flag_row)
            total += t
        if i < n:
            disp_row[c] = c - e
            flag_row[c] = 0
            partner_row[c] = e
        a = c
        b = e
    return total


@nb.njit(parallel=True, cache=True)
def match_gcp_rows(left_p, right_p, dsi, bt, step_costs, tests, nchunks, out):
    """``dsi3`` through ground control points on every row (``gcp_row``); rows in parallel.

    ``dsi``, ``step_costs``, ``tests``: ``gcp_row``'s (``records``); ``bt``: the
    Birchfield-Tomasi cost instead of eq. 4's SAD. Outputs (``records.Outputs``):
    ``disparity``, ``flags``, ``total``, and ``partner[y, x] = j`` for each control point
    ``(y, x) <-> (y, j)``, -1 elsewhere.
    """
    dmin, ndisp, radius = dsi
    disp, flags, total, partner = out.disparity, out.flags, out.total, out.partner
    height, width = disp.shape
    wp = left_p.shape[1]
    for ch in nb.prange(nchunks):
        y0, y1 = chunk_bounds(height, nchunks, ch)
        cost = np.empty((width, ndisp), dtype=np.float64)
        vcol = np.empty((width, ndisp), dtype=np.int32)
        colsum = np.empty(wp, dtype=np.int64)
        colsq = np.empty(wp, dtype=np.int64)
        var_l = np.empty(width, dtype=np.float64)
        path = path_scratch(width, ndisp)
        gcp_x = np.empty(width, dtype=np.int64)
        gcp_j = np.empty(width, dtype=np.int64)
        for y in range(y0, y1):
            _row_costs_any(left_p, right_p, y, dmin, ndisp, radius, vcol, cost, y > y0, bt)
            window_variance_row(left_p, y, radius, tests.signal_steps, colsum, colsq, var_l, y > y0)
            for x in range(width):
                partner[y, x] = -1
            for x in range(width):
                disp[y, x] = np.nan
                flags[y, x] = FLAG_BORDER
            total[y] = gcp_row(cost, var_l, dsi, step_costs, tests, path, gcp_x, gcp_j, disp[y],
                               flags[y], partner[y])  # fmt: skip


@nb.njit(cache=True)
def band_row_gcps(cost, width, dsi, r, wta_k, keep, iwork, anchors, partner_row, diagonals, folded):
    """Intille and Bobick's ground control points of band row ``r``, as ``gcp.select_gcps``.

    ``wta_k`` is the band's block match (``band_block_match``); ``keep``
    (``band_feature_mask`` with the points' variance floor and uniqueness, no guard) holds
    the window, variance, uniqueness and range tests. A survivor ``x`` with match ``j`` is
    a candidate when it passes the exact left-right check: over the right pixel's band
    every other left pixel costs strictly more. ``folded`` False: the check walks the
    band's cost array ``cost`` (``band_lane_costs``), up to the first left pixel that costs
    no more (``diagonals`` is not read). True, for a band without the array (``cost``
    is not read): ``diagonals`` is ``(least, second, best)``, and the pixel's cost
    ``best[x * R + r]`` must be the least of the right pixel's costs, and no other equal to
    it (``least`` and ``second``, in ``_gcp_diagonals``' order; ``band_block_match``'
    ``diagonals``). On a band's array the walk is the faster: few survivors, most of them
    stopped early. The points are the longest run of
    candidates strictly increasing in ``j`` too, the first in lexicographic order of the
    candidates. Each point ``x <-> j`` goes to ``anchors.pins[x * R + r]`` (which must hold
    -1), ``anchors.pinned[x]`` and ``partner_row[x]`` (which must hold -1). Returns their
    number. ``dsi``: ``records.Dsi``. Scratch: ``iwork`` (int64, at least (4, width)).
    """
    dmin, ndisp, radius = dsi
    pins, pinned = anchors.pins, anchors.pinned
    nr = BAND_ROWS
    nk = (ndisp + 2) * nr
    cand_x = iwork[0]
    cand_j = iwork[1]
    m = 0
    for x in range(radius, width - radius):
        if not keep[x * nr + r]:
            continue
        k = wta_k[x * nr + r]
        j = x - dmin - k
        if not folded:
            best = cost[x * nk + (k + 1) * nr + r]
            back = True
            for k2 in range(ndisp):
                x2 = j + dmin + k2
                if x2 == x or x2 < 0 or x2 >= width:
                    continue
                if cost[x2 * nk + (k2 + 1) * nr + r] <= best:
                    back = False
                    break
            if not back:
                continue
        else:
            least, second, best_cost = diagonals
            best = best_cost[x * nr + r]
            i = (width - 1 - j) * nr + r  # _gcp_diagonals' order
            if not (least[i] == best and second[i] > best):
                continue
        cand_x[m] = x
        cand_j[m] = j
        m += 1
    # the longest subsequence strictly increasing in j, lexicographically first
    kept = iwork[3]
    n = _longest_run(cand_j, m, iwork[2], kept)
    for q in range(n):
        x = cand_x[kept[q]]
        pins[x * nr + r] = cand_j[kept[q]]
        pinned[x] = True
        partner_row[x] = cand_j[kept[q]]
    return n


@nb.njit(cache=True, inline="always")
def _gcp_arrays(n):
    """``(least, second, best)``, ``n`` float64 each: ``band_block_match``' ``diagonals``."""
    return (_placed(n, np.float64, 30), _placed(n, np.float64, 31), _placed(n, np.float64, 0))


def _gcp_scratch(gcp, n):
    """``band_block_match``' ``diagonals`` for ``match_band_rows``: None without ``gcp``.

    Otherwise ``_gcp_arrays(n)``. Compiled code takes the overload below, which chooses by
    the type of ``gcp``.
    """
    return None if gcp is None else _gcp_arrays(n)


@overload(_gcp_scratch)
def _gcp_scratch_compiled(gcp, n):
    if isinstance(gcp, (types.NoneType, types.Omitted)):
        return lambda gcp, n: None
    return lambda gcp, n: _gcp_arrays(n)


@nb.njit(cache=True, inline="always")
def _gcp_diagonals(cost, o, x, dmin, ndisp, width, least, second):
    """Fold column ``x`` (at ``cost[o:]``) into the two least costs of each right pixel.

    ``least[(width - 1 - j) * R + r]`` and ``second[...]`` (right pixels in reverse order)
    are the least and the second least (counted with repeats: equal to the least where it
    occurs twice) of lane ``r``'s costs of right pixel ``j``, over the left pixels
    ``x2 = j + dmin + k2`` of the row: the diagonal of the band's costs that
    ``gcp.select_gcps``' left-right check walks. Only the cells with
    ``0 <= j < width`` are folded (the others are inf). In reverse order a column's
    right pixels ``j = x - dmin - k`` follow its cells, so the fold is one flat loop (a
    vector loop; numba leaves the SLP vectorizer off).
    """
    nr = BAND_ROWS
    k_lo = max(0, x - dmin - width + 1)
    k_hi = min(ndisp, x - dmin + 1)
    if k_hi <= k_lo:
        return
    oc = o + np.uint64((k_lo + 1) * nr)
    od = np.uint64((width - 1 - x + dmin + k_lo) * nr)
    for i in range(np.uint64((k_hi - k_lo) * nr)):
        v = cost[oc + i]
        m = least[od + i]
        second[od + i] = min(second[od + i], max(m, v))
        least[od + i] = min(m, v)


@nb.njit(cache=True, inline="always")
def _gcp_best(cost, o, x, wta_k, best):
    """``best[x * R + r]``: lane ``r``'s cost at its match ``wta_k`` (inf: none)."""
    nr = BAND_ROWS
    for r in range(nr):
        k = wta_k[x * nr + r]
        best[x * nr + r] = cost[o + np.uint64((k + 1) * nr + r)] if k >= 0 else np.inf

"""Compiled kernels: windowed SAD costs of one row, the scanline DPs, the row drivers.

Kernels that call each other live in this one file because numba's on-disk cache
does not notice edits made in other files.

Conventions (see ``docs`` and ``../shared/paper/NOTES.md``):

* A left pixel ``x`` matches the right pixel ``j = x - d``.
* The banded DSI of one row is ``cost[x, k]`` with ``d = dmin + k``; a cell whose
  right pixel falls outside the image holds ``inf``.
* Costs are integers (quantized signal, window *sums*) stored in float64, so every
  DP sum is exact and the result does not depend on evaluation order.
* DP step costs are *doubled* so that the half-weights of the d and e steps of
  eq. 5 stay integers: match ``2 * DSI(p)``, occlusion ``occ2``, d step
  ``2 * DSI(p) + DSI(b) + DSI(c)``, e step ``2 * DSI(p) + DSI(a) + DSI(c)``.
"""

import numba as nb
import numpy as np

# Step codes stored per DP node (how the node was entered).
STEP_NONE = 0  # unreachable
STEP_C = 1  # match (i-1, j-1) -> (i, j)
STEP_A = 2  # left pixel i occluded: (i-1, j) -> (i, j)
STEP_B = 3  # right pixel j occluded: (i, j-1) -> (i, j)
STEP_D = 4  # (i-1, j-2) -> (i, j): right j-1 between left i-1 and i
STEP_E = 5  # (i-2, j-1) -> (i, j): left i-1 between right j-1 and j (half-pixel)
STEP_START = 6  # the anchored start node of a segment

# Reason flags (uint8 bits), mirrored in result.py.
FLAG_OCCLUDED = 1
FLAG_BORDER = 2


# --------------------------------------------------------------------------- costs


@nb.njit(cache=True)
def row_costs(left_p, right_p, y, dmin, ndisp, radius, colsum, out):
    """Windowed SAD of eq. 4 for row ``y`` into ``out[x, k]`` (inf outside the image).

    ``left_p``/``right_p`` are the integer signals padded by ``radius`` on every side
    (edge replicated): padded row ``y + t``, ``t in [0, 2 * radius]``, is row ``y - radius + t``
    of the window, replicated identically in both views. Along the row the window is
    *truncated* to the columns ``s`` where both ``x + s`` and ``x - d + s`` lie inside the
    images, and the sum is rescaled to the full window (``* W / columns used``): padding one
    view and comparing it with real pixels of the other would charge a fake mismatch to the
    pixels within ``radius`` of an image edge. Interior cells are exact integer sums.
    ``colsum`` is a scratch vector at least as long as the row.
    """
    wp = left_p.shape[1]
    width = wp - 2 * radius
    win = 2 * radius + 1
    for k in range(ndisp):
        d = dmin + k
        for x in range(width):
            out[x, k] = np.inf
        x0 = max(0, d)
        x1 = min(width, width + d)  # exclusive; 0 <= x - d < width
        if x0 >= x1:
            continue
        for x in range(x0, x1):
            s = 0
            for t in range(win):
                s += abs(left_p[y + t, x + radius] - right_p[y + t, x - d + radius])
            colsum[x] = s
        # running sum over the truncated window [max(x - r, x0), min(x + r, x1 - 1)]
        lo = x0
        hi = min(x0 + radius, x1 - 1)
        s = 0
        for c in range(lo, hi + 1):
            s += colsum[c]
        for x in range(x0, x1):
            new_lo = max(x - radius, x0)
            new_hi = min(x + radius, x1 - 1)
            while hi < new_hi:
                hi += 1
                s += colsum[hi]
            while lo < new_lo:
                s -= colsum[lo]
                lo += 1
            used = hi - lo + 1
            if used == win:
                out[x, k] = s
            else:
                out[x, k] = s * win / used


# --------------------------------------------------------------------------- DP


@nb.njit(cache=True, inline="always")
def _node(table, x, k, ndisp, dmin, x_lo, x_hi, j_lo, j_hi, anchor_start):
    """Accumulated cost of node (x, dmin + k), with the segment's boundary rules."""
    if k < 0 or k >= ndisp:
        return np.inf
    j = x - dmin - k
    if anchor_start:
        if x < x_lo or j < j_lo:
            return np.inf
    else:
        if x < x_lo - 1 or j < j_lo - 1:
            return np.inf
        if x == x_lo - 1 or j == j_lo - 1:
            return 0.0  # virtual start: nothing consumed on one side
    if x > x_hi or j > j_hi:
        return np.inf
    return table[x - x_lo, k]


@nb.njit(cache=True)
def scanline_dp(
    cost,
    dmin,
    occ2,
    five,
    slant2,
    x_lo,
    x_hi,
    j_lo,
    j_hi,
    anchor_start,
    anchor_end,
    table,
    steps,
    path_x,
    path_k,
    path_s,
):
    """Cheapest path over the banded DSI of one scanline segment (eq. 5).

    The segment matches left pixels ``x_lo..x_hi`` with right pixels ``j_lo..j_hi``.

    * ``anchor_start``: the path starts at the (already matched) node
      ``(x_lo, j_lo)``. Otherwise it starts at a *virtual* node where one side has
      consumed nothing: ``x = x_lo - 1`` or ``j = j_lo - 1``, at cost 0. On a whole
      scanline this makes the left pixels ``x < d`` of the first disparity border
      pixels (their partner would lie left of the right image), free of charge.
    * ``anchor_end``: the path ends at ``(x_hi, j_hi)``, entered by a match step
      (c, d or e). Otherwise it ends at the cheapest node with ``x == x_hi`` or
      ``j == j_hi``; the pixels left over on the other side have no partner inside
      the image (border) and cost nothing.

    ``five`` selects the five-step model (a, b, c, d, e) over the classic three.
    Returns ``(n, total)``: the path (end to start) in ``path_x/k/s[:n]`` and its
    doubled cost; ``n == 0`` when no admissible path exists.
    """
    ndisp = cost.shape[1]
    for x in range(x_lo, x_hi + 1):
        r = x - x_lo
        for k in range(ndisp):
            table[r, k] = np.inf
            steps[r, k] = STEP_NONE
        k_hi = min(ndisp - 1, x - j_lo - dmin)
        k_lo = max(0, x - j_hi - dmin)
        for k in range(k_hi, k_lo - 1, -1):
            j = x - dmin - k
            if anchor_start and x == x_lo:
                if j == j_lo:
                    table[r, k] = 0.0
                    steps[r, k] = STEP_START
                    continue
            is_end = anchor_end and x == x_hi and j == j_hi
            best = np.inf
            step = STEP_NONE
            here = cost[x, k]
            if here < np.inf:
                v = (
                    _node(table, x - 1, k, ndisp, dmin, x_lo, x_hi, j_lo, j_hi, anchor_start)
                    + 2.0 * here
                )
                if v < best:
                    best = v
                    step = STEP_C
                if five and x >= 1:
                    if k + 1 < ndisp:  # d step from (x-1, d+1) via b=(x, d+1), c=(x-1, d)
                        extra = cost[x, k + 1] + cost[x - 1, k]
                        v = (
                            _node(
                                table,
                                x - 1,
                                k + 1,
                                ndisp,
                                dmin,
                                x_lo,
                                x_hi,
                                j_lo,
                                j_hi,
                                anchor_start,
                            )
                            + 2.0 * here
                            + extra
                            + slant2
                        )
                        if v < best:
                            best = v
                            step = STEP_D
                    if k >= 1:  # e step from (x-2, d-1) via a=(x-1, d-1), c=(x-1, d)
                        extra = cost[x - 1, k - 1] + cost[x - 1, k]
                        v = (
                            _node(
                                table,
                                x - 2,
                                k - 1,
                                ndisp,
                                dmin,
                                x_lo,
                                x_hi,
                                j_lo,
                                j_hi,
                                anchor_start,
                            )
                            + 2.0 * here
                            + extra
                            + slant2
                        )
                        if v < best:
                            best = v
                            step = STEP_E
            if not is_end:
                v = (
                    _node(table, x - 1, k - 1, ndisp, dmin, x_lo, x_hi, j_lo, j_hi, anchor_start)
                    + occ2
                )
                if v < best:
                    best = v
                    step = STEP_A
                v = _node(table, x, k + 1, ndisp, dmin, x_lo, x_hi, j_lo, j_hi, anchor_start) + occ2
                if v < best:
                    best = v
                    step = STEP_B
            table[r, k] = best
            steps[r, k] = step

    # choose the end node
    end_x = -1
    end_k = -1
    total = np.inf
    if anchor_end:
        k = x_hi - j_hi - dmin
        if 0 <= k < ndisp:
            total = table[x_hi - x_lo, k]
            end_x = x_hi
            end_k = k
    else:
        # nodes with x == x_hi (j <= j_hi), then nodes with j == j_hi (x < x_hi)
        for k in range(ndisp):
            j = x_hi - dmin - k
            if j_lo <= j <= j_hi:
                v = table[x_hi - x_lo, k]
                if v < total:
                    total = v
                    end_x = x_hi
                    end_k = k
        for k in range(ndisp):
            x = j_hi + dmin + k
            if x_lo <= x < x_hi:
                v = table[x - x_lo, k]
                if v < total:
                    total = v
                    end_x = x
                    end_k = k
    if not total < np.inf:
        return 0, np.inf

    # backtrack
    n = 0
    x = end_x
    k = end_k
    while True:
        s = steps[x - x_lo, k]
        path_x[n] = x
        path_k[n] = k
        path_s[n] = s
        n += 1
        if s == STEP_START:
            break
        if s == STEP_C:
            x -= 1
        elif s == STEP_A:
            x -= 1
            k -= 1
        elif s == STEP_B:
            k += 1
        elif s == STEP_D:
            x -= 1
            k += 1
        else:  # STEP_E
            x -= 2
            k -= 1
        j = x - dmin - k
        if not anchor_start and (x == x_lo - 1 or j == j_lo - 1):
            break
    return n, total


@nb.njit(cache=True)
def apply_path(path_x, path_k, path_s, n, dmin, disp_row, flag_row):
    """Write the left-image disparities and occlusions of a backtracked path.

    Pixels the path does not consume keep what the caller put there (border).
    """
    for i in range(n):
        x = path_x[i]
        d = dmin + path_k[i]
        s = path_s[i]
        if s == STEP_C or s == STEP_D:
            disp_row[x] = d
            flag_row[x] = 0
        elif s == STEP_E:
            disp_row[x] = d
            flag_row[x] = 0
            disp_row[x - 1] = d - 0.5
            flag_row[x - 1] = 0
        elif s == STEP_A:
            disp_row[x] = np.nan
            flag_row[x] = FLAG_OCCLUDED


# --------------------------------------------------------------------------- drivers


@nb.njit(cache=True)
def _chunk_bounds(height, nchunks, c):
    step = (height + nchunks - 1) // nchunks
    return c * step, min(height, (c + 1) * step)


@nb.njit(parallel=True, cache=True)
def match_dsi_rows(
    left_p, right_p, dmin, ndisp, radius, occ2, five, slant2, nchunks, disp, flags, total
):
    """Run the whole-scanline DP on every row; rows are the only parallel loop."""
    height, width = disp.shape
    wp = left_p.shape[1]
    for c in nb.prange(nchunks):
        y0, y1 = _chunk_bounds(height, nchunks, c)
        cost = np.empty((width, ndisp), dtype=np.float64)
        colsum = np.empty(wp, dtype=np.int64)
        table = np.empty((width, ndisp), dtype=np.float64)
        steps = np.empty((width, ndisp), dtype=np.uint8)
        path_x = np.empty(2 * width + 2, dtype=np.int64)
        path_k = np.empty(2 * width + 2, dtype=np.int64)
        path_s = np.empty(2 * width + 2, dtype=np.uint8)
        for y in range(y0, y1):
            row_costs(left_p, right_p, y, dmin, ndisp, radius, colsum, cost)
            for x in range(width):
                disp[y, x] = np.nan
                flags[y, x] = FLAG_BORDER
            n, t = scanline_dp(
                cost,
                dmin,
                occ2,
                five,
                slant2,
                0,
                width - 1,
                0,
                width - 1,
                False,
                False,
                table,
                steps,
                path_x,
                path_k,
                path_s,
            )
            apply_path(path_x, path_k, path_s, n, dmin, disp[y], flags[y])
            total[y] = t


@nb.njit(parallel=True, cache=True)
def match_block_rows(left_p, right_p, dmin, ndisp, radius, nchunks, disp, flags, total):
    """Winner-take-all block matching: the disparity of least window SAD per pixel."""
    height, width = disp.shape
    wp = left_p.shape[1]
    for c in nb.prange(nchunks):
        y0, y1 = _chunk_bounds(height, nchunks, c)
        cost = np.empty((width, ndisp), dtype=np.float64)
        colsum = np.empty(wp, dtype=np.int64)
        for y in range(y0, y1):
            row_costs(left_p, right_p, y, dmin, ndisp, radius, colsum, cost)
            t = 0.0
            for x in range(width):
                best = np.inf
                best_k = -1
                for k in range(ndisp):
                    if cost[x, k] < best:
                        best = cost[x, k]
                        best_k = k
                if best_k < 0:
                    disp[y, x] = np.nan
                    flags[y, x] = FLAG_BORDER
                else:
                    disp[y, x] = dmin + best_k
                    flags[y, x] = 0
                    t += best
            total[y] = t


# --------------------------------------------------------------------------- divide and conquer


@nb.njit(cache=True)
def window_ssd(left_p, right_p, y, x, j, radius):
    """Window sum of squared signal differences of cell (x, j), truncated like ``row_costs``."""
    width = left_p.shape[1] - 2 * radius
    win = 2 * radius + 1
    s = 0.0
    used = 0
    for c in range(-radius, radius + 1):
        if x + c < 0 or x + c >= width or j + c < 0 or j + c >= width:
            continue
        used += 1
        for t in range(win):
            diff = float(left_p[y + t, x + c + radius] - right_p[y + t, j + c + radius])
            s += diff * diff
    return s * win / used


@nb.njit(cache=True)
def window_variance_row(signal_p, y, radius, signal_steps, colsum, colsq, out):
    """Window variance (gray levels squared) of every pixel of row ``y``.

    ``signal_p`` is an integer signal padded by ``radius`` (edge replicated), like the
    inputs of ``row_costs``; the variance is that of the ``(2 radius + 1)^2`` padded window,
    as :func:`dcstereo.cost.window_variance` computes it, but from exact integer sums.
    ``colsum`` and ``colsq`` are int64 scratch vectors as long as a padded row.
    """
    wp = signal_p.shape[1]
    width = wp - 2 * radius
    win = 2 * radius + 1
    n = win * win
    for xp in range(wp):
        s = 0
        q = 0
        for t in range(win):
            v = np.int64(signal_p[y + t, xp])
            s += v
            q += v * v
        colsum[xp] = s
        colsq[xp] = q
    s = 0
    q = 0
    for xp in range(win):
        s += colsum[xp]
        q += colsq[xp]
    norm = float(n) * float(n) * float(signal_steps) * float(signal_steps)
    for x in range(width):
        if x > 0:
            s += colsum[x + win - 1] - colsum[x - 1]
            q += colsq[x + win - 1] - colsq[x - 1]
        out[x] = float(n * q - s * s) / norm


@nb.njit(cache=True)
def pixel_variance(signal_p, y, x, radius, signal_steps):
    """Window variance of the one pixel ``(y, x)``, like ``window_variance_row``."""
    win = 2 * radius + 1
    n = win * win
    s = 0
    q = 0
    for t in range(win):
        for c in range(win):
            v = np.int64(signal_p[y + t, x + c])
            s += v
            q += v * v
    return float(n * q - s * s) / (float(n) * float(n) * float(signal_steps) * float(signal_steps))


@nb.njit(cache=True)
def reliability(var_left, var_right, ssd, vs_relative):
    """SER (eq. 2) and VS (eq. 3) of a candidate pair, from its window statistics.

    ``var_left`` and ``var_right`` are the window variances of the two pixels and ``ssd``
    the window sum of squared differences, all in gray levels (squared). Returns
    ``(ser, vs)``: ``ser = (var_left + var_right) / ssd`` (inf for a perfect match) and
    ``vs = |var_left - var_right|``, divided by ``var_left + var_right`` when
    ``vs_relative`` (0 when both variances are 0).
    """
    total = var_left + var_right
    ser = total / ssd if ssd > 0 else np.inf
    vs = abs(var_left - var_right)
    if vs_relative:
        vs = vs / total if total > 0 else 0.0
    return ser, vs


@nb.njit(cache=True)
def _argmin_row(cost, x, k_lo, k_hi):
    """Index of the least cost of ``cost[x, k_lo..k_hi]`` (-1 when all are inf)."""
    best = np.inf
    best_k = -1
    for k in range(k_lo, k_hi + 1):
        if cost[x, k] < best:
            best = cost[x, k]
            best_k = k
    return best_k


@nb.njit(cache=True)
def uniqueness_ratio(cost, x, best_k):
    """Second-least window cost of left pixel ``x`` over the band, over the cost at ``best_k``.

    The second cost is the least ``cost[x, k]`` with ``|k - best_k| > 1`` (the two
    neighbours of a minimum belong to it). The ratio is ``inf`` when the cost at ``best_k``
    is 0 and the second is not, and 1 when both are 0; a ratio below 1 says that ``best_k``
    is not the least cost of the band.
    """
    ndisp = cost.shape[1]
    best = cost[x, best_k]
    second = np.inf
    for k in range(ndisp):
        if abs(k - best_k) > 1 and cost[x, k] < second:
            second = cost[x, k]
    if best > 0:
        return second / best
    return np.inf if second > 0 else 1.0


NOT_MATCHED = -2  # ``wta_k`` entry not computed yet


@nb.njit(cache=True)
def block_match(cost, x, wta_k, wta_ratio):
    """Whole-band block match of left pixel ``x``, computed once and kept in ``wta_k``.

    ``wta_k[x]`` becomes the least-cost index over the band (-1 where the band is empty)
    and ``wta_ratio[x]`` its ``uniqueness_ratio`` (0 where the band is empty); entries
    equal to ``NOT_MATCHED`` are computed on first use. Returns ``wta_k[x]``.
    """
    if wta_k[x] == NOT_MATCHED:
        k = _argmin_row(cost, x, 0, cost.shape[1] - 1)
        wta_k[x] = k
        wta_ratio[x] = uniqueness_ratio(cost, x, k) if k >= 0 else 0.0
    return wta_k[x]


@nb.njit(cache=True)
def fill_interval(
    cost,
    dmin,
    occ2,
    slant2,
    a,
    c,
    b,
    e,
    width,
    linear,
    table,
    steps,
    path_x,
    path_k,
    path_s,
    disp_row,
    flag_row,
):
    """Fill the left pixels strictly between anchors ``a <-> b`` and ``c <-> e``.

    ``a == -1`` (and ``b == -1``) is the free start of the scanline, ``c == width`` (and
    ``e == width``) its free end: there the whole-scanline boundary rules apply. With
    ``linear`` and two real anchors the disparities are interpolated linearly; otherwise
    the DP runs inside the rectangle with its path forced through the anchors. Returns the
    doubled cost of the DP path (0 for interpolation).
    """
    if c - a <= 1:
        return 0.0
    anchor_start = a >= 0
    anchor_end = c < width
    if linear and anchor_start and anchor_end:
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
    n, t = scanline_dp(
        cost,
        dmin,
        occ2,
        True,
        slant2,
        x_lo,
        x_hi,
        j_lo,
        j_hi,
        anchor_start,
        anchor_end,
        table,
        steps,
        path_x,
        path_k,
        path_s,
    )
    apply_path(path_x, path_k, path_s, n, dmin, disp_row, flag_row)
    return t


@nb.njit(cache=True)
def divide_row(
    cost,
    left_p,
    right_p,
    y,
    radius,
    var_l,
    wta_k,
    wta_ratio,
    dmin,
    occ2,
    slant2,
    ser_min,
    vs_max,
    vs_relative,
    var_floor,
    max_candidates,
    lr_check,
    uniqueness,
    edge_guard,
    linear,
    signal_steps,
    table,
    steps,
    path_x,
    path_k,
    path_s,
    stack,
    disp_row,
    flag_row,
    partner_row,
    ser_row,
    vs_row,
):
    """Section 2 on one scanline: pin reliable feature pairs, fill between them.

    A work list (``stack``, shape (>= width + 2, 4)) of problems ``(A, C, B, D)``: match
    left pixels strictly inside ``(A, C)`` with right pixels strictly inside ``(B, D)``.
    The candidate of highest left window variance (``var_l``, of row ``y``) is
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
    by ``fill_interval``. An accepted pair ``p <-> j`` writes ``disp_row[p] = p - j``,
    ``partner_row[p] = j``, ``ser_row[p]`` and ``vs_row[p]``. Returns the doubled total cost
    of the fill paths.
    """
    width, ndisp = cost.shape
    scale2 = float(signal_steps * signal_steps)
    # candidates: a whole window inside the image, variance at least the floor, strongest
    # first (ties: leftmost first)
    ncand = 0
    for p in range(radius, width - radius):
        if var_l[p] >= var_floor:
            ncand += 1
    pixels = np.empty(ncand, dtype=np.int64)
    strength = np.empty(ncand, dtype=np.float64)
    ncand = 0
    for p in range(radius, width - radius):
        if var_l[p] >= var_floor:
            pixels[ncand] = p
            strength[ncand] = -var_l[p]
            ncand += 1
    order = pixels[np.argsort(strength, kind="mergesort")]
    retired = np.zeros(width, dtype=np.bool_)
    total = 0.0
    top = 1
    stack[0, 0] = -1
    stack[0, 1] = width
    stack[0, 2] = -1
    stack[0, 3] = width
    while top > 0:
        top -= 1
        a = stack[top, 0]
        c = stack[top, 1]
        b = stack[top, 2]
        e = stack[top, 3]
        found = False
        if c - a > 1 and e - b > 1:
            tries = 0
            kept = 0  # the scan compacts ``order``, dropping the candidates retired for good
            i = 0
            while i < ncand:
                p = order[i]
                i += 1
                if retired[p]:
                    continue
                order[kept] = p
                kept += 1
                if p <= a or p >= c:
                    continue
                if max_candidates > 0 and tries >= max_candidates:
                    break
                tries += 1
                # right pixels strictly inside (B, D), their whole window inside the image
                k_lo = max(0, p - min(e - 1, width - 1 - radius) - dmin)
                k_hi = min(ndisp - 1, p - max(b + 1, radius) - dmin)
                if uniqueness > 0:
                    # only the whole-band match can be unique; the ranges of the sub-problems
                    # nest, so a candidate that fails here fails in all of them
                    best_k = block_match(cost, p, wta_k, wta_ratio)
                    if not k_lo <= best_k <= k_hi or wta_ratio[p] < uniqueness:
                        retired[p] = True
                        kept -= 1
                        continue
                else:
                    best_k = _argmin_row(cost, p, k_lo, k_hi)
                    if best_k < 0:
                        continue
                if edge_guard > 0:
                    guarded = True
                    for x2 in (p - edge_guard, p + edge_guard):
                        x2 = min(max(x2, 0), width - 1)
                        k2 = block_match(cost, x2, wta_k, wta_ratio)
                        if k2 < 0 or abs(k2 - best_k) > 1 or wta_ratio[x2] < uniqueness:
                            guarded = False
                    if not guarded:
                        if uniqueness > 0:
                            retired[p] = True
                            kept -= 1
                        continue
                best = cost[p, best_k]
                j = p - dmin - best_k
                if lr_check:
                    # the right pixel, matched back inside (A, C), must choose p again
                    back = True
                    for k in range(ndisp):
                        x = j + dmin + k
                        if x <= a or x >= c or x == p:
                            continue
                        if cost[x, k] <= best:
                            back = False
                            break
                    if not back:
                        continue  # a narrower interval may let it pass
                ssd = window_ssd(left_p, right_p, y, p, j, radius) / scale2
                ser, vs = reliability(
                    var_l[p], pixel_variance(right_p, y, j, radius, signal_steps), ssd, vs_relative
                )
                if ser >= ser_min and vs <= vs_max:
                    found = True
                    retired[p] = True  # an anchor from now on
                    kept -= 1
                    disp_row[p] = p - j
                    flag_row[p] = 0
                    partner_row[p] = j
                    ser_row[p] = ser
                    vs_row[p] = vs
                    stack[top, 0] = a
                    stack[top, 1] = p
                    stack[top, 2] = b
                    stack[top, 3] = j
                    stack[top + 1, 0] = p
                    stack[top + 1, 1] = c
                    stack[top + 1, 2] = j
                    stack[top + 1, 3] = e
                    top += 2
                    break
                if uniqueness > 0:
                    retired[p] = True  # same pair, same SER and VS in every sub-problem
                    kept -= 1
            while i < ncand:
                order[kept] = order[i]
                kept += 1
                i += 1
            ncand = kept
        if not found:
            total += fill_interval(
                cost,
                dmin,
                occ2,
                slant2,
                a,
                c,
                b,
                e,
                width,
                linear,
                table,
                steps,
                path_x,
                path_k,
                path_s,
                disp_row,
                flag_row,
            )
    return total


@nb.njit(parallel=True, cache=True)
def match_dc_rows(
    left_p,
    right_p,
    dmin,
    ndisp,
    radius,
    occ2,
    slant2,
    ser_min,
    vs_max,
    vs_relative,
    var_floor,
    max_candidates,
    lr_check,
    uniqueness,
    edge_guard,
    linear,
    signal_steps,
    nchunks,
    disp,
    flags,
    total,
    partner,
    ser,
    vs,
):
    """Divide-and-conquer matching of every row; rows are the only parallel loop.

    Outputs per pixel: ``disp``, ``flags``; per accepted feature pair ``(y, x) <-> (y, j)``:
    ``partner[y, x] = j`` and its ``ser`` and ``vs`` (-1 and NaN elsewhere); per row, the
    doubled cost of the fill paths in ``total``.
    """
    height, width = disp.shape
    wp = left_p.shape[1]
    for ch in nb.prange(nchunks):
        y0, y1 = _chunk_bounds(height, nchunks, ch)
        cost = np.empty((width, ndisp), dtype=np.float64)
        colsum = np.empty(wp, dtype=np.int64)
        colsq = np.empty(wp, dtype=np.int64)
        var_l = np.empty(width, dtype=np.float64)
        wta_k = np.empty(width, dtype=np.int64)
        wta_ratio = np.empty(width, dtype=np.float64)
        table = np.empty((width, ndisp), dtype=np.float64)
        steps = np.empty((width, ndisp), dtype=np.uint8)
        path_x = np.empty(2 * width + 2, dtype=np.int64)
        path_k = np.empty(2 * width + 2, dtype=np.int64)
        path_s = np.empty(2 * width + 2, dtype=np.uint8)
        stack = np.empty((width + 2, 4), dtype=np.int64)
        for y in range(y0, y1):
            row_costs(left_p, right_p, y, dmin, ndisp, radius, colsum, cost)
            window_variance_row(left_p, y, radius, signal_steps, colsum, colsq, var_l)
            wta_k[:] = NOT_MATCHED
            for x in range(width):
                disp[y, x] = np.nan
                flags[y, x] = FLAG_BORDER
                partner[y, x] = -1
                ser[y, x] = np.nan
                vs[y, x] = np.nan
            total[y] = divide_row(
                cost,
                left_p,
                right_p,
                y,
                radius,
                var_l,
                wta_k,
                wta_ratio,
                dmin,
                occ2,
                slant2,
                ser_min,
                vs_max,
                vs_relative,
                var_floor,
                max_candidates,
                lr_check,
                uniqueness,
                edge_guard,
                linear,
                signal_steps,
                table,
                steps,
                path_x,
                path_k,
                path_s,
                stack,
                disp[y],
                flags[y],
                partner[y],
                ser[y],
                vs[y],
            )

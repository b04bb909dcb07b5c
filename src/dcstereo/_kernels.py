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
    y,
    cost,
    left_p,
    right_p,
    radius,
    var_l,
    var_r,
    dmin,
    occ2,
    slant2,
    ser_min,
    vs_max,
    vs_relative,
    var_floor,
    max_candidates,
    lr_check,
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
    ser_row,
    vs_row,
):
    """Section 2 on one scanline: pin reliable feature pairs, fill between them.

    A work list (``stack``, shape (>= width + 2, 4)) of problems ``(A, C, B, D)``: match
    left pixels strictly inside ``(A, C)`` with right pixels strictly inside ``(B, D)``.
    The candidate of highest left variance is block-matched inside the band and the right
    interval (the ordering constraint); accepted when ``SER >= ser_min`` and
    ``VS <= vs_max`` (eq. 2 and 3), it splits the problem in two; otherwise the next
    strongest candidate is tried, down to ``var_floor`` and at most ``max_candidates``
    (0: no limit). A problem without a reliable pair is filled by ``fill_interval``.
    Returns the doubled total cost of the fill paths.
    """
    width, ndisp = cost.shape
    scale2 = float(signal_steps * signal_steps)
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
            order = np.argsort(-var_l[y, a + 1 : c], kind="mergesort")
            tries = 0
            for idx in order:
                p = a + 1 + idx
                v_l = var_l[y, p]
                if v_l < var_floor:
                    break
                if max_candidates > 0 and tries >= max_candidates:
                    break
                tries += 1
                k_lo = max(0, p - (e - 1) - dmin)
                k_hi = min(ndisp - 1, p - (b + 1) - dmin)
                best = np.inf
                best_k = -1
                for k in range(k_lo, k_hi + 1):
                    if cost[p, k] < best:
                        best = cost[p, k]
                        best_k = k
                if best_k < 0:
                    continue
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
                        continue
                v_r = var_r[y, j]
                ssd = window_ssd(left_p, right_p, y, p, j, radius) / scale2
                ser = (v_l + v_r) / ssd if ssd > 0 else np.inf
                vs = abs(v_l - v_r)
                if vs_relative:
                    vs = vs / (v_l + v_r) if v_l + v_r > 0 else 0.0
                if ser >= ser_min and vs <= vs_max:
                    found = True
                    disp_row[p] = p - j
                    flag_row[p] = 0
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
    var_l,
    var_r,
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
    linear,
    signal_steps,
    nchunks,
    disp,
    flags,
    total,
    ser,
    vs,
):
    """Divide-and-conquer matching of every row; rows are the only parallel loop."""
    height, width = disp.shape
    wp = left_p.shape[1]
    for ch in nb.prange(nchunks):
        y0, y1 = _chunk_bounds(height, nchunks, ch)
        cost = np.empty((width, ndisp), dtype=np.float64)
        colsum = np.empty(wp, dtype=np.int64)
        table = np.empty((width, ndisp), dtype=np.float64)
        steps = np.empty((width, ndisp), dtype=np.uint8)
        path_x = np.empty(2 * width + 2, dtype=np.int64)
        path_k = np.empty(2 * width + 2, dtype=np.int64)
        path_s = np.empty(2 * width + 2, dtype=np.uint8)
        stack = np.empty((width + 2, 4), dtype=np.int64)
        for y in range(y0, y1):
            row_costs(left_p, right_p, y, dmin, ndisp, radius, colsum, cost)
            for x in range(width):
                disp[y, x] = np.nan
                flags[y, x] = FLAG_BORDER
                ser[y, x] = np.nan
                vs[y, x] = np.nan
            total[y] = divide_row(
                y,
                cost,
                left_p,
                right_p,
                radius,
                var_l,
                var_r,
                dmin,
                occ2,
                slant2,
                ser_min,
                vs_max,
                vs_relative,
                var_floor,
                max_candidates,
                lr_check,
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
                ser[y],
                vs[y],
            )

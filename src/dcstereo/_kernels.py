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
def row_costs(left_p, right_p, y, dmin, ndisp, radius, vcol, out, incremental):
    """Windowed SAD of eq. 4 for row ``y`` into ``out[x, k]`` (inf outside the image).

    ``left_p``/``right_p`` are the integer signals padded by ``radius`` on every side
    (edge replicated): padded row ``y + t``, ``t in [0, 2 * radius]``, is row ``y - radius + t``
    of the window, replicated identically in both views. Along the row the window is
    *truncated* to the columns ``s`` where both ``x + s`` and ``x - d + s`` lie inside the
    images, and the sum is rescaled to the full window (``* W / columns used``): padding one
    view and comparing it with real pixels of the other would charge a fake mismatch to the
    pixels within ``radius`` of an image edge. Interior cells are exact integer sums.

    ``vcol`` (int32, shape (width, ndisp): room for windows of 500,000 rows) holds the
    vertical window sums ``sum_t |L(y + t, x) - R(y + t, x - d)|`` of every cell; with
    ``incremental`` it must hold those of row ``y - 1`` (the previous call) and is updated
    by adding the row that enters the window and subtracting the one that leaves it (two
    absolute differences per cell instead of ``W``); otherwise it is computed afresh. The
    horizontal sum then runs along ``x`` for all disparities at once (the inner loop is
    over ``k``, contiguous).
    """
    wp = left_p.shape[1]
    width = wp - 2 * radius
    win = 2 * radius + 1
    # vertical sums; cells whose partner lies outside the right image hold 0
    if incremental:
        top = y - 1  # padded row leaving the window
        bottom = y + 2 * radius  # padded row entering it
        for x in range(width):
            lt = left_p[top, x + radius]
            lb = left_p[bottom, x + radius]
            base = x - dmin + radius
            k_lo = max(0, x - dmin - (width - 1))
            k_hi = min(ndisp - 1, x - dmin)
            for k in range(k_lo, k_hi + 1):
                jp = base - k
                vcol[x, k] += abs(lb - right_p[bottom, jp]) - abs(lt - right_p[top, jp])
    else:
        for x in range(width):
            for k in range(ndisp):
                vcol[x, k] = 0
            base = x - dmin + radius
            k_lo = max(0, x - dmin - (width - 1))
            k_hi = min(ndisp - 1, x - dmin)
            for t in range(win):
                lv = left_p[y + t, x + radius]
                for k in range(k_lo, k_hi + 1):
                    vcol[x, k] += abs(lv - right_p[y + t, base - k])
    _window_sums(vcol, out, width, dmin, ndisp, radius, False)


@nb.njit(cache=True, inline="always")
def _window_sums(vcol, out, width, dmin, ndisp, radius, halve):
    """Finish a row's window costs from its vertical sums ``vcol`` into ``out[x, k]``.

    The horizontal sums run along ``x`` for every ``k`` at once (the inner loop is over
    ``k``, contiguous; the cells outside the right image hold 0 in ``vcol``); ``halve``
    halves them (exact: they are integers) for the doubled Birchfield-Tomasi values, then
    the cells outside the image get ``inf`` and the truncated windows near the ends of
    each disparity's range are rescaled to the full window (``* W / columns used``;
    halving first changes no bit, a power of two commutes with the rounding).
    """
    win = 2 * radius + 1
    for k in range(ndisp):
        out[0, k] = 0.0
    for c in range(min(radius, width - 1) + 1):
        for k in range(ndisp):
            out[0, k] += vcol[c, k]
    for x in range(1, width):
        add = x + radius
        sub = x - radius - 1
        if add < width and sub >= 0:
            for k in range(ndisp):
                out[x, k] = out[x - 1, k] + (vcol[add, k] - vcol[sub, k])
        elif add < width:
            for k in range(ndisp):
                out[x, k] = out[x - 1, k] + vcol[add, k]
        elif sub >= 0:
            for k in range(ndisp):
                out[x, k] = out[x - 1, k] - vcol[sub, k]
        else:
            for k in range(ndisp):
                out[x, k] = out[x - 1, k]
    if halve:
        for x in range(width):
            for k in range(ndisp):
                out[x, k] *= 0.5
    for k in range(ndisp):
        d = dmin + k
        x0 = max(0, d)
        x1 = min(width, width + d)  # exclusive; 0 <= x - d < width
        for x in range(0, min(x0, width)):
            out[x, k] = np.inf
        for x in range(max(x1, 0), width):
            out[x, k] = np.inf
        # only the first and last ``radius`` columns of the range have truncated windows
        lo_end = min(x0 + radius, x1)
        hi_start = max(x1 - radius, lo_end)
        for x in range(x0, lo_end):
            used = min(x + radius, x1 - 1) - max(x - radius, x0) + 1
            if used != win:
                out[x, k] = out[x, k] * win / used
        for x in range(hi_start, x1):
            used = min(x + radius, x1 - 1) - max(x - radius, x0) + 1
            if used != win:
                out[x, k] = out[x, k] * win / used


# --------------------------------------------------------------------------- DP


@nb.njit(cache=True, inline="always")
def _earlier_steps5(row, prev, prev2, here, left, k1, k2, occ2, slant2):
    """Pass 1 of a row of the five-step DP: c, d, e, a into ``row[k + 1]``, ``k1..k2``.

    ``row``, ``prev``, ``prev2``: padded table rows of columns x, x - 1, x - 2; ``here``,
    ``left``: the cost rows of x and x - 1. A function of its own, over 1-D arrays, so
    that the compiler vectorizes the loop (written inline in ``scanline_dp`` it does not);
    inlined by numba, so that no reference counting of the row views is paid per column.
    """
    for k in range(k1, k2 + 1):
        h2 = 2.0 * here[k]
        c = prev[k + 1] + h2
        u = h2 + left[k] + slant2  # the d and e steps' shared terms, added once
        d = prev[k + 2] + here[k + 1] + u
        e = prev2[k] + left[k - 1] + u
        a = prev[k] + occ2
        row[k + 1] = min(min(c, d), min(e, a))


@nb.njit(cache=True, inline="always")
def _earlier_steps3(row, prev, here, k1, k2, occ2):
    """Pass 1 of a row of the three-step DP: c and a (see ``_earlier_steps5``)."""
    for k in range(k1, k2 + 1):
        row[k + 1] = min(prev[k + 1] + 2.0 * here[k], prev[k] + occ2)


@nb.njit(cache=True, inline="always")
def _slow_cell(cost, table, x, r, k, ndisp, occ2, slant2, slant_ok, allow_a):
    """Best of the c, d, e (and a) steps into cell ``(x, k)``, with bounds checks."""
    h2 = 2.0 * cost[x, k]
    best = table[r - 1, k + 1] + h2
    if slant_ok:
        u = h2 + cost[x - 1, k] + slant2
        if k + 1 < ndisp:
            best = min(best, table[r - 1, k + 2] + cost[x, k + 1] + u)
        if k >= 1:
            best = min(best, table[r - 2, k] + cost[x - 1, k - 1] + u)
    if allow_a:
        best = min(best, table[r - 1, k] + occ2)
    return best


@nb.njit(cache=True, inline="always")
def _step_into(cost, table, x, r, k, ndisp, occ2, slant2, slant_ok, allow_ab):
    """Find the step the forward pass took into cell ``(x, k)``.

    The candidates are evaluated again with the very expressions of the forward pass, in
    its order of preference (c, d, e, a, b: the first of equal costs wins), and the first
    whose cost equals the cell's is the step: exact, since the arithmetic is the same.
    """
    best = table[r, k + 1]
    h2 = 2.0 * cost[x, k]
    if table[r - 1, k + 1] + h2 == best:
        return STEP_C
    if slant_ok:
        u = h2 + cost[x - 1, k] + slant2
        if k + 1 < ndisp:
            if table[r - 1, k + 2] + cost[x, k + 1] + u == best:
                return STEP_D
        if k >= 1:
            if table[r - 2, k] + cost[x - 1, k - 1] + u == best:
                return STEP_E
    if allow_ab:
        if table[r - 1, k] + occ2 == best:
            return STEP_A
        if table[r, k + 2] + occ2 == best:
            return STEP_B
    return STEP_NONE


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
    ``table`` (shape >= (x_hi - x_lo + 3, ndisp + 2)) is padded so that every predecessor
    is a plain read: node ``(x, dmin + k)`` lives at ``table[x - x_lo + 2, k + 1]``; rows 0
    and 1 are the columns ``x_lo - 2`` and ``x_lo - 1`` (the virtual start), columns 0 and
    ``ndisp + 1`` lie outside the band (inf), and the virtual start cells ``j == j_lo - 1``
    hold 0. Each row is done in two passes: the steps from earlier columns (c, d, e, a),
    independent across disparities and branch-free (the compiler vectorizes it), then the
    b steps down the column, the one chain within a row. No step is stored: the backtrack
    finds it again (``_step_into``). Returns ``(n, total)``: the path (end to start) in
    ``path_x/k/s[:n]`` and its doubled cost; ``n == 0`` when no admissible path exists.
    """
    ndisp = cost.shape[1]
    inf = np.inf
    for kk in range(ndisp + 2):
        table[0, kk] = inf
        table[1, kk] = inf
    if not anchor_start:
        for k in range(ndisp):
            if x_lo - 1 - dmin - k >= j_lo - 1:
                table[1, k + 1] = 0.0
    k_start_cell = x_lo - j_lo - dmin if anchor_start else -9
    k_end_cell = x_hi - j_hi - dmin if anchor_end else -9
    for x in range(x_lo, x_hi + 1):
        r = x - x_lo + 2
        row = table[r]
        prev = table[r - 1]
        prev2 = table[r - 2]
        here = cost[x]
        for kk in range(ndisp + 2):
            row[kk] = inf
        k_hi = min(ndisp - 1, x - j_lo - dmin)
        k_lo = max(0, x - j_hi - dmin)
        if not anchor_start:
            k_virtual = x - dmin - (j_lo - 1)
            if 0 <= k_virtual < ndisp:
                row[k_virtual + 1] = 0.0
        # the anchored start and end cells, by their index in this row (-9: none here)
        k_start = k_start_cell if x == x_lo else -9
        k_end = k_end_cell if x == x_hi else -9
        slant_ok = five and x >= 1
        # pass 1: c, d, e, a; the first and last cells of the band would read outside
        # the cost rows, and the anchored end takes no a step: those go the slow way
        k1 = max(k_lo, 1)
        k2 = min(k_hi, ndisp - 2)
        if slant_ok:
            _earlier_steps5(row, prev, prev2, here, cost[x - 1], k1, k2, occ2, slant2)
        else:
            _earlier_steps3(row, prev, here, k1, k2, occ2)
        for k in (k_lo, k_hi, k_end):
            if k_lo <= k <= k_hi and (k < k1 or k > k2 or k == k_end):
                row[k + 1] = _slow_cell(
                    cost, table, x, r, k, ndisp, occ2, slant2, slant_ok, k != k_end
                )
        # pass 2: the b steps, down the column (k descending: (x, d+1) -> (x, d))
        # (a branch, not min(): b steps are rare, so the branch is predicted and the
        # chain of dependent additions that min() would make is speculated away)
        above = row[k_hi + 2] if k_hi >= k_lo else inf  # no cell of the band: no read
        for k in range(k_hi, k_lo - 1, -1):
            cell = row[k + 1]
            if k == k_start:
                cell = 0.0
                row[k + 1] = cell
            elif k != k_end:
                v = above + occ2
                if v < cell:
                    cell = v
                    row[k + 1] = cell
            above = cell

    # choose the end node
    end_x = -1
    end_k = -1
    total = inf
    last = x_hi - x_lo + 2
    if anchor_end:
        k = k_end_cell
        if 0 <= k < ndisp:
            total = table[last, k + 1]
            end_x = x_hi
            end_k = k
    else:
        # nodes with x == x_hi (j <= j_hi), then nodes with j == j_hi (x < x_hi)
        for k in range(ndisp):
            j = x_hi - dmin - k
            if j_lo <= j <= j_hi:
                v = table[last, k + 1]
                if v < total:
                    total = v
                    end_x = x_hi
                    end_k = k
        for k in range(ndisp):
            x = j_hi + dmin + k
            if x_lo <= x < x_hi:
                v = table[x - x_lo + 2, k + 1]
                if v < total:
                    total = v
                    end_x = x
                    end_k = k
    if not total < inf:
        return 0, inf

    # backtrack
    n = 0
    x = end_x
    k = end_k
    while True:
        r = x - x_lo + 2
        if anchor_start and x == x_lo and k == k_start_cell:
            s = STEP_START
        else:
            s = _step_into(
                cost,
                table,
                x,
                r,
                k,
                ndisp,
                occ2,
                slant2,
                five and x >= 1,
                not (anchor_end and x == x_hi and k == k_end_cell),
            )
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


def chunk_count(height: int) -> int:
    """Return how many chunks of rows a row-parallel driver deals out: four per thread.

    Never more than the rows, never fewer than one; ``_chunk_bounds`` sizes them.
    """
    return max(1, min(height, 4 * nb.get_num_threads()))


@nb.njit(cache=True)
def _chunk_bounds(height, nchunks, c):
    # sizes differ by at most one, spread evenly: the parallel loop hands each thread an
    # equal run of chunks, so ceil-sized chunks (and a short last one) would leave one
    # thread more work (36 bands in 8 chunks: 20 against 16)
    return c * height // nchunks, (c + 1) * height // nchunks


@nb.njit(parallel=True, cache=True)
def match_dsi_rows(
    left_p, right_p, dmin, ndisp, radius, bt, occ2, five, slant2, nchunks, disp, flags, total
):
    """Run the whole-scanline DP on every row; rows are the only parallel loop.

    ``bt``: the Birchfield-Tomasi cost (``row_costs_bt``) instead of the SAD of eq. 4.
    """
    height, width = disp.shape
    for c in nb.prange(nchunks):
        y0, y1 = _chunk_bounds(height, nchunks, c)
        cost = np.empty((width, ndisp), dtype=np.float64)
        vcol = np.empty((width, ndisp), dtype=np.int32)
        table = np.empty((width + 2, ndisp + 2), dtype=np.float64)
        path_x = np.empty(2 * width + 2, dtype=np.int64)
        path_k = np.empty(2 * width + 2, dtype=np.int64)
        path_s = np.empty(2 * width + 2, dtype=np.uint8)
        for y in range(y0, y1):
            _row_costs_any(left_p, right_p, y, dmin, ndisp, radius, vcol, cost, y > y0, bt)
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
                path_x,
                path_k,
                path_s,
            )
            apply_path(path_x, path_k, path_s, n, dmin, disp[y], flags[y])
            total[y] = t


@nb.njit(parallel=True, cache=True)
def match_block_rows(left_p, right_p, dmin, ndisp, radius, bt, nchunks, disp, flags, total):
    """Winner-take-all block matching: the disparity of least window cost per pixel.

    ``bt``: the Birchfield-Tomasi cost (``row_costs_bt``) instead of the SAD of eq. 4.
    """
    height, width = disp.shape
    for c in nb.prange(nchunks):
        y0, y1 = _chunk_bounds(height, nchunks, c)
        cost = np.empty((width, ndisp), dtype=np.float64)
        vcol = np.empty((width, ndisp), dtype=np.int32)
        for y in range(y0, y1):
            _row_costs_any(left_p, right_p, y, dmin, ndisp, radius, vcol, cost, y > y0, bt)
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
    if radius <= x < width - radius and radius <= j < width - radius:
        # the whole window inside both images (every feature candidate): exact integers
        si = 0
        for t in range(win):
            for c in range(win):
                di = np.int64(left_p[y + t, x + c]) - np.int64(right_p[y + t, j + c])
                si += di * di
        return float(si)
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
def window_variance_row(signal_p, y, radius, signal_steps, colsum, colsq, out, incremental):
    """Window variance (gray levels squared) of every pixel of row ``y``.

    ``signal_p`` is an integer signal padded by ``radius`` (edge replicated), like the
    inputs of ``row_costs``; the variance is that of the ``(2 radius + 1)^2`` padded window,
    as :func:`dcstereo.cost.window_variance` computes it, but from exact integer sums.
    ``colsum`` and ``colsq`` are int64 scratch vectors as long as a padded row, holding the
    vertical window sums of the signal and of its square; with ``incremental`` they must
    hold those of row ``y - 1`` (the previous call) and are updated by the row that enters
    the window and the one that leaves it, as ``row_costs`` does.
    """
    wp = signal_p.shape[1]
    width = wp - 2 * radius
    win = 2 * radius + 1
    n = win * win
    if incremental:
        top = y - 1
        bottom = y + 2 * radius
        for xp in range(wp):
            vb = np.int64(signal_p[bottom, xp])
            vt = np.int64(signal_p[top, xp])
            colsum[xp] += vb - vt
            colsq[xp] += vb * vb - vt * vt
    else:
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
def collect_pairs(pairs, counts, flag, flags):
    """Return the pairs ``(row, x_left, x_right, SER, VS)`` of rows stored compactly.

    Row ``y``'s ``counts[y]`` pairs are ``pairs[y, :counts[y]]`` (``x``, ``j``, SER, VS,
    float32, in increasing ``x``; ``_band_kernels.match_band_rows``' ``dc`` output).
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


@nb.njit(cache=True, inline="always")
def variance_similarity(var_left, var_right, vs_relative):
    """Return VS (eq. 3) of a candidate pair from its two window variances.

    ``|var_left - var_right|``, divided by ``var_left + var_right`` when ``vs_relative``
    (0 when both variances are 0).
    """
    vs = abs(var_left - var_right)
    if vs_relative:
        total = var_left + var_right
        vs = vs / total if total > 0 else 0.0
    return vs


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
    return ser, variance_similarity(var_left, var_right, vs_relative)


@nb.njit(cache=True, inline="always")
def _argmin_row(cost, x, k_lo, k_hi):
    """Index of the least cost of ``cost[x, k_lo..k_hi]`` (-1 when all are inf).

    Ties go to the smallest index. The least value is found first, by a reduction without
    branches, and then its first index: a running argmin would branch on every cell.
    """
    best = np.inf
    for k in range(k_lo, k_hi + 1):
        best = min(best, cost[x, k])
    if not best < np.inf:
        return -1
    k = k_lo
    while cost[x, k] != best:
        k += 1
    return k


@nb.njit(cache=True, inline="always")
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
    for k in range(0, best_k - 1):  # k <= best_k - 2
        second = min(second, cost[x, k])
    for k in range(best_k + 2, ndisp):
        second = min(second, cost[x, k])
    if best > 0:
        return second / best
    return np.inf if second > 0 else 1.0


NOT_MATCHED = -2  # ``wta_k`` entry not computed yet


@nb.njit(cache=True, inline="always")
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


@nb.njit(cache=True, inline="always")
def _edge_guarded(cost, p, best_k, edge_guard, wta_k, wta_ratio, uniqueness):
    """Apply the discontinuity guard of ``divide_row`` to candidate ``p`` matched at ``best_k``.

    True when the left pixels ``edge_guard`` columns to each side of ``p`` (clamped to the
    row) block-match within one disparity of ``best_k``, with uniqueness ratios of at
    least ``uniqueness``.
    """
    width = cost.shape[0]
    for x2 in (p - edge_guard, p + edge_guard):
        x2 = min(max(x2, 0), width - 1)
        k2 = block_match(cost, x2, wta_k, wta_ratio)
        if k2 < 0 or abs(k2 - best_k) > 1 or wta_ratio[x2] < uniqueness:
            return False
    return True


@nb.njit(cache=True)
def _pair_reliability(left_p, right_p, y, p, j, radius, var_l, var_r, signal_steps, vs_relative):
    """Return SER and VS (``reliability``) of the pair ``p <-> j`` of row ``y``.

    ``var_l`` and ``var_r`` are the window variances of the row in both views
    (``window_variance_row``).
    """
    ssd = window_ssd(left_p, right_p, y, p, j, radius) / float(signal_steps * signal_steps)
    return reliability(var_l[p], var_r[j], ssd, vs_relative)


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
        path_x,
        path_k,
        path_s,
    )
    apply_path(path_x, path_k, path_s, n, dmin, disp_row, flag_row)
    return t


@nb.njit(cache=True, inline="always")
def _tree_pull(tree_v, tree_i, node):
    """Segment tree node := the better of its children (larger value; ties: smaller index)."""
    left = 2 * node
    right = left + 1
    if tree_v[right] > tree_v[left] or (
        tree_v[right] == tree_v[left] and 0 <= tree_i[right] < tree_i[left]
    ):
        tree_v[node] = tree_v[right]
        tree_i[node] = tree_i[right]
    else:
        tree_v[node] = tree_v[left]
        tree_i[node] = tree_i[left]


@nb.njit(cache=True)
def _tree_set(tree_v, tree_i, size, pos, value):
    """Set leaf ``pos`` of the segment tree to ``value`` and update its ancestors."""
    node = size + pos
    tree_v[node] = value
    node //= 2
    while node >= 1:
        _tree_pull(tree_v, tree_i, node)
        node //= 2


@nb.njit(cache=True)
def _tree_best(tree_v, tree_i, size, lo, hi):
    """Index of the largest value in leaves ``lo..hi`` (ties: smallest index); -1 if none."""
    best_v = -np.inf
    best_i = -1
    if lo > hi:
        return -1
    left = lo + size
    right = hi + size + 1
    while left < right:
        if left & 1:
            v = tree_v[left]
            if v > best_v or (v == best_v and 0 <= tree_i[left] < best_i):
                best_v = v
                best_i = tree_i[left]
            left += 1
        if right & 1:
            right -= 1
            v = tree_v[right]
            if v > best_v or (v == best_v and 0 <= tree_i[right] < best_i):
                best_v = v
                best_i = tree_i[right]
        left //= 2
        right //= 2
    return best_i if best_v > -np.inf else -1


@nb.njit(cache=True, inline="always")
def _better(values, a, b):
    """Return the better of candidates ``a`` and ``b`` (larger value; ties: smaller index)."""
    if values[b] > values[a] or (values[b] == values[a] and b < a):
        return b
    return a


@nb.njit(cache=True)
def _sparse_build(values, n, sparse):
    """Sparse table of range maxima: ``sparse[l, i]`` the best of ``i .. i + 2**l - 1``."""
    for i in range(n):
        sparse[0, i] = i
    level = 1
    while (1 << level) <= n:
        half = 1 << (level - 1)
        for i in range(n - (1 << level) + 1):
            sparse[level, i] = _better(values, sparse[level - 1, i], sparse[level - 1, i + half])
        level += 1


@nb.njit(cache=True, inline="always")
def _sparse_best(values, sparse, lo, hi):
    """Return the best candidate of ``lo..hi`` (``lo <= hi``) from two table entries."""
    level = 0
    while (2 << level) <= hi - lo + 1:
        level += 1
    return _better(values, sparse[level, lo], sparse[level, hi - (1 << level) + 1])


@nb.njit(cache=True)
def divide_row(
    cost,
    left_p,
    right_p,
    y,
    radius,
    var_l,
    var_r,
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
    path_x,
    path_k,
    path_s,
    stack,
    tree_v,
    tree_i,
    iwork,
    fwork,
    disp_row,
    flag_row,
    partner_row,
    ser_row,
    vs_row,
):
    """Section 2 on one scanline: pin reliable feature pairs, fill between them.

    A work list (``stack``, shape (>= width + 2, 6)) of problems ``(A, C, B, D)``: match
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
    by ``fill_interval``. An accepted pair ``p <-> j`` writes ``disp_row[p] = p - j``,
    ``partner_row[p] = j``, ``ser_row[p]`` and ``vs_row[p]``. Returns the doubled total cost
    of the fill paths.

    Scratch space, so that a row allocates nothing: ``tree_v`` (float64) and ``tree_i``
    (int64) of length ``2 * size``, ``size`` the least power of two ``>= width``;
    ``iwork`` (int64, shape (6 + levels, width), ``2**(levels - 1) >= width``) and
    ``fwork`` (float64, shape (4, width)).
    """
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
    bt,
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
    doubled cost of the fill paths in ``total``. ``bt``: the Birchfield-Tomasi cost
    (``row_costs_bt``) instead of the SAD of eq. 4.
    """
    height, width = disp.shape
    wp = left_p.shape[1]
    for ch in nb.prange(nchunks):
        y0, y1 = _chunk_bounds(height, nchunks, ch)
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
        table = np.empty((width + 2, ndisp + 2), dtype=np.float64)
        path_x = np.empty(2 * width + 2, dtype=np.int64)
        path_k = np.empty(2 * width + 2, dtype=np.int64)
        path_s = np.empty(2 * width + 2, dtype=np.uint8)
        stack = np.empty((width + 2, 6), dtype=np.int64)
        size = 1
        while size < width:
            size *= 2
        tree_v = np.empty(2 * size, dtype=np.float64)
        tree_i = np.empty(2 * size, dtype=np.int64)
        levels = 1
        while (1 << (levels - 1)) < width:
            levels += 1
        iwork = np.empty((6 + levels, width), dtype=np.int64)
        fwork = np.empty((4, width), dtype=np.float64)
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
            total[y] = divide_row(
                cost,
                left_p,
                right_p,
                y,
                radius,
                var_l,
                var_r,
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
                path_x,
                path_k,
                path_s,
                stack,
                tree_v,
                tree_i,
                iwork,
                fwork,
                disp[y],
                flags[y],
                partner[y],
                ser[y],
                vs[y],
            )


# --------------------------------------------------------------------------- Birchfield-Tomasi


@nb.njit(cache=True, inline="always")
def _bt_cell2(l2, l_min, l_max, r2, r_min, r_max):
    """Twice the Birchfield-Tomasi dissimilarity of a left and a right pixel.

    From each pixel's doubled value and the least and largest of it and its two doubled
    half-pixel interpolations (:func:`_bt_row_bounds`; doubled, ``(I[x] + I[x +- 1]) / 2``
    is the integer ``I[x] + I[x +- 1]``).
    """
    d_lr = max(0, max(l2 - r_max, r_min - l2))
    d_rl = max(0, max(r2 - l_max, l_min - r2))
    return min(d_lr, d_rl)


@nb.njit(cache=True, inline="always")
def _bt_row_bounds(img_p, r, lo, hi, v2, v_min, v_max, reverse=False):
    """Fill a padded row's doubled values and their interpolation bounds, columns ``lo..hi``.

    ``v2`` the doubled value, ``v_min``/``v_max`` the least and largest of it and the two
    doubled half-pixel interpolations (a neighbour outside ``lo..hi``, the image's padded
    columns, is the pixel itself). ``reverse``: column ``xp``'s at ``len(v2) - 1 - xp``.
    """
    last = v2.shape[0] - 1
    for xp in range(lo, hi + 1):
        v = img_p[r, xp]
        twice = 2 * v
        minus = v + img_p[r, max(xp - 1, lo)]
        plus = v + img_p[r, min(xp + 1, hi)]
        i = last - xp if reverse else xp
        v2[i] = twice
        v_min[i] = min(twice, min(minus, plus))
        v_max[i] = max(twice, max(minus, plus))


@nb.njit(cache=True, inline="always")
def _bt_bounds_buffers(wp):
    """Six int32 rows of ``wp``: a view's values and bounds for two padded rows."""
    return (
        np.empty(wp, dtype=np.int32), np.empty(wp, dtype=np.int32),
        np.empty(wp, dtype=np.int32), np.empty(wp, dtype=np.int32),
        np.empty(wp, dtype=np.int32), np.empty(wp, dtype=np.int32),
    )  # fmt: skip


@nb.njit(cache=True)
def row_costs_bt(left_p, right_p, y, dmin, ndisp, radius, vcol, out, incremental):
    """Windowed Birchfield-Tomasi dissimilarity of row ``y`` into ``out[x, k]``.

    The contract of ``row_costs`` (same arguments, padded inputs, band, ``inf`` outside
    the image, window truncated at the image edges and rescaled to ``W`` columns, ``vcol``
    kept across the rows of a chunk with ``incremental``), with the per-pixel absolute
    difference replaced by the sampling-insensitive dissimilarity of Birchfield and
    Tomasi (1998): ``min(d_LR, d_RL)`` with
    ``d_LR = max(0, I_L(x) - I_R^max, I_R^min - I_L(x))``, where ``I_R^min/max`` are
    the least and largest of the linearly interpolated right values at ``j - 1/2``,
    ``j`` and ``j + 1/2`` (``j = x - d``), and ``d_RL`` symmetrically. At the image's
    first and last columns the missing neighbour is the pixel itself. ``vcol`` holds
    *doubled* dissimilarities (exact integers); ``out`` is halved at the end, so its
    units are those of ``row_costs`` (half-integers, still exact in float64).
    """
    wp = left_p.shape[1]
    width = wp - 2 * radius
    win = 2 * radius + 1
    lo = radius
    hi = radius + width - 1
    # each padded row's doubled values and their least and largest doubled half-pixel
    # interpolations, made once per row instead of once per cell
    l2, l_min, l_max, l2b, l_minb, l_maxb = _bt_bounds_buffers(wp)
    r2, r_min, r_max, r2b, r_minb, r_maxb = _bt_bounds_buffers(wp)
    if incremental:
        top = y - 1
        bottom = y + 2 * radius
        _bt_row_bounds(left_p, top, lo, hi, l2, l_min, l_max)
        _bt_row_bounds(right_p, top, lo, hi, r2, r_min, r_max, True)
        _bt_row_bounds(left_p, bottom, lo, hi, l2b, l_minb, l_maxb)
        _bt_row_bounds(right_p, bottom, lo, hi, r2b, r_minb, r_maxb, True)
        for x in range(width):
            xp = x + radius
            lb2, lbmin, lbmax = l2b[xp], l_minb[xp], l_maxb[xp]
            lt2, ltmin, ltmax = l2[xp], l_min[xp], l_max[xp]
            rbase = wp - 1 - (x - dmin + radius)  # reversed: k increasing reads forward
            k_lo = max(0, x - dmin - (width - 1))
            k_hi = min(ndisp - 1, x - dmin)
            for k in range(k_lo, k_hi + 1):
                i = rbase + k
                vcol[x, k] += _bt_cell2(
                    lb2, lbmin, lbmax, r2b[i], r_minb[i], r_maxb[i]
                ) - _bt_cell2(lt2, ltmin, ltmax, r2[i], r_min[i], r_max[i])
    else:
        for x in range(width):
            for k in range(ndisp):
                vcol[x, k] = 0
        for t in range(win):
            _bt_row_bounds(left_p, y + t, lo, hi, l2, l_min, l_max)
            _bt_row_bounds(right_p, y + t, lo, hi, r2, r_min, r_max, True)
            for x in range(width):
                xp = x + radius
                lv2, lvmin, lvmax = l2[xp], l_min[xp], l_max[xp]
                rbase = wp - 1 - (x - dmin + radius)
                k_lo = max(0, x - dmin - (width - 1))
                k_hi = min(ndisp - 1, x - dmin)
                for k in range(k_lo, k_hi + 1):
                    i = rbase + k
                    vcol[x, k] += _bt_cell2(lv2, lvmin, lvmax, r2[i], r_min[i], r_max[i])
    _window_sums(vcol, out, width, dmin, ndisp, radius, True)


@nb.njit(cache=True)
def _row_costs_any(left_p, right_p, y, dmin, ndisp, radius, vcol, out, incremental, bt):
    """``row_costs_bt`` when ``bt``, else ``row_costs`` (the windowed SAD of eq. 4)."""
    if bt:
        row_costs_bt(left_p, right_p, y, dmin, ndisp, radius, vcol, out, incremental)
    else:
        row_costs(left_p, right_p, y, dmin, ndisp, radius, vcol, out, incremental)


# --------------------------------------------------------------------------- confidence


@nb.njit(parallel=True, cache=True)
def confidence_rows(left_p, right_p, disparity, wanted, dmin, ndisp, radius, bt, nchunks, out):
    """Write into ``out`` the margin of each wanted pixel's disparity over its best rival.

    With ``C`` the row's window costs (``_row_costs_any``), ``c`` the least of ``C`` at
    ``floor(d)`` and ``ceil(d)``, and ``r`` the least ``C`` at the disparities two or more
    from ``d``: ``(r - c) / r``, at least -1 (0 when both are 0: a tie in a flat window);
    NaN when no rival has a cost. ``out`` holds NaN at the other pixels already.
    """
    height, width = disparity.shape
    for ch in nb.prange(nchunks):
        y0, y1 = _chunk_bounds(height, nchunks, ch)
        cost = np.empty((width, ndisp), dtype=np.float64)
        vcol = np.empty((width, ndisp), dtype=np.int32)
        for y in range(y0, y1):
            _row_costs_any(left_p, right_p, y, dmin, ndisp, radius, vcol, cost, y > y0, bt)
            for x in range(width):
                if not wanted[y, x]:
                    continue
                v = disparity[y, x] - dmin
                lo = int(np.floor(v))
                hi = int(np.ceil(v))
                c = min(cost[x, lo], cost[x, hi])
                # the rivals, |k - v| >= 2: k <= lo - 2 and k >= hi + 2 (for a whole, a
                # half and any fractional v alike), two runs without a test per cell
                r = np.inf
                for k in range(0, max(0, lo - 1)):
                    r = min(r, cost[x, k])
                for k in range(hi + 2, ndisp):
                    r = min(r, cost[x, k])
                if r == np.inf:
                    continue
                if r > 0.0:
                    out[y, x] = max((r - c) / r, -1.0)
                else:
                    out[y, x] = 0.0 if c == 0.0 else -1.0


# --------------------------------------------------------------------------- ground control points


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
    # longest strictly increasing subsequence in j, lexicographically first in the index:
    # ``length[i]``: the longest one that starts at candidate i
    length = np.empty(m, dtype=np.int64)
    longest = _run_lengths(cand_j, m, length, np.empty(m, dtype=np.int64))
    n = 0
    need = longest
    last_j = -1
    for i in range(m):
        if need == 0:
            break
        if length[i] == need and cand_j[i] > last_j:
            gcp_x[n] = cand_x[i]
            gcp_j[n] = cand_j[i]
            last_j = cand_j[i]
            n += 1
            need -= 1
    return n


@nb.njit(cache=True)
def gcp_row(
    cost,
    var_l,
    dmin,
    radius,
    occ2,
    uniqueness,
    var_floor,
    table,
    path_x,
    path_k,
    path_s,
    gcp_x,
    gcp_j,
    disp_row,
    flag_row,
    partner_row,
):
    """Run the three-step DP of one scanline, forced through its ground control points.

    ``select_gcps`` picks the points; between consecutive ones (and from the scanline's
    free start to the first, from the last to its free end) ``scanline_dp`` runs with
    ``five=False`` and anchored ends, as ``fill_interval`` does for ``dc`` (also between
    neighbouring points, so that the right pixels skipped between them pay their
    occlusions). Without any point it is exactly the whole-scanline ``dsi3`` DP. A point
    ``x <-> j`` writes ``disp_row[x] = x - j`` and ``partner_row[x] = j``. Returns the
    doubled path cost.
    """
    width = cost.shape[0]
    n = select_gcps(cost, var_l, dmin, radius, uniqueness, var_floor, gcp_x, gcp_j)
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
                occ2,
                False,
                0.0,
                a if anchor_start else 0,
                c if anchor_end else width - 1,
                b if anchor_start else 0,
                e if anchor_end else width - 1,
                anchor_start,
                anchor_end,
                table,
                path_x,
                path_k,
                path_s,
            )
            apply_path(path_x, path_k, path_s, n_path, dmin, disp_row, flag_row)
            total += t
        if i < n:
            disp_row[c] = c - e
            flag_row[c] = 0
            partner_row[c] = e
        a = c
        b = e
    return total


@nb.njit(parallel=True, cache=True)
def match_gcp_rows(
    left_p,
    right_p,
    dmin,
    ndisp,
    radius,
    bt,
    occ2,
    uniqueness,
    var_floor,
    signal_steps,
    nchunks,
    disp,
    flags,
    total,
    partner,
):
    """``dsi3`` through ground control points on every row (``gcp_row``); rows in parallel.

    ``partner[y, x] = j`` for each control point ``(y, x) <-> (y, j)``, -1 elsewhere.
    """
    height, width = disp.shape
    wp = left_p.shape[1]
    for ch in nb.prange(nchunks):
        y0, y1 = _chunk_bounds(height, nchunks, ch)
        cost = np.empty((width, ndisp), dtype=np.float64)
        vcol = np.empty((width, ndisp), dtype=np.int32)
        colsum = np.empty(wp, dtype=np.int64)
        colsq = np.empty(wp, dtype=np.int64)
        var_l = np.empty(width, dtype=np.float64)
        table = np.empty((width + 2, ndisp + 2), dtype=np.float64)
        path_x = np.empty(2 * width + 2, dtype=np.int64)
        path_k = np.empty(2 * width + 2, dtype=np.int64)
        path_s = np.empty(2 * width + 2, dtype=np.uint8)
        gcp_x = np.empty(width, dtype=np.int64)
        gcp_j = np.empty(width, dtype=np.int64)
        for y in range(y0, y1):
            _row_costs_any(left_p, right_p, y, dmin, ndisp, radius, vcol, cost, y > y0, bt)
            window_variance_row(left_p, y, radius, signal_steps, colsum, colsq, var_l, y > y0)
            for x in range(width):
                partner[y, x] = -1
            for x in range(width):
                disp[y, x] = np.nan
                flags[y, x] = FLAG_BORDER
            total[y] = gcp_row(
                cost,
                var_l,
                dmin,
                radius,
                occ2,
                uniqueness,
                var_floor,
                table,
                path_x,
                path_k,
                path_s,
                gcp_x,
                gcp_j,
                disp[y],
                flags[y],
                partner[y],
            )

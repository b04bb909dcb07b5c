"""Section 2's measures of a feature pair: strength, reliability (eq. 2, 3), uniqueness.

The divide-and-conquer search of section 2 (:mod:`.divide`, and its band form
:mod:`.divide_bands`) picks the candidate of highest window variance (the feature
strength, ``window_variance_row``), block-matches it (``block_match``, the least window
cost, with ``uniqueness_ratio``) and accepts the pair when it is reliable: the signal
variance to matching error ratio ``SER`` (eq. 2) and the variance similarity ``VS``
(eq. 3) of ``reliability``, from the window SSD (``window_ssd``) and the two variances.
Also here: the structures the search finds the strongest candidate of an interval with
(a sparse table of range maxima, a segment tree).
"""

import numba as nb
import numpy as np

from dcstereo._vector.simd import _floor_log2


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
        out[x] = _window_variance(s, q, n, norm)


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
def _window_variance(sm, sq, n, norm):
    """Return a window's variance from its integer sum ``sm`` and sum of squares ``sq``.

    ``n`` pixels, ``norm`` the float64 ``(n * steps)**2``: the int64 numerator of
    ``features.window_variance_row``, bit for bit (``band_lane_variance``'s float64 one
    equals it wherever it is taken; the search makes the right view's from the SSD's sums).
    """
    return float(n * sq - sm * sm) / norm


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
            # a select, not _better's branches: the right half's index is the larger
            a = sparse[level - 1, i]
            b = sparse[level - 1, i + half]
            sparse[level, i] = b if values[b] > values[a] else a
        level += 1


@nb.njit(cache=True, inline="always")
def _sparse_best(values, sparse, lo, hi):
    """Return the best candidate of ``lo..hi`` (``lo <= hi``) from two table entries."""
    level = _floor_log2(hi - lo + 1)
    return _better(values, sparse[level, lo], sparse[level, hi - (1 << level) + 1])

"""The scanline DP of section 3: the cheapest path across the DSI of one scanline (eq. 5).

One row at a time: ``scanline_dp`` runs the five-step model of eq. 5 (steps a, b, c, d, e;
see ``../shared/paper/NOTES.md``, "Section 3") or the classic three steps of Intille and
Bobick (a, b, c) over the banded DSI of one scanline segment, free or anchored at either
end, and backtracks the path; ``apply_path`` writes its disparities and occlusions. The
band form, ``BAND_ROWS`` rows in lockstep, is :mod:`.band_dp`, bit for bit the same.

Conventions (``docs`` and ``../shared/paper/NOTES.md``):

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

from dcstereo._records import PathScratch
from dcstereo.result import FLAG_BORDER, FLAG_OCCLUDED  # noqa: F401 (the kernels' flags)

# Step codes stored per DP node (how the node was entered).
STEP_NONE = 0  # unreachable
STEP_C = 1  # match (i-1, j-1) -> (i, j)
STEP_A = 2  # left pixel i occluded: (i-1, j) -> (i, j)
STEP_B = 3  # right pixel j occluded: (i, j-1) -> (i, j)
STEP_D = 4  # (i-1, j-2) -> (i, j): right j-1 between left i-1 and i
STEP_E = 5  # (i-2, j-1) -> (i, j): left i-1 between right j-1 and j (half-pixel)
STEP_START = 6  # the anchored start node of a segment


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
def scanline_dp(cost, dmin, step_costs, x_lo, x_hi, j_lo, j_hi, anchor_start, anchor_end, path):
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

    ``step_costs`` (``records.StepCosts``): the occlusion cost ``occ2``, the d and e steps'
    ``slant2``, and ``five``, the five-step model (a, b, c, d, e) over the classic three.
    ``path`` (``records.PathScratch``, ``path_scratch``): ``table`` (shape
    >= (x_hi - x_lo + 3, ndisp + 2)) is padded so that every predecessor
    is a plain read: node ``(x, dmin + k)`` lives at ``table[x - x_lo + 2, k + 1]``; rows 0
    and 1 are the columns ``x_lo - 2`` and ``x_lo - 1`` (the virtual start), columns 0 and
    ``ndisp + 1`` lie outside the band (inf), and the virtual start cells ``j == j_lo - 1``
    hold 0. Each row is done in two passes: the steps from earlier columns (c, d, e, a),
    independent across disparities and branch-free (the compiler vectorizes it), then the
    b steps down the column, the one chain within a row. No step is stored: the backtrack
    finds it again (``_step_into``). Returns ``(n, total)``: the path (end to start) in
    ``path.path_x/k/s[:n]`` and its doubled cost; ``n == 0`` when no admissible path
    exists.
    """
    occ2, slant2, five = step_costs
    table, path_x, path_k, path_s = path
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
def apply_path(path, n, dmin, disp_row, flag_row):
    """Write the left-image disparities and occlusions of a path ``scanline_dp`` backtracked.

    ``path``: its ``records.PathScratch`` (``n`` nodes). Pixels the path does not consume
    keep what the caller put there (border).
    """
    path_x, path_k, path_s = path.path_x, path.path_k, path.path_s
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


@nb.njit(cache=True)
def path_scratch(width, ndisp):
    """Return the ``records.PathScratch`` of ``scanline_dp`` for rows of ``width`` pixels."""
    return PathScratch(
        np.empty((width + 2, ndisp + 2), dtype=np.float64),
        np.empty(2 * width + 2, dtype=np.int64),
        np.empty(2 * width + 2, dtype=np.int64),
        np.empty(2 * width + 2, dtype=np.uint8),
    )

"""The method of Redert et al. [6] (``redert``): sheared-window costs, the DP, the row driver.

The orientation-and-occlusion DP the paper compares with in section 4 (Fig. 4),
reconstructed (``../shared/paper/NOTES.md``, "[6]"; :mod:`dcstereo.methods.redert` describes the
model): the DP state carries a disparity and a surface orientation (a disparity slope),
the right image's window is sheared by the orientation, and occlusions are states.

Conventions (shared with :mod:`.dp` and :mod:`.costs`):

* A left pixel ``x`` matches the right pixel ``j = x - d``; ``d = dmin + k``.
* ``steps`` is the sampling resolution: right-image positions and disparities inside a
  segment are multiples of ``1 / steps`` pixel (a power of two, 1 to 16).
* Orientations are disparity slopes in units of ``1 / steps`` pixel per pixel: ``oq[o]``
  is the integer ``steps * slope`` of orientation index ``o``; ``oq[o]`` is 0 or divides
  ``steps`` (slopes ``0, +-1/L``).
* The matching signal is an integer; right-image samples at ``1 / steps`` positions
  are linear interpolations ``(steps - f) * R[q] + f * R[q + 1]`` (``f`` steps), compared
  with ``steps * L``, so every window cost is an exact integer in units of ``1 / steps``
  signal step (``steps`` times the cost of ``costs.row_costs`` at slope 0).
* ``node[x, k, o]`` is the cost of matching left pixel ``x`` alone at disparity
  ``dmin + k`` with orientation ``o``; ``seg[x, k, o]`` the cost of the segment of
  orientation ``o`` ending at that node (see :func:`sheared_costs`); ``inf`` where the
  right pixel ``x - d`` (or the segment's start node) is outside the image.
* DP states per band node ``(x, k)``: ``0..O-1`` matched with orientation ``o``, then
  left pixel ``x`` occluded and right pixel ``j`` occluded, one state per position in a
  run of occlusions up to ``run_cap``, and two for a run from the scanline's start (see
  :func:`scanline_dp`).
"""

import numba as nb
import numpy as np

from dcstereo._records import RedertScratch
from dcstereo.result import FLAG_BORDER, FLAG_OCCLUDED
from dcstereo.scanline.rows import chunk_bounds

# Back-pointer code of an unreachable state (the others: see ``scanline_dp``).
CODE_NONE = 0


# --------------------------------------------------------------------------- costs


@nb.njit(cache=True)
def _right_samples(right_p, t, radius, steps, out):
    """Right row ``t`` (padded) at every ``1 / steps`` position: ``out[qq]``, ``qq = 0..top``.

    ``out[steps q0 + f] = (steps - f) R[t, q0] + f R[t, q0 + 1]``, the interpolation that
    :func:`sample_columns` compares with ``steps * L``.
    """
    width = right_p.shape[1] - 2 * radius
    for q0 in range(width):
        here = right_p[t, q0 + radius]
        out[steps * q0] = steps * here
        if q0 + 1 < width:
            after = right_p[t, q0 + 1 + radius]
            for f in range(1, steps):
                out[steps * q0 + f] = (steps - f) * here + f * after


@nb.njit(cache=True)
def _add_window_row(left_p, right_p, t, radius, steps, e_lo, sign, samples, out):
    """Add ``sign`` times window row ``t``'s absolute differences to the valid ``out`` cells."""
    width = left_p.shape[1] - 2 * radius
    ne = out.shape[1]
    top = steps * (width - 1)
    _right_samples(right_p, t, radius, steps, samples)
    for c in range(width):
        a = steps * left_p[t, c + radius]
        base = steps * c - e_lo  # the right position of cell m is base - m
        m_lo = max(0, base - top)
        m_hi = min(ne, base + 1)
        if sign > 0:
            for m in range(m_lo, m_hi):
                out[c, m] += abs(a - samples[base - m])
        else:
            for m in range(m_lo, m_hi):
                out[c, m] -= abs(a - samples[base - m])


@nb.njit(cache=True)
def sample_columns(left_p, right_p, y, radius, steps, e_lo, out):
    """Vertical window sums of the interpolated absolute difference, for row ``y``.

    ``out[c, m]`` with disparity ``e / steps``, ``e = e_lo + m``: the left column ``c``
    against the right position ``q = c - e / steps``, summed over the ``2 * radius + 1``
    window rows, ``sum_t |steps L[y + t, c] - ((steps - f) R[y + t, q0] + f R[y + t, q0 + 1])|``
    with ``steps q = steps q0 + f``; ``-1`` where ``q`` is outside ``[0, width - 1]``.
    ``left_p``/``right_p`` are the signals padded by ``radius`` (edge replicated).
    """
    width = left_p.shape[1] - 2 * radius
    ne = out.shape[1]
    top = steps * (width - 1)
    samples = np.empty(top + 1, dtype=np.int64)
    for c in range(width):
        base = steps * c - e_lo
        for m in range(ne):
            qq = base - m
            out[c, m] = 0 if 0 <= qq <= top else -1
    for t in range(y, y + 2 * radius + 1):
        _add_window_row(left_p, right_p, t, radius, steps, e_lo, 1, samples, out)


@nb.njit(cache=True)
def slide_columns(left_p, right_p, y, radius, steps, e_lo, out):
    """Move :func:`sample_columns`' sums from row ``y - 1`` (in ``out``) to row ``y``.

    The window row that enters is added and the one that leaves subtracted: two rows of
    absolute differences instead of ``2 * radius + 1``, the same integers.
    """
    width = left_p.shape[1] - 2 * radius
    samples = np.empty(steps * (width - 1) + 1, dtype=np.int64)
    _add_window_row(left_p, right_p, y + 2 * radius, radius, steps, e_lo, 1, samples, out)
    _add_window_row(left_p, right_p, y - 1, radius, steps, e_lo, -1, samples, out)


@nb.njit(cache=True)
def pixel_cost(columns, e_lo, x, e, q, radius):
    """Sheared window cost of left pixel ``x`` at disparity ``e / steps``, slope ``q / steps``.

    The left window column ``x + s`` (``s = -radius..radius``) is compared with the right
    position ``x + s - (e + q s) / steps`` (``columns`` from :func:`sample_columns`).
    Like ``costs.row_costs``, the window is truncated to the columns whose left and
    right positions both lie inside the images and the sum rescaled to the full window
    (``* W / columns used``); ``inf`` when the centre position is outside.
    """
    width = columns.shape[0]
    win = 2 * radius + 1
    if columns[x, e - e_lo] < 0:
        return np.inf
    total = 0
    used = 0
    for s in range(-radius, radius + 1):
        c = x + s
        if c < 0 or c >= width:
            continue
        v = columns[c, e + q * s - e_lo]
        if v < 0:
            continue
        total += v
        used += 1
    if used == win:
        return float(total)
    return total * win / used


@nb.njit(cache=True)
def segment_shape(q, steps):
    """Return ``(length, delta)`` of a segment of slope ``q / steps`` (``q`` 0 or a divisor).

    A segment joins integer nodes ``(x - length, d - delta)`` and ``(x, d)``: slope 0 is
    one pixel at constant disparity, slope ``+-1/L`` spans ``L`` pixels and one disparity.
    """
    if q == 0:
        return 1, 0
    a = abs(q)
    return steps // a, 1 if q > 0 else -1


@nb.njit(cache=True)
def _line_value(ring, mask, c, m):
    """Return a line prefix at column ``c``, cell ``m``: 0 before column 0 or outside the cells."""
    if c < 0 or m < 0 or m >= ring.shape[1]:
        return 0
    return ring[c & mask, m]


@nb.njit(cache=True)
def sheared_costs(columns, e_lo, steps, dmin, oq, radius, node, seg):
    """Node and segment costs of one row from :func:`sample_columns`.

    ``node[x, k, o]``: pixel ``x`` alone at integer disparity ``d = dmin + k`` with the
    window sheared by orientation ``o`` (how a surface starts after an occlusion).
    ``seg[x, k, o]``: the segment of orientation ``o`` that ends at node ``(x, d)``, the
    sum over its pixels ``p = x - L + 1 .. x`` of the pixel costs at the interpolated
    disparity ``d - delta + slope * (p - x + L)``; ``inf`` when the segment's start node
    ``(x - L, d - delta)`` is not a node of the band inside both images.

    Pixel ``p`` of a segment sits at disparity ``(e0 + q (p - x0)) / steps`` with its
    window sheared by the same slope, so every column value it reads lies on one line
    of ``columns``, cell ``m`` at column ``c`` followed by cell ``m + q`` at ``c + 1``.
    Along each line the kernel keeps two running sums, ``P`` of the column values and
    ``Q`` of ``P``: a window is a difference of two ``P`` and a segment (the sum of its
    pixels' windows) one of four ``Q``, whatever its length; both are exact integers.
    The sums live in a ring of the last columns (enough for the longest segment and its
    windows). Where a window is truncated (a column outside either image; the right
    position only grows along a line, so its two end columns tell) the pixels are summed
    one by one with :func:`pixel_cost`.
    """
    width, ndisp, norient = node.shape
    ne = columns.shape[1]
    longest = 1
    for o in range(norient):
        longest = max(longest, segment_shape(oq[o], steps)[0])
    span = longest + 2 * radius + 2  # the columns x - L - r - 1 .. x + r
    size = 1
    while size < min(span, width):
        size *= 2
    mask = size - 1
    ring_p = np.empty((size, ne), dtype=np.int64)
    ring_q = np.empty((size, ne), dtype=np.int64)
    # flat views and unsigned offsets: numba checks a signed index for wraparound,
    # which keeps LLVM from vectorizing the running sums
    flat_c = columns.reshape(-1)
    flat_p = ring_p.reshape(-1)
    flat_q = ring_q.reshape(-1)
    for o in range(norient):
        q = oq[o]
        length, delta = segment_shape(q, steps)
        # cells whose line comes from a cell of the previous column (none when the slope
        # steps over every cell: |q| >= ne)
        m_from = np.uint64(min(ne, max(0, q)))
        m_to = np.uint64(max(min(ne, max(0, q)), min(ne, ne + q)))
        for c in range(width + radius):
            if c < width:
                o_c = np.uint64(c * ne)
                o_row = np.uint64((c & mask) * ne)
                if c == 0:
                    m_from_c = m_to  # no previous column: every line starts here
                else:
                    m_from_c = m_from
                for i in range(np.uint64(0), m_from_c):
                    flat_p[o_row + i] = flat_c[o_c + i]
                    flat_q[o_row + i] = flat_c[o_c + i]
                if c > 0:
                    o_prev = np.uint64(((c - 1) & mask) * ne) - np.uint64(q)
                    for i in range(m_from, m_to):
                        v = flat_c[o_c + i] + flat_p[o_prev + i]
                        flat_p[o_row + i] = v
                        flat_q[o_row + i] = v + flat_q[o_prev + i]
                for i in range(m_to, np.uint64(ne)):
                    flat_p[o_row + i] = flat_c[o_c + i]
                    flat_q[o_row + i] = flat_c[o_c + i]
            x = c - radius
            if x < 0:
                continue
            whole = x - radius >= 0 and x + radius < width
            for k in range(ndisp):
                d = dmin + k
                if not 0 <= x - d < width:
                    node[x, k, o] = np.inf
                    seg[x, k, o] = np.inf
                    continue
                mx = steps * d - e_lo  # the node's cell at column x
                if (
                    whole
                    and columns[x - radius, mx - q * radius] >= 0
                    and columns[x + radius, mx + q * radius] >= 0
                ):
                    inner = ring_p[(x + radius) & mask, mx + q * radius]
                    inner -= _line_value(ring_p, mask, x - radius - 1, mx - q * (radius + 1))
                    here = float(inner)
                else:
                    here = pixel_cost(columns, e_lo, x, steps * d, q, radius)
                node[x, k, o] = here
                x0 = x - length
                k0 = k - delta
                if x0 < 0 or k0 < 0 or k0 >= ndisp or x0 - (d - delta) < 0:
                    seg[x, k, o] = np.inf
                    continue
                if length == 1:
                    seg[x, k, o] = here
                    continue
                lo = x0 + 1 - radius
                if (
                    lo >= 0
                    and x + radius < width
                    and columns[lo, mx - q * (x - lo)] >= 0
                    and columns[x + radius, mx + q * radius] >= 0
                ):
                    # sum over p of P(p + r) - P(p - r - 1), p = x0 + 1 .. x
                    total = ring_q[(x + radius) & mask, mx + q * radius]
                    total -= _line_value(ring_q, mask, x0 + radius, mx - q * (length - radius))
                    total -= _line_value(ring_q, mask, x - radius - 1, mx - q * (radius + 1))
                    total += _line_value(
                        ring_q, mask, x0 - radius - 1, mx - q * (length + radius + 1)
                    )
                    seg[x, k, o] = float(total)
                    continue
                e0 = steps * (d - delta)
                total_f = here
                for p in range(x0 + 1, x):
                    total_f += pixel_cost(columns, e_lo, p, e0 + q * (p - x0), q, radius)
                seg[x, k, o] = total_f


# --------------------------------------------------------------------------- DP


@nb.njit(cache=True)
def scanline_dp(node, seg, dmin, model, work):
    """Cheapest path of one whole scanline through the (x, d, orientation) states.

    ``model`` (``records.RedertModel``): ``steps``, the slopes ``oq`` and the costs
    ``occ``, ``discount``, ``run_cap``, ``orient``, ``slant`` below; ``work``
    (``records.RedertScratch``): ``table``, ``back`` and the path ``path_x/k/st``.

    Moves into band node ``(x, k)`` (``j = x - dmin - k``; DSI cell ``(x, j)``):

    * matched with orientation ``o2`` by a segment (cost ``seg[x, k, o2]``, plus ``slant``
      when the segment changes the disparity): from matched ``o1`` at
      ``(x - L, k - delta)`` (``segment_shape``), plus ``orient`` when ``o1 != o2``;
    * matched with orientation ``o2`` by a diagonal step (cost ``node[x, k, o2]``): from an
      occlusion state, or the virtual start, at ``(x - 1, k)``: a new surface, any
      orientation, no orientation cost;
    * left pixel ``x`` occluded: from any state at ``(x - 1, k - 1)``;
    * right pixel ``j`` occluded: from any state at ``(x, k + 1)``.

    An occluded pixel costs ``occ``, less ``discount`` for the 2nd to ``run_cap``-th pixel
    of a run of occlusions (consecutive occlusion states, left and right alike) entered
    from a matched state. A run from the virtual start (the scanline's border, not a jump
    between surfaces) pays ``occ`` for every pixel, in two states of its own; with
    ``run_cap == 1`` or ``discount == 0`` every occluded pixel costs ``occ`` and the
    border runs share the ordinary states (the model of ``dsi3``).

    Virtual start nodes (``x == -1`` or ``j == -1``, in the band) cost 0 and are left
    by a diagonal match or an occlusion. The path ends at the cheapest state of a node
    with ``x == width - 1`` or ``j == width - 1``. Returns ``(n, total)``: the path (end
    to start) in ``path_x/k/st[:n]``, one entry per node; ``n == 0`` when no path exists.

    States (``N = run_cap``): ``0..O-1`` matched with orientation ``o``; ``O + c - 1``
    left pixel occluded and ``O + N + c - 1`` right pixel occluded, the ``c``-th pixel of
    its run (``c == N``: the ``N``-th or a later one); ``O + 2 N`` / ``O + 2 N + 1`` left /
    right pixel occluded in a border run. Back-pointer codes: a matched state entered by
    a segment stores ``1 + o1``; any other state stores ``1 + state`` of its predecessor,
    or ``O + 2 N + 3`` (the virtual start).

    ``table`` (float64, ``(ring, D, states)``) holds the values of the last ``ring``
    columns, column ``x`` in slot ``x % ring``: at least the longest segment's length plus
    one (or the width); ``back`` (uint8, ``(W, D, states)``) every column's.
    """
    steps, oq, occ, discount, run_cap, orient, slant = model
    table, back, path_x, path_k, path_st = work
    width, ndisp, norient = node.shape
    s_left = norient
    s_right = norient + run_cap
    s_left_border = norient + 2 * run_cap
    s_right_border = s_left_border + 1
    nstates = s_left_border + 2
    start_code = nstates + 1
    border_runs = run_cap > 1 and discount > 0.0
    inf = np.inf
    lengths = np.empty(norient, dtype=np.int64)
    deltas = np.empty(norient, dtype=np.int64)
    longest = 1
    for o in range(norient):
        lengths[o], deltas[o] = segment_shape(oq[o], steps)
        longest = max(longest, lengths[o])
    # the table keeps the last `ring` columns: column x in slot x % ring (what a node reads
    # lies at most the longest segment back)
    ring = table.shape[0]
    if ring < min(width, longest + 1):
        raise ValueError("scanline_dp: the table must keep the longest segment's columns")
    # per node, over its matched states: the least cost and the first state that has it,
    # and the first state of least cost plus the orientation change (its value is
    # least + orient: adding a constant keeps the order, rounded too, but can tie two
    # states): what a segment into a later node and the first pixel of an occlusion run read
    least = np.empty((ring, ndisp), dtype=np.float64)
    least_code = np.empty((ring, ndisp), dtype=np.int64)
    turn_code = np.empty((ring, ndisp), dtype=np.int64)
    # the cheapest state of each node with j == width - 1 and x < width - 1 (a path's
    # possible end), kept as its column finishes: the ring may no longer hold it
    end_value = np.full(ndisp, inf)
    end_state = np.full(ndisp, -1, dtype=np.int64)
    slots = np.empty(norient, dtype=np.int64)  # the slot of each segment's start column
    for x in range(width):
        sx = x % ring
        s1 = (x - 1) % ring  # read only where x >= 1
        for o in range(norient):
            slots[o] = (x - lengths[o]) % ring  # read only where the segment starts inside
        for k in range(ndisp):
            for st in range(nstates):
                table[sx, k, st] = inf
                back[x, k, st] = CODE_NONE
            least[sx, k] = inf
            least_code[sx, k] = CODE_NONE
            turn_code[sx, k] = CODE_NONE
        k_hi = min(ndisp - 1, x - dmin)
        k_lo = max(0, x - (width - 1) - dmin)
        for k in range(k_hi, k_lo - 1, -1):
            j = x - dmin - k
            # diagonal predecessor (x - 1, k): occlusion states or the virtual start
            diag_best = inf
            diag_code = CODE_NONE
            if x - 1 == -1 or j - 1 == -1:
                diag_best = 0.0
                diag_code = start_code
            else:
                for st in range(s_left, nstates):
                    if table[s1, k, st] < diag_best:
                        diag_best = table[s1, k, st]
                        diag_code = 1 + st
            for o2 in range(norient):
                best = inf
                code = CODE_NONE
                if node[x, k, o2] < inf and diag_code != CODE_NONE:
                    best = diag_best + node[x, k, o2]
                    code = diag_code
                here = seg[x, k, o2]
                if here < inf:
                    delta = deltas[o2]
                    if delta != 0:
                        here += slant
                    sp = slots[o2]
                    pk = k - delta
                    # cheapest matched predecessor, a change of orientation charged
                    v = table[sp, pk, o2]
                    c = 1 + o2
                    turn = least[sp, pk] + orient
                    if turn < v:
                        v = turn
                        c = turn_code[sp, pk]
                    if v + here < best:
                        best = v + here
                        code = c
                table[sx, k, o2] = best
                back[x, k, o2] = code
            low = inf
            low_turn = inf
            for o in range(norient):
                if table[sx, k, o] < low:
                    low = table[sx, k, o]
                    least_code[sx, k] = 1 + o
                if table[sx, k, o] + orient < low_turn:
                    low_turn = table[sx, k, o] + orient
                    turn_code[sx, k] = 1 + o
            least[sx, k] = low
            # left pixel x occluded, from (x - 1, k - 1); right pixel j occluded, from
            # (x, k + 1): the same rules
            for side in range(2):
                if side == 0:
                    if k < 1:
                        continue
                    at_start = x - 1 == -1
                    sp, pk, base, s_border = s1, k - 1, s_left, s_left_border
                else:
                    if k + 1 >= ndisp:
                        continue
                    at_start = j - 1 == -1
                    sp, pk, base, s_border = sx, k + 1, s_right, s_right_border
                if not border_runs:
                    s_border = base
                if at_start:
                    table[sx, k, s_border] = occ
                    back[x, k, s_border] = start_code
                    continue
                if border_runs:
                    best = inf
                    code = CODE_NONE
                    for st in (s_left_border, s_right_border):
                        if table[sp, pk, st] < best:
                            best = table[sp, pk, st]
                            code = 1 + st
                    if code != CODE_NONE:
                        table[sx, k, s_border] = best + occ
                        back[x, k, s_border] = code
                for count in range(1, run_cap + 1):
                    best = inf
                    code = CODE_NONE
                    if count == 1:
                        # the first pixel of a run, after a match (run_cap 1: every
                        # occluded pixel, from any state, as in dsi3)
                        best = least[sp, pk]
                        code = least_code[sp, pk]
                        if run_cap == 1:
                            for st in range(norient, norient + 2):
                                if table[sp, pk, st] < best:
                                    best = table[sp, pk, st]
                                    code = 1 + st
                        best += occ
                    else:
                        # the run goes on: a discounted pixel, the count-th of the run
                        for st in (s_left + count - 2, s_right + count - 2):
                            w = table[sp, pk, st] + (occ - discount)
                            if w < best:
                                best = w
                                code = 1 + st
                        if count == run_cap:  # or a pixel beyond the discounted ones
                            for st in (s_left + count - 1, s_right + count - 1):
                                w = table[sp, pk, st] + occ
                                if w < best:
                                    best = w
                                    code = 1 + st
                    if code != CODE_NONE:
                        table[sx, k, base + count - 1] = best
                        back[x, k, base + count - 1] = code
        k = x - dmin - (width - 1)  # the node of this column with j == width - 1
        if x < width - 1 and 0 <= k < ndisp:
            for st in range(nstates):
                if table[sx, k, st] < end_value[k]:
                    end_value[k] = table[sx, k, st]
                    end_state[k] = st

    # the end: nodes with x == width - 1, then nodes with j == width - 1 (x < width - 1)
    end_x = -1
    end_k = -1
    end_st = -1
    total = inf
    last = (width - 1) % ring
    for k in range(ndisp):
        x = width - 1
        j = x - dmin - k
        if 0 <= j <= width - 1:
            for st in range(nstates):
                if table[last, k, st] < total:
                    total = table[last, k, st]
                    end_x, end_k, end_st = x, k, st
    for k in range(ndisp):
        x = width - 1 + dmin + k
        if 0 <= x < width - 1 and end_value[k] < total:
            total = end_value[k]
            end_x, end_k, end_st = x, k, end_state[k]
    if not total < inf:
        return 0, inf

    # backtrack
    n = 0
    x, k, st = end_x, end_k, end_st
    while True:
        path_x[n] = x
        path_k[n] = k
        path_st[n] = st
        n += 1
        code = back[x, k, st]
        if code == start_code:
            break
        if st < norient:
            if code > norient:  # diagonal, from an occlusion state
                x, st = x - 1, code - 1
            else:
                length, delta = segment_shape(oq[st], steps)
                x, k, st = x - length, k - delta, code - 1
        elif st < s_right or st == s_left_border:
            x, k, st = x - 1, k - 1, code - 1
        else:
            k, st = k + 1, code - 1
    return n, total


@nb.njit(cache=True)
def apply_path(work, n, dmin, model, disp_row, flag_row, orient_row):
    """Write disparities, occlusions and orientations (slopes) of a backtracked path.

    The path of ``scanline_dp`` in ``work`` (``n`` nodes), its ``model``.

    A node entered by a segment writes the segment's pixels (interpolated disparities,
    multiples of ``1 / steps``); a node entered diagonally writes its own pixel; a left
    occlusion state (``O .. O + run_cap - 1`` or ``O + 2 run_cap``, see
    :func:`scanline_dp`) marks its pixel occluded. The path is stored end to start, so
    entry ``i + 1`` is the node before entry ``i``.
    """
    steps, oq, run_cap = model.steps, model.oq, model.run_cap
    path_x, path_k, path_st = work.path_x, work.path_k, work.path_st
    norient = oq.shape[0]
    for i in range(n):
        x = path_x[i]
        st = path_st[i]
        if st < norient:
            d = dmin + path_k[i]
            q = oq[st]
            length = 1
            if i + 1 < n and path_st[i + 1] < norient:  # entered by a segment
                length = segment_shape(q, steps)[0]
            for p in range(x - length + 1, x + 1):
                disp_row[p] = d + q * (p - x) / steps
                flag_row[p] = 0
                orient_row[p] = q / steps
        elif st < norient + run_cap or st == norient + 2 * run_cap:  # left pixel occluded
            disp_row[x] = np.nan
            flag_row[x] = FLAG_OCCLUDED


# --------------------------------------------------------------------------- driver


@nb.njit(parallel=True, cache=True)
def match_redert_rows(left_p, right_p, dsi, model, nchunks, out, slopes):
    """Run the orientation DP on every row; rows (in chunks) are the only parallel loop.

    Per thread: the column sums (W x sampled disparities), the cost volume, the DP's back
    pointers (W x D x (orientations + 2 run_cap + 2) bytes) and its values for the last
    columns only (the longest segment's plus one: 9 x D x states float64 with the default
    orientations, where a table of every column, 4.5 MB a thread on teddy, was 129 MB on a
    3000-pixel row of 256 disparities); never H x W x D.

    ``dsi`` (``records.Dsi``): the disparities and the window; ``model``
    (``records.RedertModel``): see ``scanline_dp``; ``out`` (``records.Outputs``):
    ``disparity``, ``flags`` and ``total`` are written, and ``slopes`` (float32, (H, W)):
    each matched pixel's orientation.
    """
    dmin, ndisp, radius = dsi
    steps, oq, run_cap = model.steps, model.oq, model.run_cap
    disp, flags, total = out.disparity, out.flags, out.total
    height, width = disp.shape
    norient = oq.shape[0]
    omax = 0
    for o in range(norient):
        omax = max(omax, abs(oq[o]))
    e_lo = steps * dmin - radius * omax
    ne = steps * (ndisp - 1) + 2 * radius * omax + 1
    # the DP's values: the columns of the longest segment and its end (the steps back
    # to the start are all kept)
    ring = 1
    for o in range(norient):
        ring = max(ring, segment_shape(oq[o], steps)[0] + 1)
    ring = min(ring, width)
    for c in nb.prange(nchunks):
        y0, y1 = chunk_bounds(height, nchunks, c)
        columns = np.empty((width, ne), dtype=np.int64)
        node = np.empty((width, ndisp, norient), dtype=np.float64)
        seg = np.empty((width, ndisp, norient), dtype=np.float64)
        table = np.empty((ring, ndisp, norient + 2 * run_cap + 2), dtype=np.float64)
        back = np.empty((width, ndisp, norient + 2 * run_cap + 2), dtype=np.uint8)
        work = RedertScratch(
            table,
            back,
            np.empty(2 * width + 2, dtype=np.int64),
            np.empty(2 * width + 2, dtype=np.int64),
            np.empty(2 * width + 2, dtype=np.int64),
        )
        for y in range(y0, y1):
            if y == y0:
                sample_columns(left_p, right_p, y, radius, steps, e_lo, columns)
            else:
                slide_columns(left_p, right_p, y, radius, steps, e_lo, columns)
            sheared_costs(columns, e_lo, steps, dmin, oq, radius, node, seg)
            for x in range(width):
                disp[y, x] = np.nan
                flags[y, x] = FLAG_BORDER
                slopes[y, x] = np.nan
            n, t = scanline_dp(node, seg, dmin, model, work)
            apply_path(work, n, dmin, model, disp[y], flags[y], slopes[y])
            total[y] = t

"""Semi-global aggregation of a cost volume, and the winner-take-all of its sums.

Hirschmueller, *Stereo processing by semiglobal matching and mutual information*, IEEE
TPAMI 30(2), 2008: the cost of each pixel and disparity is aggregated along 1-D paths
that reach it from several directions (eq. 13, :func:`~.sgm_simd.path_step`), and the
sums ``S(p, d)`` of the paths (eq. 14) choose the disparity. Eight paths: left to right,
right to left, and the three from the rows above and the three from the rows below (one
vertical, two diagonal); four paths keep the horizontal and the vertical ones.

From two threads to below :data:`SPLIT_THREADS` (6) the volume is swept three times, each
sweep streaming through it once:

* :func:`vertical_pass` down the rows (the paths from above) into one sum volume, and up
  the rows (the paths from below) into another; the two are independent, so they run side
  by side (:func:`vertical_passes`);
* :func:`final_pass`, rows in parallel: the two horizontal paths of the row, the total
  of the four sums, the least total of each pixel (winner-take-all) with its sub-pixel
  fit; then :func:`left_right_check`, on whole rows (a volume may hold a tile of columns),
  against the right view's choices.

On one thread (:func:`paths_and_choices`) the up sweep and the final pass are one:
:func:`up_final_pass` runs each row's paths from below into a buffer of two rows and
chooses the row at once, the same outputs bit for bit without the volume from below.

Two tasks cannot keep more than two threads busy. From :data:`SPLIT_THREADS` threads
(:func:`aggregation_plan`), :func:`split_passes` gives the same two volumes from bands:
each of the six paths runs along lines that no step crosses (the vertical path's columns,
the diagonals' lines ``x - y`` or ``x + y`` constant), so a band of such lines is a task
that waits on no other (:func:`band_pass`, :func:`band_edges`). One parallel loop a
direction: the vertical path's bands store their values, then the bands of one diagonal
add theirs (saturated), then the other's, in :func:`vertical_pass`'s order of addition,
so that the volumes are the same bit for bit. The split streams through the costs once a
direction instead of once a pass, and through the sums three times instead of once: on
one thread it took 1.4-2.0x the fused passes' time (8 paths; 1.05-1.2x with 4), so that
it can only gain from more than about four threads (``docs/performance.md``).

Parallel loops hand out their tasks (a pass or a band, a pair of rows, a row) from a shared
counter (:func:`next_task`): each thread takes the next task when it is done with its
last, so a thread that waits for a core holds back one task, not a fixed share of the work.

Costs and path values are ``int16``; lanes ``k >= ndisp`` of each pixel (the vector
padding) hold a cost no real one reaches, so they never win and never lower a minimum.
The smoothness penalty ``P2`` of a step is read from a table by the absolute difference of
the two pixels' intensities (1/16 gray levels): smaller across edges.
"""

import numba as nb
import numpy as np

from dcstereo._vector.sgm import (
    add_saturated,
    next_task,
    path_step,
    path_total_step,
    paths_step,
    prefetch_pixel,
)
from dcstereo.result import FLAG_BORDER, FLAG_MISMATCH, FLAG_OCCLUDED

#: Pad of the path buffers at ``k = -1`` and ``k = Dp`` (never less than a path value;
#: ``PAD + P1`` saturates at the int16 bound).
PAD = 16383

#: Sub-pixel fits of :func:`final_pass` (``subpixel`` argument).
SUBPIXEL_NONE = 0
SUBPIXEL_PARABOLA = 1
SUBPIXEL_EQUIANGULAR = 2

#: The thread count from which :func:`aggregation_plan` splits the passes into bands: the
#: split's one-thread time is up to 2x the fused passes', which two threads halve at best,
#: so at 4 threads it can at best draw level; 6 leaves a margin for imperfect scaling.
SPLIT_THREADS = 6

#: The fewest columns a band of :func:`split_passes` holds on average.
MIN_BAND = 8

#: How many pixels ahead :func:`final_pass`'s right-to-left walk asks for the sums from
#: above and below (``prefetch_pixel``). The walk goes down through memory, one chain of
#: dependent steps, and the processor's own prefetch kept it waiting on memory: the pass
#: took 1.5-1.6 ns a disparity on KITTI's volumes (128 lanes), 0.5 ns on volumes that fit
#: the caches; asked 2, 4 or 8 pixels ahead, 0.7-0.8 ns (an AMD EPYC VM, Zen 3, one thread).
PREFETCH_PIXELS = 4


@nb.njit(cache=True)
def _gradient_p2(luma, y, x, yq, xq, p2_table):
    return p2_table[abs(luma[y, x] - luma[yq, xq])]


@nb.njit(cache=True)
def _path_buffer(slots, lanes):
    """``slots`` path vectors of ``lanes`` values with their pads, and a last one of zeros.

    Slot ``s`` starts at ``s * (lanes + 2)``: ``PAD``, the values, ``PAD``. The last slot
    holds zeros: the predecessor of a path's first pixel (``L = C`` from it).
    """
    stride = lanes + 2
    buffer = np.empty((slots + 1) * stride, dtype=np.int16)
    for s in range(slots + 1):
        buffer[s * stride] = PAD
        buffer[s * stride + lanes + 1] = PAD
    zero = slots * stride
    for k in range(lanes):
        buffer[zero + 1 + k] = 0
    return buffer


@nb.njit(cache=True)
def vertical_pass(cost, luma, y_first, y_last, step, p1, p2_table, diagonals, sums):
    """Aggregate the paths from above (``step`` 1) or below (-1), rows ``y_first..y_last``.

    ``cost`` and ``sums`` are ``(H, W, Dp)`` int16 volumes of a strip of rows, flattened
    (C order), and ``luma`` (int32, ``(H, W)``) the strip's intensity; row ``y_first``
    starts every path. ``sums[y, x]`` receives the sum of the vertical path's value and,
    with ``diagonals``, of the two diagonal paths' (predecessors ``x - 1`` and ``x + 1`` in
    the previous row; a diagonal path whose predecessor is beyond the image starts at the
    pixel). The paths of a pixel are one :func:`~.sgm_simd.paths_step`; a row, one
    :func:`vertical_row`.
    """
    height, width = luma.shape
    lanes = cost.size // (height * width)
    state = vertical_state(width, lanes, diagonals)
    y = y_first
    first = True
    while True:
        state = vertical_row(
            cost, luma, y, step, first, p1, p2_table, diagonals, state, sums, y * width * lanes
        )
        first = False
        if y == y_last:
            break
        y += step


@nb.njit(cache=True)
def vertical_state(width, lanes, diagonals):
    """Return the state :func:`vertical_row` carries from row to row, for rows of ``width``.

    ``(prev, cur, prev_min, cur_min, mins)``: the path vectors of the previous row and of
    this one (:func:`_path_buffer`, a slot a pixel and path, and one beyond each end of the
    row), their least values, and one pixel's.
    """
    npaths = 3 if diagonals else 1
    slots = width + 2  # slot x + 1 holds pixel x; slots 0 and width + 1 lie beyond the image
    return (
        _path_buffer(npaths * slots, lanes),
        _path_buffer(npaths * slots, lanes),
        np.zeros((npaths, slots), dtype=np.int64),
        np.zeros((npaths, slots), dtype=np.int64),
        np.zeros(3, dtype=np.int64),
    )


@nb.njit(cache=True, inline="always")
def vertical_row(cost, luma, y, step, first, p1, p2_table, diagonals, state, sums, s_row):
    """Run :func:`vertical_pass`'s paths through row ``y``: its sums to ``sums[s_row + x * Dp]``.

    ``state`` (:func:`vertical_state`) holds the paths' values in row ``y - step`` (unread
    where ``first``: row ``y`` starts them); returned with this row's in their place.
    """
    height, width = luma.shape
    lanes = cost.size // (height * width)
    prev, cur, prev_min, cur_min, mins = state
    npaths = 3 if diagonals else 1
    stride = lanes + 2
    slots = width + 2
    zero = npaths * slots * stride  # the slot of zeros
    row = y * width * lanes
    yq = y - step
    for x in range(width):
        c_off = row + x * lanes
        s_off = s_row + x * lanes
        q0 = (x + 1) * stride
        if first:
            p0, p2_0, mins[0] = zero, 0, 0
        else:
            p0, p2_0, mins[0] = (
                q0,
                _gradient_p2(luma, y, x, yq, x, p2_table),
                prev_min[0, x + 1],
            )
        if diagonals:
            q1 = (slots + x + 1) * stride
            q2 = (2 * slots + x + 1) * stride
            if first or x == 0:
                p1_, p2_1, mins[1] = zero, 0, 0
            else:
                p1_ = (slots + x) * stride
                p2_1 = _gradient_p2(luma, y, x, yq, x - 1, p2_table)
                mins[1] = prev_min[1, x]
            if first or x == width - 1:
                p2_, p2_2, mins[2] = zero, 0, 0
            else:
                p2_ = (2 * slots + x + 2) * stride
                p2_2 = _gradient_p2(luma, y, x, yq, x + 1, p2_table)
                mins[2] = prev_min[2, x + 2]
            paths_step(
                cost, c_off, prev, (p0, p1_, p2_), cur, (q0, q1, q2), lanes, p1,
                (p2_0, p2_1, p2_2), mins, sums, s_off,
            )  # fmt: skip
            cur_min[1, x + 1] = mins[1]
            cur_min[2, x + 1] = mins[2]
        else:
            paths_step(cost, c_off, prev, (p0,), cur, (q0,), lanes, p1, (p2_0,), mins, sums, s_off)
        cur_min[0, x + 1] = mins[0]
    return cur, prev, cur_min, prev_min, mins


@nb.njit(cache=True, parallel=True)
def vertical_passes(cost, luma, p1, p2_table, diagonals, down, up, threads):
    """:func:`vertical_pass` down the strip into ``down`` and up it into ``up``, side by side.

    Two tasks for whichever of ``threads`` (numba's thread count) come first: one thread
    alone runs both.
    """
    last = luma.shape[0] - 1
    counter = np.zeros(1, dtype=np.int64)
    for _ in nb.prange(max(1, min(threads, 2))):
        task = next_task(counter)
        while task < 2:
            if task == 0:
                vertical_pass(cost, luma, 0, last, 1, p1, p2_table, diagonals, down)
            else:
                vertical_pass(cost, luma, last, 0, -1, p1, p2_table, diagonals, up)
            task = next_task(counter)


@nb.njit(cache=True)
def line_range(height, width, slope):
    """Return the lines ``c = x + slope * t`` of a path: ``(first, last + 1)``.

    ``t`` counts the rows in the path's order (0 for its first row). Slope 0: the vertical
    path's columns; -1: the diagonal path whose predecessor is ``x - 1`` in the previous
    row; 1: the one whose predecessor is ``x + 1``. The path's steps run along each line,
    and no step crosses from one line to another.
    """
    if slope < 0:
        return 1 - height, width
    if slope > 0:
        return 0, width + height - 1
    return 0, width


@nb.njit(cache=True)
def line_length(height, width, slope, c):
    """Return the number of pixels of line ``c`` (:func:`line_range`) in the image."""
    if slope < 0:  # x = c + t
        return min(height - 1, width - 1 - c) - max(0, -c) + 1
    if slope > 0:  # x = c - t
        return min(height - 1, c) - max(0, c - width + 1) + 1
    return height


@nb.njit(cache=True)
def band_edges(height, width, slope, bands):
    """Split a path's lines (:func:`line_range`) into ``bands`` bands of about equal pixels.

    Returns ``bands + 1`` line numbers: band ``i`` holds lines ``edges[i]..edges[i + 1] -
    1``, the first that start on or past ``i / bands`` of the pixels; a band may be empty
    (fewer lines than bands).
    """
    first, end = line_range(height, width, slope)
    total = height * width
    edges = np.full(bands + 1, end, dtype=np.int64)
    edges[0] = first
    band = 1
    before = 0  # pixels on the lines before c
    for c in range(first, end):
        while band < bands and before * bands >= band * total:
            edges[band] = c
            band += 1
        before += line_length(height, width, slope, c)
    return edges


@nb.njit(cache=True)
def band_pass(cost, luma, y_first, step, slope, c0, c1, p1, p2_table, add, sums):
    """Run one path over the lines ``c0..c1 - 1`` (:func:`line_range`) into ``sums``.

    The vertical path (``slope`` 0) or a diagonal one (-1, 1: predecessor ``x + slope`` in
    the previous row) from above (``step`` 1, rows from ``y_first`` = 0 down) or from below
    (-1, from the last row up); a path whose predecessor is beyond the image starts at the
    pixel. ``sums[y, x]`` (a flattened ``(H, W, Dp)`` volume, as ``cost``) receives the
    value (``add`` False) or adds it, saturated: the steps and sums of
    :func:`vertical_pass`, one path at a time, so that the vertical path stored, then the
    slope -1 path added, then the slope 1 one, give its volume bit for bit. Steps on
    different lines are independent: bands of lines run side by side.
    """
    height, width = luma.shape
    lanes = cost.size // (height * width)
    stride = lanes + 2
    slots = max(c1 - c0, 0)  # slot c - c0 holds line c's last pixel
    prev = _path_buffer(slots, lanes)
    cur = _path_buffer(slots, lanes)
    zero = slots * stride  # the slot of zeros
    prev_min = np.zeros(slots, dtype=np.int64)
    cur_min = np.zeros(slots, dtype=np.int64)
    mins = np.zeros(1, dtype=np.int64)
    for t in range(height):
        y = y_first + step * t
        yq = y - step
        row = y * width * lanes
        for x in range(max(0, c0 - slope * t), min(width, c1 - slope * t)):
            s = x + slope * t - c0
            q = s * stride
            xq = x + slope
            c_off = row + x * lanes
            if t == 0 or xq < 0 or xq >= width:
                p, p2, pmin = zero, 0, 0
            else:
                p, p2, pmin = q, _gradient_p2(luma, y, x, yq, xq, p2_table), prev_min[s]
            if add:
                cur_min[s] = path_step(cost, c_off, prev, p, cur, q, lanes, p1, p2, pmin)
                add_saturated(sums, c_off, sums, c_off, cur, q + 1, lanes)
            else:
                mins[0] = pmin
                paths_step(cost, c_off, prev, (p,), cur, (q,), lanes, p1, (p2,), mins, sums, c_off)
                cur_min[s] = mins[0]
        prev, cur = cur, prev
        prev_min, cur_min = cur_min, prev_min


#: The three ways :func:`paths_and_choices` runs a strip's paths (:func:`aggregation_plan`).
PLAN_SWEEP, PLAN_PASSES, PLAN_SPLIT = 0, 1, 2


def aggregation_plan(width, threads):
    """Return how a strip ``width`` columns wide is aggregated on ``threads`` threads.

    One rule for the three paths, which give the same outputs bit for bit:
    :data:`PLAN_SPLIT` (:func:`split_passes`, bands of each path direction) from
    :data:`SPLIT_THREADS` threads where the strip holds two bands (``2 * MIN_BAND``
    columns; one band a direction would give the fused passes' two tasks for more work);
    else :data:`PLAN_SWEEP` (:func:`vertical_pass` down, then :func:`up_final_pass`) on
    one thread; else :data:`PLAN_PASSES` (:func:`vertical_passes`, two tasks, then
    :func:`final_pass`).

    >>> aggregation_plan(640, 1), aggregation_plan(640, 2), aggregation_plan(640, 8)
    (0, 1, 2)
    >>> aggregation_plan(12, 8)  # too narrow for two bands
    1
    """
    if threads >= SPLIT_THREADS and split_bands(width, threads) >= 2:
        return PLAN_SPLIT
    return PLAN_SWEEP if threads == 1 else PLAN_PASSES


def paths_and_choices(
    cost, luma, down, up, y0, y1, x0, x1, dmin, ndisp, p1, p2_table, diagonals, subpixel,
    best, value, candidate, confidence, out_y, out_x, threads,
):  # fmt: skip
    """Aggregate a strip's paths and choose its rows ``y0..y1 - 1``: :func:`final_pass`'s outputs.

    ``threads`` is numba's thread count; :func:`aggregation_plan` chooses the path. Its
    :data:`PLAN_SWEEP` (one thread): :func:`vertical_pass` into ``down``, then
    :func:`up_final_pass`, which leaves ``up`` unread and unwritten, with one stream
    through the costs and one through a volume of sums fewer (KITTI 000066's kernels, one
    thread: 93.4 -> 87.4 ms). Otherwise the paths from above into ``down`` and from below
    into ``up``: :func:`vertical_passes` (:data:`PLAN_PASSES`, two tasks) or
    :func:`split_passes` (:data:`PLAN_SPLIT`, :func:`split_bands` bands of each path
    direction), the same volumes bit for bit; then :func:`final_pass` (rows in parallel).
    The same outputs, bit for bit, on every path.
    """
    width = luma.shape[1]
    plan = aggregation_plan(width, threads)
    if plan == PLAN_SWEEP:
        vertical_pass(cost, luma, 0, luma.shape[0] - 1, 1, p1, p2_table, diagonals, down)
        up_final_pass(
            cost, luma, down, y0, y1, x0, x1, dmin, ndisp, p1, p2_table, diagonals, subpixel,
            best, value, candidate, confidence, out_y, out_x,
        )  # fmt: skip
        return
    if plan == PLAN_SPLIT:
        bands = split_bands(width, threads)
        split_passes(cost, luma, p1, p2_table, diagonals, down, up, threads, bands)
    else:
        vertical_passes(cost, luma, p1, p2_table, diagonals, down, up, threads)
    final_pass(
        cost, luma, down, up, y0, y1, x0, x1, dmin, ndisp, p1, p2_table, subpixel, best,
        value, candidate, confidence, out_y, out_x, threads,
    )  # fmt: skip


def split_bands(width, threads):
    """Return the bands of each path direction of :func:`split_passes` for ``threads``.

    Two a thread, each at least :data:`MIN_BAND` lines wide on average (of ``width``
    columns), at least one.
    """
    return max(1, min(2 * threads, width // MIN_BAND))


@nb.njit(cache=True, parallel=True)
def split_passes(cost, luma, p1, p2_table, diagonals, down, up, threads, bands):
    """:func:`vertical_passes`' volumes, bit for bit, from tasks for any number of threads.

    Three parallel loops, one a path direction: the vertical path's ``bands`` bands of
    columns (:func:`band_pass`, :func:`band_edges`), from above into ``down`` and from
    below into ``up``, store their values; then, with ``diagonals``, the bands of the
    diagonal of slope -1 add theirs, then those of slope 1, in :func:`vertical_pass`'s
    order. Each loop holds ``2 * bands`` tasks, handed out from a shared counter to
    ``threads`` (numba's thread count); no task waits on another, only each loop's end on
    its last.
    """
    height, width = luma.shape
    last = height - 1
    tasks = 2 * bands
    for direction in range(3 if diagonals else 1):
        slope = 0 if direction == 0 else 2 * direction - 3  # 0, -1, 1
        add = direction > 0
        edges = band_edges(height, width, slope, bands)
        counter = np.zeros(1, dtype=np.int64)
        for _ in nb.prange(max(1, min(threads, tasks))):
            task = next_task(counter)
            while task < tasks:
                c0, c1 = edges[task // 2], edges[task // 2 + 1]
                if task % 2 == 0:
                    band_pass(cost, luma, 0, 1, slope, c0, c1, p1, p2_table, add, down)
                else:
                    band_pass(cost, luma, last, -1, slope, c0, c1, p1, p2_table, add, up)
                task = next_task(counter)


@nb.njit(cache=True)
def _subpixel(t, off, k, ndisp, mode):
    """Offset in ``(-0.5, 0.5)`` of the least total ``t[off + k]`` from its neighbours."""
    if mode == SUBPIXEL_NONE or k <= 0 or k >= ndisp - 1:
        return 0.0
    a = np.float64(t[off + k - 1])
    b = np.float64(t[off + k])
    c = np.float64(t[off + k + 1])
    if mode == SUBPIXEL_PARABOLA:
        den = a - 2.0 * b + c
        return (a - c) / (2.0 * den) if den > 0 else 0.0
    den = max(a, c) - b  # equiangular: two lines of opposite slopes through the three
    return (a - c) / (2.0 * den) if den > 0 else 0.0


@nb.njit(cache=True)
def _margin(t, off, k, ndisp, best):
    """``(rival - best) / rival`` for the least total ``rival`` two or more disparities off."""
    if k < 2 and k + 2 >= ndisp:
        return np.float32(np.nan)  # no disparity two or more away
    # the rows below and above the three nearest as slices, the least by compare and store:
    # the compiler makes whole vectors of it (``min`` on the indexed row stayed scalar)
    rival = np.int16(32767)
    below = t[off : off + max(k - 1, 0)]
    for j in range(below.size):  # the disparities two or more below the chosen one
        if below[j] < rival:
            rival = below[j]
    above = t[off + min(k + 2, ndisp) : off + ndisp]
    for j in range(above.size):  # and two or more above it
        if above[j] < rival:
            rival = above[j]
    rival = np.int64(rival)
    if rival <= 0:
        return np.float32(np.nan)
    return np.float32((rival - best) / rival)


@nb.njit(cache=True, parallel=True)
def final_pass(
    cost, luma, down, up, y0, y1, x0, x1, dmin, ndisp, p1, p2_table, subpixel, best, value,
    candidate, confidence, out_y, out_x, threads,
):  # fmt: skip
    """Horizontal paths, totals and winner-take-all of rows ``y0..y1 - 1``, columns ``x0..x1 - 1``.

    Rows and columns of the volume's tile (``luma``'s; ``cost``, ``down`` and ``up`` its
    flattened ``(H, W, Dp)`` volumes); the horizontal paths run over all of the tile's
    columns. The total of a pixel is the sum of the four path sums (saturated). Pixel
    ``(y, x)`` writes ``[out_y + y - y0, out_x + x - x0]`` (its place in the image) of
    ``best`` (int16: the least total's ``k``, the first of equals), ``value`` (int16: that
    total) and ``candidate`` (float32: ``dmin + k`` plus the sub-pixel offset), ``(H, W)``
    arrays, which :func:`left_right_check` reads.

    ``confidence`` (float32, the shape of ``best``, or of no columns: not wanted) receives
    ``(rival - best) / rival`` of each pixel's totals, ``rival`` the least total of the
    disparities two or more away from the chosen one (NaN where there is none or it is 0).
    ``threads`` is numba's thread count (the pairs of rows are handed out one at a time).
    """
    height, width = luma.shape
    lanes = cost.size // (height * width)
    rows = y1 - y0
    pairs = (rows + 1) // 2  # two rows a task: two chains of dependent steps
    counter = np.zeros(1, dtype=np.int64)
    for _ in nb.prange(max(1, min(threads, pairs))):
        scratch = _final_scratch(width, lanes)
        i = next_task(counter)
        while i < pairs:
            ra = 2 * i
            pair = ra + 1 < rows
            rb = ra + 1 if pair else ra
            _final_rows(
                cost, luma, down, up, y0 + ra, y0 + rb, (y0 + ra) * width * lanes,
                (y0 + rb) * width * lanes, pair, lanes, p1, p2_table, scratch, x0, x1, dmin,
                ndisp, subpixel, best, value, candidate, confidence, out_y + ra, out_y + rb,
                out_x,
            )  # fmt: skip
            i = next_task(counter)


@nb.njit(cache=True)
def _final_scratch(width, lanes):
    """One thread's buffers for :func:`_final_rows`, rows of ``width`` pixels."""
    return (
        _path_buffer(width, lanes),  # the left-to-right paths of the two rows
        _path_buffer(width, lanes),
        _path_buffer(2, lanes),  # the right-to-left paths' last two pixels
        _path_buffer(2, lanes),
        np.empty(width * lanes, dtype=np.int16),  # the totals
        np.empty(width * lanes, dtype=np.int16),
        np.empty(width, dtype=np.int64),  # each pixel's first least total
        np.empty(width, dtype=np.int64),
    )


@nb.njit(cache=True)
def _final_rows(
    cost, luma, down, up, ya, yb, up_a, up_b, pair, lanes, p1, p2_table, scratch, x0, x1,
    dmin, ndisp, subpixel, best, value, candidate, confidence, out_a, out_b, out_x,
):  # fmt: skip
    """Run the horizontal paths, totals and choices of rows ``ya`` and ``yb`` (``yb``: ``pair``).

    :func:`_horizontal_rows` (the sums from below at ``up[up_a]`` and ``up[up_b]``), then
    :func:`_choose_row` of each into rows ``out_a`` and ``out_b`` of the outputs;
    ``scratch``: :func:`_final_scratch`.
    """
    hbuf_a, hbuf_b, back_a, back_b, total_a, total_b, best_a, best_b = scratch
    _horizontal_rows(
        cost, luma, down, up, ya, yb, up_a, up_b, pair, lanes, p1, p2_table, hbuf_a, hbuf_b,
        back_a, back_b, total_a, total_b, best_a, best_b, ndisp,
    )  # fmt: skip
    _choose_row(
        total_a, best_a, lanes, x0, x1, dmin, ndisp, subpixel, best[out_a], value[out_a],
        candidate[out_a], confidence[out_a], out_x,
    )  # fmt: skip
    if pair:
        _choose_row(
            total_b, best_b, lanes, x0, x1, dmin, ndisp, subpixel, best[out_b], value[out_b],
            candidate[out_b], confidence[out_b], out_x,
        )  # fmt: skip


@nb.njit(cache=True)
def up_final_pass(
    cost, luma, down, y0, y1, x0, x1, dmin, ndisp, p1, p2_table, diagonals, subpixel, best,
    value, candidate, confidence, out_y, out_x,
):  # fmt: skip
    """:func:`final_pass`'s rows with the paths from below, in one sweep up the strip, one thread.

    The same outputs as ``vertical_pass`` up the strip into a volume ``up`` and then
    :func:`final_pass` (``down`` from the paths from above), bit for bit, without the volume:
    each row's sums from below go to a buffer of two rows, and its horizontal paths and
    totals run at once, while they and the row's costs are in the caches. With the pass
    down before it, the costs are read twice and one volume of sums written and read once;
    the two passes and the final pass read the costs three times and write and read two
    volumes of sums. The paths from below stop at row ``y0``.
    """
    height, width = luma.shape
    lanes = cost.size // (height * width)
    state = vertical_state(width, lanes, diagonals)
    up = np.empty(2 * width * lanes, dtype=np.int16)  # rows ya (first half) and yb
    scratch = _final_scratch(width, lanes)
    y = height - 1
    first = True
    while y >= y0:
        state = vertical_row(cost, luma, y, -1, first, p1, p2_table, diagonals, state, up, 0)
        first = False
        if y >= y1:  # below the rows wanted: the paths only
            y -= 1
            continue
        ya, pair = y, y - 1 >= y0
        yb = y - 1 if pair else y
        if pair:
            state = vertical_row(
                cost, luma, yb, -1, False, p1, p2_table, diagonals, state, up, width * lanes
            )
        _final_rows(
            cost, luma, down, up, ya, yb, 0, width * lanes, pair, lanes, p1, p2_table, scratch,
            x0, x1, dmin, ndisp, subpixel, best, value, candidate, confidence,
            out_y + ya - y0, out_y + yb - y0, out_x,
        )  # fmt: skip
        y = yb - 1


@nb.njit(cache=True)
def _horizontal_rows(
    cost, luma, down, up, ya, yb, up_a, up_b, pair, lanes, p1, p2_table, hbuf_a, hbuf_b,
    back_a, back_b, total_a, total_b, best_a, best_b, ndisp,
):  # fmt: skip
    """Run the two horizontal paths of rows ``ya`` and ``yb``, and their pixels' totals.

    ``yb`` only with ``pair``. The sums from below of row ``ya`` start at ``up[up_a]`` (a
    volume's row, or :func:`up_final_pass`'s buffer), of ``yb`` at ``up[up_b]``.
    ``best_a``/``best_b`` receive each pixel's first least total. The steps of the two rows
    are interleaved, so that the processor runs one row's while the other's wait on their
    predecessor's least value.
    """
    width = luma.shape[1]
    stride = lanes + 2
    row_a, row_b = ya * width * lanes, yb * width * lanes
    zero = width * stride  # the slot of zeros: the predecessor of a path's first pixel
    ha = path_step(cost, row_a, hbuf_a, zero, hbuf_a, 0, lanes, p1, 0, 0)
    hb = path_step(cost, row_b, hbuf_b, zero, hbuf_b, 0, lanes, p1, 0, 0) if pair else 0
    for x in range(1, width):  # left to right
        prev, here = (x - 1) * stride, x * stride
        p2 = _gradient_p2(luma, ya, x, ya, x - 1, p2_table)
        ha = path_step(cost, row_a + x * lanes, hbuf_a, prev, hbuf_a, here, lanes, p1, p2, ha)
        if pair:
            p2 = _gradient_p2(luma, yb, x, yb, x - 1, p2_table)
            hb = path_step(cost, row_b + x * lanes, hbuf_b, prev, hbuf_b, here, lanes, p1, p2, hb)
    parts_a, parts_b = (down, up, hbuf_a), (down, up, hbuf_b)
    ma = mb = 0
    for x in range(width - 1, -1, -1):  # right to left, the totals and their least
        q = (x % 2) * stride
        if x == width - 1:
            p_off, p2a, p2b = 2 * stride, 0, 0
        else:
            p_off = ((x + 1) % 2) * stride
            p2a = _gradient_p2(luma, ya, x, ya, x + 1, p2_table)
            p2b = _gradient_p2(luma, yb, x, yb, x + 1, p2_table)
        offs = x * lanes
        if x >= PREFETCH_PIXELS:  # the sums from above and below, a few pixels on
            ahead = offs - PREFETCH_PIXELS * lanes
            prefetch_pixel(down, row_a + ahead, lanes)
            prefetch_pixel(up, up_a + ahead, lanes)
            if pair:
                prefetch_pixel(down, row_b + ahead, lanes)
                prefetch_pixel(up, up_b + ahead, lanes)
        c_off = row_a + offs
        ma, k, _ = path_total_step(
            cost, c_off, back_a, p_off, back_a, q, lanes, p1, p2a, ma, parts_a,
            (c_off, up_a + offs, x * stride + 1), total_a, offs,
        )  # fmt: skip
        best_a[x] = min(k, ndisp - 1)
        if pair:
            c_off = row_b + offs
            mb, k, _ = path_total_step(
                cost, c_off, back_b, p_off, back_b, q, lanes, p1, p2b, mb, parts_b,
                (c_off, up_b + offs, x * stride + 1), total_b, offs,
            )  # fmt: skip
            best_b[x] = min(k, ndisp - 1)


@nb.njit(cache=True)
def _choose_row(total, best_k, lanes, x0, x1, dmin, ndisp, subpixel, best, value, candidate,
                confidence, out_x):  # fmt: skip
    """Winner-take-all and sub-pixel fit of columns ``x0..x1 - 1`` of a row (``final_pass``)."""
    for x in range(x0, x1):
        k = best_k[x]
        total_k = total[x * lanes + k]
        j = out_x + x - x0
        best[j] = k
        value[j] = total_k
        if confidence.size:
            confidence[j] = _margin(total, x * lanes, k, ndisp, total_k)
        offset = _subpixel(total, x * lanes, k, ndisp, subpixel)  # |offset| < 0.5
        candidate[j] = np.float32(dmin + k + offset)


@nb.njit(cache=True, parallel=True)
def left_right_check(best, value, candidate, dmin, tolerance, disparity, flags, threads):
    """Check whole rows of :func:`final_pass`'s choices against the right view's, as SGBM.

    Each right pixel keeps the disparity of the left pixel of least total that chose it
    (the first of equals); a left pixel whose disparity differs from its right pixel's by
    more than ``tolerance`` (negative: no check) loses its estimate (NaN), flagged
    ``FLAG_OCCLUDED`` where the right pixel's disparity is the larger (it belongs to a
    nearer surface, which hides this pixel from the right view) and ``FLAG_MISMATCH``
    otherwise; a choice whose right pixel lies beyond the image is ``FLAG_BORDER``. The
    others take their ``candidate``. ``best``, ``value`` and ``candidate`` are ``(H, W)``;
    ``threads`` is numba's thread count (the rows are handed out one at a time).
    """
    height, width = best.shape
    counter = np.zeros(1, dtype=np.int64)
    for _ in nb.prange(max(1, min(threads, height))):
        right_best = np.empty(width, dtype=np.int64)
        right_d = np.empty(width, dtype=np.int64)
        y = next_task(counter)
        while y < height:
            right_best[:] = 1 << 30
            right_d[:] = -(1 << 30)
            for x in range(width):
                xr = x - dmin - best[y, x]
                if 0 <= xr < width and value[y, x] < right_best[xr]:
                    right_best[xr] = value[y, x]
                    right_d[xr] = dmin + best[y, x]
            for x in range(width):
                d = dmin + best[y, x]
                xr = x - d
                if xr < 0 or xr >= width:
                    disparity[y, x] = np.nan
                    flags[y, x] = FLAG_BORDER
                elif tolerance >= 0 and abs(right_d[xr] - d) > tolerance:
                    disparity[y, x] = np.nan
                    flags[y, x] = FLAG_OCCLUDED if right_d[xr] > d else FLAG_MISMATCH
                else:
                    disparity[y, x] = candidate[y, x]
                    flags[y, x] = 0
            y = next_task(counter)

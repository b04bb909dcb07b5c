"""The colour-weighted median's kernels (:mod:`dcstereo.refine.weighted_median`).

Each sample of a window is an int32 key, its disparity's float32 bits made to sort as
signed integers (:func:`sample_keys`), and an integer weight. The keys of :data:`CHUNK`
pixels' windows are sorted side by side (:func:`sorted_windows`): the columns of the row
first, by a fixed network of compare-exchanges, then blocks of columns and the windows
merged from them by Batcher's merges (:func:`~dcstereo.refine._median.window_plan`), each
exchange a ``min`` and a ``max`` of two rows of keys (vector code). The windows of
neighbouring pixels share all their columns but one, so a block serves several windows:
467 exchanges a pixel of a 9 x 9 window where sorting it takes 864 (the stage, one thread,
AVX2, in one process alternating with the sort of each window: teddy 54.2 -> 46.7 ms,
tsukuba 45.4 -> 38.5, KITTI 000066 133.7 -> 122.9). The weights stay where they are: a
binary search over the sorted keys finds each pixel's median, the least sorted key whose
weight at or below it (a masked sum over the window's samples, again for all the chunk's
pixels at once) reaches half the total. Samples
outside the image or without an estimate get the weight 0 and the largest key,
:data:`EMPTY`: a sample of weight 0 is never the weighted median (the weight at or below
the largest finite value is the whole total, which is positive), so the result is that of
the samples with an estimate alone.

A weight is symmetric: pixel ``p``'s weight of its sample ``p + o`` is ``p + o``'s of ``p``
(the same colour difference and distance). Each row computes the weights of the half of its
window after the centre (:func:`forward_weights`) and takes the others from the rows above,
which computed them before it: bands of rows run in order, keeping the last ``radius + 1``
rows' weights (the kernel, one thread, AVX2: teddy 53 -> 46 ms, KITTI 000066 133 -> 113).
"""

import numba as nb
import numpy as np

from dcstereo._vector.sgm import next_task
from dcstereo.refine._median import exchange_rows, sortable32

#: Pixels of a row whose windows are sorted together: ``81 x 256`` keys and as many
#: weights (2 x 81 KiB for a 9 x 9 window) for the search's 7 sums, and the sorted columns,
#: blocks and windows (189 rows of 264 lanes, 195 KiB). When each window was sorted on its
#: own (the stage, one thread, AVX2): 128 pixels teddy 56.7 ms and KITTI 000066 142, 256
#: 52.8 and 132, 512 53-58 on teddy; with the merges 64 to 512 pixels alike on teddy.
CHUNK = 256

#: The key of a sample that does not count (outside the image, or without an estimate):
#: above every finite value's, with the weight 0.
EMPTY = np.int32(0x7FFFFFFF)


@nb.njit(cache=True, inline="always")
def sample_key(bits):
    """Return a float32's int32 bits as a key of the same order (``-0.0`` as ``+0.0``).

    A NaN or an infinity (no estimate) gives :data:`EMPTY`.
    """
    if (bits & 0x7F800000) == 0x7F800000:
        return EMPTY
    key = sortable32(bits)
    return np.int32(0) if key == np.int32(-1) else key  # -0.0's bits sort just below +0.0


@nb.njit(cache=True, parallel=True)
def sample_keys(bits, keys):
    """Fill ``keys`` (int32) with the :func:`sample_key` of each pixel's float32 ``bits``."""
    height, width = bits.shape
    for y in nb.prange(height):
        for x in range(width):
            keys[y, x] = sample_key(bits[y, x])


#: The rows of a task of the guided kernels (:func:`weighted_median_rows` and the local
#: planes'): each computes the weights of ``radius`` rows above it again (4 of 32: an
#: eighth more colour factors). The local planes, teddy, one thread (AVX2): 16 rows 26.2
#: ms, 32 24.7, 64 23.9; 32 keeps twelve tasks for threads on a 375-row image.
BAND = 32


@nb.njit(cache=True, inline="always")
def band_rows(band, radius, height):
    """Return ``(first, y0, stop)``: the rows a guided kernel's band runs, and those it writes.

    Band ``band`` writes rows ``y0 .. stop - 1`` (:data:`BAND` of them, the last band
    fewer); it runs from ``first``, ``radius`` rows above ``y0`` (cut at the top), whose
    forward weights its first rows read.

    >>> band_rows.py_func(0, 4, 70), band_rows.py_func(2, 4, 70)
    ((0, 0, 32), (60, 64, 70))
    """
    y0 = band * BAND
    return max(0, y0 - radius), y0, min(height, y0 + BAND)


@nb.njit(cache=True, inline="always")
def forward_index(dy, dx, side):
    """Return offset ``(dy, dx)``'s place among the forward offsets (:func:`forward_weights`).

    The forward offsets are those after the centre in the window's row-major order: ``dy >
    0``, or ``dy == 0`` and ``dx > 0``; they are numbered ``0 .. (side**2 - 1) / 2 - 1``.
    """
    return dy * side + dx - 1


@nb.njit(cache=True, inline="always")
def channel_differences(guide, y, yy, dx, diff):
    """Write ``diff[x - a]``: the largest channel difference of ``(y, x)`` and ``(yy, x + dx)``.

    ``guide`` ``(3, H, W)``; for the pixels ``a <= x < b`` whose sample lies inside the
    row, ``(a, b)`` returned. Vector code (the guided kernels' colour term).
    """
    width = guide.shape[2]
    a, b = max(0, -dx), min(width, width - dx)  # the pixels, their samples + dx
    r1, g1, b1 = (
        guide[0, yy, a + dx : b + dx],
        guide[1, yy, a + dx : b + dx],
        guide[2, yy, a + dx : b + dx],
    )
    r0, g0, b0 = guide[0, y, a:b], guide[1, y, a:b], guide[2, y, a:b]
    for i in range(b - a):
        diff[i] = max(abs(np.int32(r1[i]) - np.int32(r0[i])),
                      abs(np.int32(g1[i]) - np.int32(g0[i])),
                      abs(np.int32(b1[i]) - np.int32(b0[i])))  # fmt: skip
    return a, b


@nb.njit(cache=True)
def forward_weights(guide, y, radius, colour_weight, space_weight, diff, slot):
    """Write ``slot[forward_index(dy, dx), x]``: pixel ``(y, x)``'s weight of ``(y + dy, x + dx)``.

    ``colour_weight[g] * space_weight[dy + radius, dx + radius]`` (int32), ``g`` the largest
    channel difference, for the forward offsets whose sample lies inside the image; the
    other entries are left as they are (never read). ``diff``: int32 scratch of the width.
    """
    height = guide.shape[1]
    side = 2 * radius + 1
    for dy in range(0, min(radius, height - 1 - y) + 1):
        for dx in range(1 if dy == 0 else -radius, radius + 1):
            space = space_weight[dy + radius, dx + radius]
            a, b = channel_differences(guide, y, y + dy, dx, diff)
            dst = slot[forward_index(dy, dx, side), a:b]
            for i in range(b - a):  # a table lookup each (an unsigned index: no test for
                dst[i] = colour_weight[np.uint32(diff[i])] * space  # a negative one)


@nb.njit(cache=True, parallel=True)
def weighted_median_rows(key, guide, moved, radius, colour_weight, space_weight, plan,
                         sums_like, out, threads=1):  # fmt: skip
    """Write into ``out`` the colour-weighted median of each moved pixel's window.

    ``key``: :func:`sample_keys` of the disparity map's float32 bits (a NaN or an infinity:
    no estimate); ``guide``: ``(3, H, W)`` integer levels 0..255 (a gray image as three
    equal channels); ``out``: the map's int32 bits, where a pixel with ``moved[y, x]``
    receives the weighted median of the finite values of the ``(2 radius + 1)`` square
    around it, cut at the image's edges, each weighted by ``colour_weight[g] *
    space_weight[dy + radius, dx + radius]``, ``g`` the largest difference of a channel
    between that pixel and the centre: the least value ``v`` with ``2 * (weight of the
    values <= v) >= total weight``. ``colour_weight`` (256) and ``space_weight`` are int32
    tables whose products are under ``2**31`` (a sample's weight, int32), ``space_weight``
    symmetric about its centre (see below);
    ``sums_like``'s integer dtype is that of the window's sums (int32 where twice the
    largest total fits, otherwise int64). ``plan``:
    :func:`~dcstereo.refine._median.window_plan` of ``2 radius + 1``.

    A weight is symmetric (pixel ``p``'s of its sample ``p + o`` is ``p + o``'s of ``p``),
    so each row computes those of half its window (:func:`forward_weights`) and takes the
    others from the rows above: bands of :data:`BAND` rows, handed out one at a time to
    ``threads`` (numba's thread count; default 1) as each is free, run their rows in order
    keeping the last ``radius + 1`` rows' weights (:func:`median_row`).
    """
    height, width = key.shape
    side = 2 * radius + 1
    half = (side * side - 1) // 2  # the forward offsets; slot[half]: the centre's weight
    slots = radius + 1
    bands = (height + BAND - 1) // BAND
    counter = np.zeros(1, dtype=np.int64)
    for _ in nb.prange(max(1, min(threads, bands))):
        ring = np.empty((slots, half + 1, width), dtype=np.int32)
        for s in range(slots):  # g = 0
            ring[s, half, :] = colour_weight[0] * space_weight[radius, radius]
        diff = np.empty(width, dtype=np.int32)
        scratch = (
            np.empty((side * side, CHUNK), dtype=np.int32),  # keys
            np.empty((side * side, CHUNK), dtype=np.int32),  # weights
            # the sorted columns, their blocks and the windows (window_plan), a lane a
            # column from radius before the chunk's first pixel
            np.empty((plan[2].max() + 1, CHUNK + side - 1), dtype=np.int32),
            np.empty(CHUNK, dtype=sums_like.dtype),  # total
            np.empty(CHUNK, dtype=sums_like.dtype),  # below
            np.empty((3, CHUNK), dtype=np.int32),  # the search's low, high and probe
        )
        band = next_task(counter)
        while band < bands:
            first, y0, stop = band_rows(band, radius, height)
            for y in range(first, stop):
                forward_weights(
                    guide, y, radius, colour_weight, space_weight, diff, ring[y % slots]
                )
                if y >= y0:
                    median_row(key, moved, radius, plan, ring, y, scratch, out)
            band = next_task(counter)


@nb.njit(cache=True)
def median_row(key, moved, radius, plan, ring, y, scratch, out):
    """Write row ``y`` of :func:`weighted_median_rows`, its weights from ``ring``.

    ``ring[t % (radius + 1)]`` holds row ``t``'s forward weights (:func:`forward_weights`)
    for rows ``y - radius .. y``, and the centre's at ``[.., half]``: pixel ``x``'s weight of
    its sample at a forward offset ``o`` is its own row's; at ``-o``, the one row ``y - dy``
    gave pixel ``x - dx`` for ``o``. :data:`CHUNK` pixels at a time: their windows' keys
    sorted together (:func:`sorted_windows`), then the binary search of masked weight sums.
    """
    height, width = key.shape
    side = 2 * radius + 1
    count = side * side
    half = (count - 1) // 2
    slots = radius + 1
    rounds = 0  # the binary search's: 2**rounds >= count
    while (1 << rounds) < count:
        rounds += 1
    keys, weights, tree, total, below, search = scratch
    low, high, probe = search[0], search[1], search[2]
    steps, orders = plan[0], plan[2]
    ordered = orders[steps[-1, 7] : steps[-1, 7] + count]  # the rows of tree, least first
    for x0 in range(0, width, CHUNK):
        n = min(CHUNK, width - x0)
        wanted = False
        for i in range(n):
            wanted |= moved[y, x0 + i]
        if not wanted:
            continue
        for o in range(count):
            dy, dx = o // side - radius, o % side - radius
            key_row, weight_row = keys[o], weights[o]
            yy = y + dy
            if yy < 0 or yy >= height:
                for i in range(CHUNK):
                    key_row[i] = EMPTY
                    weight_row[i] = 0
                continue
            first = min(n, max(0, -dx - x0))  # the chunk's samples inside the image
            last = max(first, min(n, width - dx - x0))
            # every column of the chunk, a short chunk's unread ones too: the network
            # and the sums below run over all CHUNK (a constant count: vector code)
            for i in range(first):
                key_row[i] = EMPTY
                weight_row[i] = 0
            for i in range(last, CHUNK):
                key_row[i] = EMPTY
                weight_row[i] = 0
            # the samples of this offset inside the image, as views that start at the
            # first of them: every index from 0 up, so that the loops are whole vectors
            m = last - first
            if m > 0:
                src, dst = x0 + first + dx, x0 + first
                if o == half:
                    weight = ring[y % slots, half, dst:]
                elif o > half:  # a forward offset: this row's own
                    weight = ring[y % slots, forward_index(dy, dx, side), dst:]
                else:  # the sample's, for the opposite offset
                    weight = ring[yy % slots, forward_index(-dy, -dx, side), src:]
                k1, k0, w0 = key[yy, src:], key_row[first:], weight_row[first:]
                for i in range(m):
                    k = k1[i]
                    k0[i] = k
                    w0[i] = 0 if k == EMPTY else weight[i]
        for i in range(CHUNK):
            total[i] = 0
        for o in range(count):
            weight_row = weights[o]
            for i in range(CHUNK):
                total[i] += weight_row[i]
        sorted_windows(key, y, x0, radius, plan, tree)
        # the least sorted position whose key has half the weight at or below it
        for i in range(CHUNK):
            low[i] = 0
            high[i] = count - 1
        for _ in range(rounds):
            for i in range(CHUNK):
                probe[i] = tree[ordered[(low[i] + high[i]) >> 1], i]
                below[i] = 0
            for o in range(count):
                key_row, weight_row = keys[o], weights[o]
                for i in range(CHUNK):
                    below[i] += weight_row[i] if key_row[i] <= probe[i] else 0
            for i in range(CHUNK):
                middle = (low[i] + high[i]) >> 1
                enough = 2 * below[i] >= total[i]
                high[i] = middle if enough else high[i]
                low[i] = low[i] if enough else middle + 1
        for i in range(n):
            if moved[y, x0 + i]:
                out[y, x0 + i] = sortable32(tree[ordered[low[i]], i])


@nb.njit(cache=True)
def sorted_windows(key, y, x0, radius, plan, tree):
    """Sort the windows of the :data:`CHUNK` pixels of row ``y`` from ``x0`` in ``tree``.

    ``plan``: :func:`~dcstereo.refine._median.window_plan` ``(steps, exchanges, orders,
    columns)``; ``tree``: int32, its rows (``orders.max() + 1``) of ``CHUNK + 2 radius``
    lanes, lane ``l`` the column ``x0 - radius + l``. The keys of each column's ``2 radius
    + 1`` rows around ``y`` (:data:`EMPTY` outside the image) are sorted by ``columns``,
    then the plan's merges make the blocks of columns and the windows; pixel ``x0 + i``'s
    sorted keys are then ``tree[orders[steps[-1, 7] + k], i]``, ``k`` from 0. Each merge
    an exchange of two rows over the lanes at once (vector code); the keys past the row's
    end, and the lanes of a short chunk's missing pixels, are sorted too and never read.
    """
    height, width = key.shape
    steps, exchanges, orders, columns = plan
    side = 2 * radius + 1
    lanes = CHUNK + side - 1
    first = min(lanes, max(0, radius - x0))  # the lanes of columns inside the image
    last = max(first, min(lanes, width - x0 + radius))
    for dy in range(side):
        row = tree[dy]
        yy = y + dy - radius
        if yy < 0 or yy >= height:
            for i in range(lanes):
                row[i] = EMPTY
            continue
        for i in range(first):
            row[i] = EMPTY
        for i in range(last, lanes):
            row[i] = EMPTY
        src, dst = key[yy, x0 - radius + first :], row[first:]
        for i in range(last - first):
            dst[i] = src[i]
    exchange_rows(tree, columns, lanes)
    for s in range(steps.shape[0]):
        a_order, a_rows, a_shift = steps[s, 0], steps[s, 1], steps[s, 2]
        b_order, b_rows, b_shift = steps[s, 3], steps[s, 4], steps[s, 5]
        start, n = steps[s, 6], CHUNK + steps[s, 10]
        for k in range(a_rows):
            src, dst = tree[orders[a_order + k], a_shift:], tree[start + k]
            for i in range(n):
                dst[i] = src[i]
        for k in range(b_rows):
            src, dst = tree[orders[b_order + k], b_shift:], tree[start + a_rows + k]
            for i in range(n):
                dst[i] = src[i]
        for e in range(steps[s, 8], steps[s, 9]):
            low, high = tree[exchanges[e, 0]], tree[exchanges[e, 1]]
            for i in range(n):
                a = low[i]
                b = high[i]
                low[i] = min(a, b)
                high[i] = max(a, b)

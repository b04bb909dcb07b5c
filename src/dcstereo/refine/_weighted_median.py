"""The colour-weighted median's kernels (:mod:`dcstereo.refine.weighted_median`).

Each sample of a window is an int32 key, its disparity's float32 bits made to sort as
signed integers (:func:`sample_keys`), and an integer weight. A fixed sorting network of
compare-exchanges (Batcher's odd-even merge sort,
:func:`~dcstereo.refine._median.sort_network`) sorts a copy of the keys of :data:`CHUNK`
pixels side by side, each exchange a ``min`` and a ``max`` of two rows of keys (vector
code). The weights stay where they are: a binary search over the sorted keys finds each
pixel's median, the least sorted key whose weight at or below it (a masked sum over the
window's samples, again for all the chunk's pixels at once) reaches half the total. Samples
outside the image or without an estimate get the weight 0 and the largest key,
:data:`EMPTY`: a sample of weight 0 is never the weighted median (the weight at or below
the largest finite value is the whole total, which is positive), so the result is that of
the samples with an estimate alone.
"""

import numba as nb
import numpy as np

from dcstereo.refine._median import exchange_rows, sortable32

#: Pixels of a row whose windows are sorted together: ``81 x 256`` keys, their sorted copy
#: and as many weights (3 x 81 KiB for a 9 x 9 window, in the second-level cache) for each
#: of the network's 864 exchanges and the search's 7 sums. The stage, one thread (AVX2):
#: 128 pixels teddy 56.7 ms and KITTI 000066 142, 256 52.8 and 132, 512 53-58 on teddy.
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


@nb.njit(cache=True, parallel=True)
def weighted_median_rows(key, guide, moved, radius, colour_weight, space_weight, network,
                         sums_like, out):  # fmt: skip
    """Write into ``out`` the colour-weighted median of each moved pixel's window.

    ``key``: :func:`sample_keys` of the disparity map's float32 bits (a NaN or an infinity:
    no estimate); ``guide``: ``(3, H, W)`` integer levels 0..255 (a gray image as three
    equal channels); ``out``: the map's int32 bits, where a pixel with ``moved[y, x]``
    receives the weighted median of the finite values of the ``(2 radius + 1)`` square
    around it, cut at the image's edges, each weighted by ``colour_weight[g] *
    space_weight[dy + radius, dx + radius]``, ``g`` the largest difference of a channel
    between that pixel and the centre: the least value ``v`` with ``2 * (weight of the
    values <= v) >= total weight``. ``colour_weight`` (256) and ``space_weight`` are int32
    tables whose products are under ``2**31`` (a sample's weight, int32);
    ``sums_like``'s integer dtype is that of the window's sums (int32 where twice the
    largest total fits, otherwise int64). ``network``:
    :func:`~dcstereo.refine._median.sort_network` of ``(2 radius + 1)**2``. Rows in parallel.
    """
    height, width = key.shape
    side = 2 * radius + 1
    count = side * side
    rounds = 0  # the binary search's: 2**rounds >= count
    while (1 << rounds) < count:
        rounds += 1
    for y in nb.prange(height):
        keys = np.empty((count, CHUNK), dtype=np.int32)
        weights = np.empty((count, CHUNK), dtype=np.int32)
        ordered = np.empty((count, CHUNK), dtype=np.int32)
        total = np.empty(CHUNK, dtype=sums_like.dtype)
        below = np.empty(CHUNK, dtype=sums_like.dtype)
        low = np.empty(CHUNK, dtype=np.int32)
        high = np.empty(CHUNK, dtype=np.int32)
        probe = np.empty(CHUNK, dtype=np.int32)
        diff = np.empty(CHUNK, dtype=np.int32)
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
                space = space_weight[dy + radius, dx + radius]
                # the samples of this offset inside the image, as views that start at the
                # first of them: every index from 0 up, so that the loops are whole vectors
                m = last - first
                if m > 0:
                    src, dst = x0 + first + dx, x0 + first
                    r1, g1, b1 = guide[0, yy, src:], guide[1, yy, src:], guide[2, yy, src:]
                    r0, g0, b0 = guide[0, y, dst:], guide[1, y, dst:], guide[2, y, dst:]
                    for i in range(m):
                        diff[i] = max(abs(np.int32(r1[i]) - np.int32(r0[i])),
                                      abs(np.int32(g1[i]) - np.int32(g0[i])),
                                      abs(np.int32(b1[i]) - np.int32(b0[i])))  # fmt: skip
                    k1, k0, w0 = key[yy, src:], key_row[first:], weight_row[first:]
                    for i in range(m):  # the weights: a table lookup each (an unsigned
                        k = k1[i]  # index: no test for a negative one)
                        k0[i] = k
                        w0[i] = 0 if k == EMPTY else colour_weight[np.uint32(diff[i])] * space
            for i in range(CHUNK):
                total[i] = 0
            for o in range(count):
                key_row, weight_row, ordered_row = keys[o], weights[o], ordered[o]
                for i in range(CHUNK):
                    total[i] += weight_row[i]
                    ordered_row[i] = key_row[i]
            exchange_rows(ordered, network, CHUNK)
            # the least sorted position whose key has half the weight at or below it
            for i in range(CHUNK):
                low[i] = 0
                high[i] = count - 1
            for _ in range(rounds):
                for i in range(CHUNK):
                    probe[i] = ordered[(low[i] + high[i]) >> 1, i]
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
                    out[y, x0 + i] = sortable32(ordered[low[i], i])

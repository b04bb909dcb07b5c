"""The colour-weighted median's kernels (:mod:`dcstereo.refine.weighted_median`).

Each sample of a window is one int64 key: its disparity's float32 bits made to sort as
signed integers in the high half, its integer weight in the low half. A fixed sorting
network of compare-exchanges (Batcher's odd-even merge sort,
:func:`~dcstereo.refine._median.sort_network`) sorts the keys of :data:`CHUNK` pixels side
by side, each exchange a ``min`` and a ``max`` of two rows of keys (vector code), and a
running sum of the weights in sorted order finds each pixel's median, again for all the
chunk's pixels at once. Samples outside the image or without an estimate get the weight 0
and the largest key: a sample of weight 0 is never the weighted median (the running sum
reaches half the total, which is positive, at a sample of positive weight), so the result
is that of the samples with an estimate alone.
"""

import numba as nb
import numpy as np

from dcstereo.refine._median import exchange_rows

#: Pixels of a row whose windows are sorted together: ``81 x 128`` keys (83 KiB for a 9 x 9
#: window, in the second-level cache) for each of the network's 864 exchanges. On teddy,
#: one thread: 16 pixels 84 ms, 32 67, 64 62, 128 55, 256 59, 512 77.
CHUNK = 128

#: The key of a sample that does not count (outside the image, or without an estimate): the
#: largest value and the weight 0.
EMPTY = np.int64(0x7FFFFFFF00000000)

_LOW = np.int64(0xFFFFFFFF)


@nb.njit(cache=True, inline="always")
def sortable(bits):
    """Return a finite float32's int32 bits as an integer of the same order (-0.0 as +0.0)."""
    if bits == np.int32(-0x80000000):  # -0.0
        return np.int64(0)
    if bits < 0:
        return np.int64(bits ^ 0x7FFFFFFF)
    return np.int64(bits)


@nb.njit(cache=True, parallel=True)
def sample_keys(bits, high):
    """Fill ``high`` (int64) with each pixel's key without its weight.

    A finite value: its :func:`sortable` bits shifted to the high half; a NaN or an
    infinity (no estimate): :data:`EMPTY`, which keeps the weight 0 in the window.
    """
    height, width = bits.shape
    for y in nb.prange(height):
        for x in range(width):
            b = bits[y, x]
            finite = (b & 0x7F800000) != 0x7F800000
            high[y, x] = sortable(b) << 32 if finite else EMPTY


@nb.njit(cache=True, parallel=True)
def weighted_median_rows(high, guide, moved, radius, colour_weight, space_weight, network,
                         out):  # fmt: skip
    """Write into ``out`` the colour-weighted median of each moved pixel's window.

    ``high``: :func:`sample_keys` of the disparity map's float32 bits (a NaN or an infinity:
    no estimate); ``guide``: ``(3, H, W)`` integer levels 0..255 (a gray image
    as three equal channels); ``out``: the map's int32 bits, where a pixel with
    ``moved[y, x]`` receives the weighted median of the finite values of the
    ``(2 radius + 1)`` square around it, cut at the image's edges, each weighted by
    ``colour_weight[g] * space_weight[dy + radius, dx + radius]``, ``g`` the largest
    difference of a channel between that pixel and the centre: the least value ``v`` with
    ``2 * (weight of the values <= v) >= total weight`` (int64 tables, the weights under
    ``2**31``). ``network``: :func:`~dcstereo.refine._median.sort_network` of
    ``(2 radius + 1)**2``. Rows in parallel.
    """
    height, width = high.shape
    side = 2 * radius + 1
    count = side * side
    for y in nb.prange(height):
        keys = np.empty((count, CHUNK), dtype=np.int64)
        total = np.empty(CHUNK, dtype=np.int64)
        running = np.empty(CHUNK, dtype=np.int64)
        found = np.empty(CHUNK, dtype=np.int64)
        done = np.empty(CHUNK, dtype=np.bool_)
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
                row = keys[o]
                yy = y + dy
                if yy < 0 or yy >= height:
                    for i in range(n):
                        row[i] = EMPTY
                    continue
                first = min(n, max(0, -dx - x0))  # the chunk's samples inside the image
                last = max(first, min(n, width - dx - x0))
                for i in range(first):
                    row[i] = EMPTY
                for i in range(last, n):
                    row[i] = EMPTY
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
                    h1, out_row = high[yy, src:], row[first:]
                    for i in range(m):  # the weights: a table lookup each
                        h = h1[i]
                        out_row[i] = h if h == EMPTY else h | (colour_weight[diff[i]] * space)
            for i in range(n):
                total[i] = 0
                running[i] = 0
                found[i] = EMPTY
                done[i] = False
            for o in range(count):
                row = keys[o]
                for i in range(n):
                    total[i] += row[i] & _LOW
            # over all CHUNK columns, a short chunk's unread ones too: with a constant count
            # (exchange_rows is inlined) the compiler makes vector code of the 64-bit min
            # and max where the hardware has no such instruction (AVX2: the stage 1.6x faster)
            exchange_rows(keys, network, CHUNK)
            for o in range(count):  # the first key whose running weight reaches half
                row = keys[o]
                for i in range(n):
                    key = row[i]
                    running[i] += key & _LOW
                    hit = (not done[i]) & (2 * running[i] >= total[i])  # no branch: vectors
                    found[i] = key if hit else found[i]
                    done[i] |= hit
            for i in range(n):
                if moved[y, x0 + i]:
                    s = np.int32(found[i] >> 32)
                    out[y, x0 + i] = s ^ 0x7FFFFFFF if s < 0 else s

"""The median of a full square window by a sorting network, many pixels at a time.

Where every value of a pixel's ``side x side`` window is finite (the interior of a dense
map, as ``sgm`` leaves it), its median is the middle value of the ``side**2`` values, which
a fixed network of compare-exchanges finds: Batcher's odd-even merge sort of the next
power of two, the padding inputs (``+inf``, which never move) and the exchanges that do not
reach the middle output left out (:func:`median_network`: 113 exchanges for 25 values).
Each exchange runs over a whole row of pixels at once (a ``min`` and a ``max`` of two rows
of values), so the work is vector code. The pixels with a non-finite value in their window,
or a window cut by the image's edge, are left to the general kernel.
"""

import numba as nb
import numpy as np


def _batcher(n):
    """Return the exchanges ``(i, j)``, ``i < j``, of Batcher's odd-even merge sort of 2**p."""
    pairs = []
    p = 1
    while p < n:
        k = p
        while k >= 1:
            for j in range(k % p, n - k, 2 * k):
                for i in range(min(k, n - j - k)):
                    if (i + j) // (p * 2) == (i + j + k) // (p * 2):
                        pairs.append((i + j, i + j + k))
            k //= 2
        p *= 2
    return pairs


def sort_network(count: int) -> np.ndarray:
    """Return the exchanges ``(i, j)`` that sort ``count`` values (min to ``i``, max to ``j``).

    Batcher's odd-even merge sort of the next power of two, the exchanges with the padding
    inputs (which would hold ``+inf`` and never move) left out: int64 ``(E, 2)``.
    """
    size = 1
    while size < count:
        size *= 2
    return np.array([(i, j) for i, j in _batcher(size) if j < count], dtype=np.int64).reshape(-1, 2)


def median_network(count: int) -> np.ndarray:
    """Return the exchanges ``(i, j)`` that bring the median of ``count`` values to the middle.

    ``count`` odd. An int64 array ``(E, 2)``; after exchanging (min to ``i``, max to ``j``)
    in order, position ``count // 2`` holds the median: :func:`sort_network` without the
    exchanges that do not reach it.
    """
    needed = {count // 2}
    kept = []
    for i, j in sort_network(count)[::-1].tolist():
        if i in needed or j in needed:
            kept.append((i, j))
            needed |= {i, j}
    return np.array(kept[::-1], dtype=np.int64).reshape(-1, 2)


@nb.njit(cache=True, inline="always")
def exchange_rows(values, network, n):
    """Run ``network`` on the columns ``0..n - 1`` of ``values`` (a row a network input).

    Each exchange ``(i, j)`` puts the ``min`` of rows ``i`` and ``j`` in row ``i`` and the
    ``max`` in row ``j``, over the ``n`` columns at once (vector code): one network per column.
    """
    for e in range(network.shape[0]):
        low = values[network[e, 0]]
        high = values[network[e, 1]]
        for x in range(n):
            a = low[x]
            b = high[x]
            low[x] = min(a, b)
            high[x] = max(a, b)


@nb.njit(cache=True, inline="always")
def sortable32(bits):
    """Return a float32's int32 bits as an int32 of the same order (its own inverse).

    A negative float's bits count down as the float goes down; their magnitude bits
    flipped, they count up. ``-0.0`` sorts just below ``+0.0``, so that every finite value
    keeps its own bits through a sort.
    """
    return bits ^ np.int32(0x7FFFFFFF) if bits < 0 else bits


#: Pixels of a row whose windows :func:`median_rows_network` sorts together: ``25 x 256``
#: int32 keys (25 KiB for the 5 x 5 median) stay in the first-level cache through the
#: network's exchanges, where a whole row's went out to the second (KITTI's 1226 columns:
#: 123 KiB). One thread, AVX2, the 5 x 5 median: teddy 3.06 -> 2.04 ms, KITTI 000066 8.65
#: -> 5.42 (128 columns 2.32 and 6.02, 512 2.41 and 6.47).
CHUNK = 256


@nb.njit(cache=True, parallel=True)
def median_rows_network(bits, radius, network, full, out):
    """``out[y, x]``: the median of the window of each pixel with ``full[y, x]``.

    ``bits``: the map's float32 values as int32 (``d.view(np.int32)``), ``out`` likewise:
    the network sorts their :func:`sortable32` keys, as integers (a float's ``min`` and
    ``max`` must order NaNs and do not become vector code where the hardware has no such
    instruction: on AVX2 the 5 x 5 median took 3.8x the time). ``full`` marks the pixels
    whose whole window (inside the image) holds finite values; the others keep ``out``'s
    value. Rows in parallel, each in chunks of :data:`CHUNK` pixels.
    """
    height, width = bits.shape
    side = 2 * radius + 1
    count = side * side
    inner = width - 2 * radius
    for y in nb.prange(radius, height - radius):
        values = np.empty((count, CHUNK), dtype=np.int32)
        for x0 in range(0, inner, CHUNK):
            n = min(CHUNK, inner - x0)
            for dy in range(side):
                for dx in range(side):
                    src = bits[y - radius + dy, x0 + dx : x0 + dx + n]
                    dst = values[dy * side + dx]
                    for x in range(n):
                        dst[x] = sortable32(src[x])
            exchange_rows(values, network, n)
            middle = values[count // 2]
            for x in range(n):
                if full[y, x0 + x + radius]:
                    out[y, x0 + x + radius] = sortable32(middle[x])

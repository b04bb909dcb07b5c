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


def _batcher_merge(first, count, step, out):
    """Append to ``out`` Batcher's odd-even merge of every ``step``-th wire from ``first``.

    ``count`` wires in all (a power of two), each half sorted: the exchanges ``(i, j)``.
    """
    double = 2 * step
    if double < count:
        _batcher_merge(first, count, double, out)
        _batcher_merge(first + step, count, double, out)
        out.extend((i, i + step) for i in range(first + step, first + count - step, double))
    else:
        out.append((first, first + step))


def merge_network(m: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Return the exchanges that merge two sorted lists, and where the merged values end.

    The lists in rows ``0..m - 1`` and ``m..m + n - 1`` (each sorted); the exchanges
    ``(i, j)`` (int64 ``(E, 2)``, min to ``i``, max to ``j``) leave the ``m + n`` values
    sorted in the rows ``order`` (int64, ``order[k]`` holds the ``k``-th least). Batcher's
    odd-even merge of two lists of the next power of two, their padding (``+inf``, larger
    than any value) followed through it: an exchange of two paddings, or of a value and a
    padding after it, does nothing and is left out; one of a padding and a value after it
    moves the value, which the rows' order records instead of a copy (30 exchanges for two
    lists of 9, 189 for two of 36).

    >>> exchanges, order = merge_network(1, 2)
    >>> exchanges.tolist(), order.tolist()
    ([[0, 1], [2, 1]], [0, 2, 1])
    """
    size = 1
    while size < max(m, n):
        size *= 2
    wires = []
    _batcher_merge(0, 2 * size, 1, wires)
    # the row each wire holds (-1: a padding): the first list, its padding, the second's
    row = [w if w < m else -1 for w in range(size)]
    row += [m + w if w < n else -1 for w in range(size)]
    kept = []
    for i, j in wires:
        if row[j] < 0:  # max(value, +inf) stays where it is, and so does the min
            continue
        if row[i] < 0:  # the value moves down to wire i, the padding up to j
            row[i], row[j] = row[j], -1
            continue
        kept.append((row[i], row[j]))
    order = np.array(row[: m + n], dtype=np.int64)
    return np.array(kept, dtype=np.int64).reshape(-1, 2), order


#: The columns of :func:`window_plan`'s steps.
STEP_FIELDS = (
    "a_order", "a_rows", "a_shift", "b_order", "b_rows", "b_shift", "start", "order",
    "first", "last", "lanes",
)  # fmt: skip


def _plan_of(side, widest):
    """:func:`window_plan` with blocks of up to ``2**widest`` columns (see there)."""
    steps, exchanges, orders = [], [], list(range(side))  # the columns: sorted in place
    start = side  # the buffer's next free row

    def merge(a, a_shift, b, b_shift, lanes):  # a list: (its order's place, its rows)
        nonlocal start
        network, order = merge_network(a[1], b[1])
        steps.append((a[0], a[1], a_shift, b[0], b[1], b_shift, start, len(orders),
                      len(exchanges), len(exchanges) + len(network), lanes))  # fmt: skip
        exchanges.extend((start + network).tolist())
        orders.extend((start + order).tolist())
        start += a[1] + b[1]
        return steps[-1][7], a[1] + b[1]

    blocks = [(0, side)]  # blocks[k]: the block of 2**k columns at every lane
    while len(blocks) <= widest:
        half = 2 ** (len(blocks) - 1)
        blocks.append(merge(blocks[-1], 0, blocks[-1], half, side - 2 * half))
    pieces, offset = [], 0  # the window: the widest blocks from its left, then side's bits
    while offset < side:
        k = min(widest, (side - offset).bit_length() - 1)
        pieces.append((blocks[k], offset))
        offset += 1 << k
    window, shift = pieces[-1]
    for block, offset in pieces[-2::-1]:  # merged from the right: the shortest lists first
        window, shift = merge(block, offset, window, shift, 0), 0
    return steps, exchanges, orders


def window_plan(side: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Return how the windows of a row are sorted from their sorted columns: the merges.

    Each pixel's ``side x side`` window is the ``side`` columns around it. The columns of a
    row of windows are sorted first (rows ``0..side - 1`` of a buffer, a lane a column, by
    :func:`sort_network`); then blocks of 2, 4, ... columns are merged, each from two
    blocks of half its width (a block at each lane, shared by the windows that hold it),
    and each window from the blocks that make it, the widest from its left (9 = 4 + 4 + 1),
    merged from the right, by :func:`merge_network`; of the widest blocks, the choice of
    fewest exchanges. A 9 x 9 window: 439 exchanges and 28 for its column a pixel, where
    sorting the window takes 864.

    Returns ``(steps, exchanges, orders, columns)``. ``steps``: int64 ``(S, 11)``, a
    merge a row, its fields :data:`STEP_FIELDS`: the first list is the ``a_rows`` rows
    ``orders[a_order:]`` of the buffer (sorted in that order), each lane read ``a_shift``
    lanes on, the second likewise; they are copied to the rows from ``start``, then
    ``exchanges[first:last]`` (rows of the buffer) run over the lanes ``0 .. lanes + n -
    1`` (``n`` the windows of the row; a block is needed ``side`` lanes past them, less its
    width), which leaves the merged values sorted in the rows ``orders[order:]``.
    ``columns``: :func:`sort_network` of ``side``. The last step's order gives the
    windows' ``side**2`` values, least first.

    >>> steps, exchanges, orders, columns = window_plan(9)
    >>> len(steps), len(exchanges), len(columns)
    (4, 439, 28)
    """
    plans = [_plan_of(side, widest) for widest in range(side.bit_length())]
    steps, exchanges, orders = min(plans, key=lambda plan: len(plan[1]))
    return (
        np.array(steps, dtype=np.int64).reshape(-1, len(STEP_FIELDS)),
        np.array(exchanges, dtype=np.int64).reshape(-1, 2),
        np.array(orders, dtype=np.int64),
        sort_network(side),
    )


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

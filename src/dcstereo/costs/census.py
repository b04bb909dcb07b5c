"""Matching costs of the semi-global method: the census transform and its cost volume.

The census transform (Zabih and Woodfill, ECCV 1994) replaces each pixel by a bit string:
one bit per pixel of a window around it, set where that pixel is darker than the centre.
Two pixels are compared by the Hamming distance of their strings (a popcount), which does
not change when either view's brightness changes by any increasing function: a gain, an
offset, a gamma. ``cost="census-ad"`` adds the absolute difference of the colours,
truncated, as a weak second term (Mei et al., *On building an accurate stereo matching
system on graphics hardware*, 2011, combine the two; Hirschmueller and Scharstein, CVPR
2007, found census the most robust single cost).

All values are integers, so the volume is exact and its sums do not depend on the order of
evaluation. The cost of left pixel ``x`` at disparity ``d = dmin + k`` compares it with
right pixel ``x - d``; a right pixel outside the image is replaced by the nearest one inside
(the right rows are padded by repetition), so every cell holds a cost and the aggregation
runs over full rows. ``tests/naive_sgm.py`` holds the slow twins.
"""

import numba as nb
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic, overload

from dcstereo._vector.sgm import next_task


@nb.njit(cache=True, parallel=True)
def reversed_padded_rows(rows_in, before, after):
    """Return each row of ``rows_in`` (``(N, W)``) padded and reversed, in one pass.

    Padded by ``before`` repeated first values and ``after`` repeated last ones, then
    reversed: ``out[n, j] = rows_in[n, clip(W + after - 1 - j, 0, W - 1)]``, ``W + before +
    after`` columns (the right view as the cost kernel reads it). Rows in parallel. The
    copy reads a reversed view of the row from index 0 up, which the compiler makes vector
    code of (indexed from the end, it did not: teddy's codes and colours 0.84 -> 0.24 ms).
    """
    count, width = rows_in.shape
    length = width + before + after
    out = np.empty((count, length), dtype=rows_in.dtype)
    for n in nb.prange(count):
        row = rows_in[n]
        dst = out[n]
        last = row[width - 1]
        first = row[0]
        for j in range(after):
            dst[j] = last
        backwards, body = row[::-1], dst[after : after + width]
        for j in range(width):
            body[j] = backwards[j]
        for j in range(after + width, length):
            dst[j] = first
    return out


@nb.njit(cache=True, parallel=True)
def census_transform(padded, rows, cols, out):
    """Write the census codes over a ``rows x cols`` window into ``out``.

    ``out`` is ``(H, W)``, uint32 for up to 32 bits, else uint64.

    ``padded`` is the int32 intensity padded by ``rows // 2`` rows and ``cols // 2``
    columns on each side, repeating its edges (``signal.padded_signal``). Bit order: the
    window in raster order, the centre left out, the first pixel in the highest bit used;
    a bit is 1 where that pixel is darker (smaller) than the centre. ``rows * cols - 1``
    must be at most 64.
    """
    height, width = out.shape
    ry, rx = rows // 2, cols // 2
    for y in nb.prange(height):
        code = out[y]
        centre = padded[y + ry, rx : rx + width]
        for x in range(width):
            code[x] = 0
        for dy in range(rows):
            for dx in range(cols):
                if dy == ry and dx == rx:
                    continue
                other = padded[y + dy, dx : dx + width]
                for x in range(width):
                    code[x] = (code[x] << 1) | (other[x] < centre[x])


def popcount(value):
    """Return the number of set bits of an unsigned integer (compiled: one ``llvm.ctpop``)."""
    return bin(int(value)).count("1")


def _ctpop_call(builder, value, width):
    """Emit ``llvm.ctpop.i{width}`` of ``value``'s low ``width`` bits; the count, ``width`` bits."""
    kind = ir.IntType(width)
    fn = cgutils.get_or_insert_function(
        builder.module, ir.FunctionType(kind, [kind]), f"llvm.ctpop.i{width}"
    )
    return builder.call(fn, [builder.trunc(value, kind) if value.type.width > width else value])


@intrinsic
def _ctpop(typingctx, value):
    if not (isinstance(value, types.Integer) and value.bitwidth in (32, 64)):
        return None
    width = value.bitwidth

    def codegen(context, builder, sig, args):
        count = _ctpop_call(builder, args[0], width)
        return builder.zext(count, ir.IntType(64)) if width < 64 else count

    return types.int64(value), codegen


@overload(popcount)
def _popcount_compiled(value):
    return lambda value: _ctpop(value)


def code_planes(codes: np.ndarray) -> np.ndarray:
    """Return census codes as :func:`pixel_cost_row` reads them: two planes, ``(2, H, W)``.

    uint32 codes (windows of up to 33 pixels) as their low and high 16 bits, uint16 planes;
    uint64 codes as their low and high 32 bits, uint32 planes. A Hamming distance is then
    the sum of two popcounts of the planes' own width: in 16-bit lanes the popcount, the
    sum and the cost are vector code of one width, where a 32-bit popcount had each vector
    of codes narrowed to the costs' lanes (AVX2, one thread, the per-pixel costs of KITTI
    000066's 24-bit codes: 19.4 -> 13.8 ms, teddy's 10.0 -> 7.1, in one process, loaded).

    >>> code_planes(np.array([[0x12345678]], np.uint32))[:, 0, 0].tolist() == [0x5678, 0x1234]
    True
    """
    half = {np.dtype(np.uint32): np.uint16, np.dtype(np.uint64): np.uint32}.get(codes.dtype)
    if half is None or codes.ndim != 2:
        raise ValueError(
            f"census codes must be 2-D uint32 or uint64, not {codes.ndim}-D {codes.dtype}"
        )
    out = np.empty((2, *codes.shape), dtype=half)
    shift = 8 * out.itemsize
    kind = codes.dtype.type
    _split_codes(codes, kind(shift), kind((1 << shift) - 1), out)
    return out


@nb.njit(cache=True, parallel=True)
def _split_codes(codes, shift, mask, out):
    """``out[0]``: the bits of ``codes`` under ``mask``, ``out[1]`` those from ``shift`` on."""
    height, width = codes.shape
    for y in nb.prange(height):
        row, low, high = codes[y], out[0, y], out[1, y]
        for x in range(width):
            low[x] = row[x] & mask
            high[x] = row[x] >> shift


def plane_bits(a, b):
    """Return the number of bits that differ between ``a`` and ``b``, two codes of a plane.

    Compiled: one ``llvm.ctpop`` of the planes' own width (16 bits for uint16 planes).
    """
    return popcount(a ^ b)


@overload(plane_bits, inline="always")
def _plane_bits_compiled(a, b):
    if isinstance(a, types.Integer) and a.bitwidth == 16:
        return lambda a, b: np.int16(_ctpop16(a ^ b))
    return lambda a, b: np.int16(_ctpop(a ^ b))


@intrinsic
def _ctpop16(typingctx, value):
    """``llvm.ctpop.i16`` of a value's low 16 bits (numba widens a uint16 ``^``)."""
    if not isinstance(value, types.Integer):
        return None

    def codegen(context, builder, sig, args):
        return _ctpop_call(builder, args[0], 16)

    return types.uint16(value), codegen


@nb.njit(cache=True)
def pixel_cost_row(codes_l, codes_r, colour_l, colour_r, y, dmin, ndisp, bit_cost, ad_max, out):
    """One row of per-pixel costs: ``out[x, k]`` for ``d = dmin + k``, ``k < ndisp``.

    In thirds of a cost unit: ``3 * bit_cost * popcount(L ^ R)`` of the census codes of
    left pixel ``x`` and right pixel ``x - d`` (in two planes, :func:`code_planes`: the
    popcounts of both, :func:`plane_bits`), plus, where ``ad_max > 0``, ``min(AD, 3 *
    ad_max)``, ``AD`` the sum of the absolute differences of the three channels of
    ``colour_l`` (``(3, H, W)``, 0..255), or three times that of its one channel
    (``(1, H, W)``): the mean absolute difference of the channels counts one unit per gray
    level, and a gray image gives the costs of its three-channel copy. The right view
    (``codes_r``, ``colour_r``) is padded by repetition (``max(0, max_disparity)`` columns
    on the left, ``max(0, -dmin)`` on the right) and then reversed: right pixel ``x - d`` of
    row ``y`` is at ``[.., y, width - 1 - x + dmin + max(0, -dmin) + k]``, so that the
    disparities of a left pixel run forward in memory. One loop over the disparities of a
    pixel makes both terms.
    """
    width = codes_l.shape[2]
    after = max(0, -dmin)
    census = np.int16(3 * bit_cost)
    limit = np.int16(3 * ad_max)
    low, high = codes_r[0, y], codes_r[1, y]
    if ad_max <= 0:
        for x in range(width):
            start = width - 1 - x + dmin + after
            a, b = codes_l[0, y, x], codes_l[1, y, x]
            row = out[x]
            w0, w1 = low[start : start + ndisp], high[start : start + ndisp]
            for k in range(ndisp):
                row[k] = np.int16(census * (plane_bits(a, w0[k]) + plane_bits(b, w1[k])))
    elif colour_l.shape[0] == 3:
        r0, r1, r2 = colour_r[0, y], colour_r[1, y], colour_r[2, y]
        for x in range(width):
            start = width - 1 - x + dmin + after
            a, b = codes_l[0, y, x], codes_l[1, y, x]
            l0, l1, l2 = colour_l[0, y, x], colour_l[1, y, x], colour_l[2, y, x]
            row = out[x]
            w0, w1 = low[start : start + ndisp], high[start : start + ndisp]
            c0, c1, c2 = (
                r0[start : start + ndisp],
                r1[start : start + ndisp],
                r2[start : start + ndisp],
            )
            for k in range(ndisp):
                ad = np.int16(
                    np.int16(abs(np.int16(l0 - c0[k])))
                    + np.int16(abs(np.int16(l1 - c1[k])))
                    + np.int16(abs(np.int16(l2 - c2[k])))
                )
                bits = np.int16(plane_bits(a, w0[k]) + plane_bits(b, w1[k]))
                row[k] = np.int16(census * bits + min(ad, limit))
    else:
        r0 = colour_r[0, y]
        for x in range(width):
            start = width - 1 - x + dmin + after
            a, b = codes_l[0, y, x], codes_l[1, y, x]
            l0 = colour_l[0, y, x]
            row = out[x]
            w0, w1 = low[start : start + ndisp], high[start : start + ndisp]
            c0 = r0[start : start + ndisp]
            for k in range(ndisp):
                ad = np.int16(3 * np.int16(abs(np.int16(l0 - c0[k]))))
                bits = np.int16(plane_bits(a, w0[k]) + plane_bits(b, w1[k]))
                row[k] = np.int16(census * bits + min(ad, limit))


@nb.njit(cache=True, parallel=True)
def cost_volume(
    codes_l, codes_r, colour_l, colour_r, dmin, ndisp, bit_cost, ad_max, box, reciprocal,
    pad_cost, y_begin, out, threads=1,
):  # fmt: skip
    """Write the box-averaged cost volume of rows ``y_begin..``: ``out[y - y_begin, x, k]``.

    ``out`` is ``(rows, W, Dp)``. Each cell is the mean, rounded down, of the per-pixel
    costs (``pixel_cost_row``) over the ``box x box`` square around ``(y, x)`` at the same
    disparity, pixels beyond the image repeating its edge: the sum times ``reciprocal``, a
    float32 just above ``1 / box**2``, truncated (``box_reciprocal``: exact for every sum
    the caller allows). The lanes ``k >= ndisp`` up to ``Dp`` (the vector padding) hold
    ``pad_cost``. The per-pixel costs and the box run over :func:`cost_span` lanes: all
    ``Dp`` where the right rows hold the columns (padded by ``Dp - ndisp`` more before, as
    ``sgm`` pads them), so that every loop over a pixel's lanes is whole vectors. Rows in
    parallel, in chunks of 32 (each chunk makes the ``box - 1`` per-pixel rows around it
    again), handed out one at a time to ``threads`` (numba's thread count; default 1) as
    each is free (``sgm_simd.next_task``).
    """
    rows = out.shape[0]
    span = cost_span(codes_l.shape[2], codes_r.shape[2], dmin, ndisp, out.shape[2])
    chunk = 32
    nchunks = (rows + chunk - 1) // chunk
    counter = np.zeros(1, dtype=np.int64)
    for _ in nb.prange(max(1, min(threads, nchunks))):
        c = next_task(counter)
        while c < nchunks:
            y0 = y_begin + c * chunk
            y1 = min(y_begin + rows, y0 + chunk)
            _volume_rows(
                codes_l, codes_r, colour_l, colour_r, dmin, ndisp, span, bit_cost, ad_max,
                box, reciprocal, pad_cost, y0, y1, y_begin, out,
            )  # fmt: skip
            c = next_task(counter)


@nb.njit(cache=True)
def _volume_rows(
    codes_l, codes_r, colour_l, colour_r, dmin, ndisp, span, bit_cost, ad_max, box,
    reciprocal, pad_cost, y0, y1, y_begin, out,
):  # fmt: skip
    """Make rows ``y0..y1 - 1`` of :func:`cost_volume`, over ``span`` lanes (:func:`cost_span`).

    A function of its own: compiled outside the parallel loop, its loops are vectorized.
    """
    _, height, width = codes_l.shape
    radius = box // 2
    ring = np.empty((box, width, span), dtype=np.int16)
    vertical = np.empty(box_scratch(width, box, span), dtype=np.int16)
    for t in range(box - 1):  # rows y0 - radius .. y0 + radius - 1
        yy = min(max(y0 - radius + t, 0), height - 1)
        pixel_cost_row(
            codes_l, codes_r, colour_l, colour_r, yy, dmin, span, bit_cost, ad_max,
            ring[(y0 - radius + t) % box],
        )  # fmt: skip
    for y in range(y0, y1):
        yy = min(y + radius, height - 1)
        pixel_cost_row(
            codes_l, codes_r, colour_l, colour_r, yy, dmin, span, bit_cost, ad_max,
            ring[(y + radius) % box],
        )  # fmt: skip
        _box_row(ring, width, span, box, reciprocal, vertical, out[y - y_begin], pad_cost, ndisp)


@nb.njit(cache=True)
def cost_span(width, right_columns, dmin, ndisp, lanes):
    """Return how many lanes of a pixel :func:`cost_volume` computes: ``ndisp`` to ``lanes``.

    The disparities ``dmin + k`` for ``k`` up to all ``lanes`` whose right pixels the right
    rows (``right_columns`` of them, :func:`pixel_cost_row`'s layout) hold for every left
    pixel: a loop over a pixel's disparities that ends on a whole vector runs no scalar
    remainder (teddy's 60 disparities as 64 lanes: its per-pixel costs 10.5 -> 7.8 ms, one
    thread, AVX2). The lanes past ``ndisp`` are then set to the padding cost.

    >>> cost_span.py_func(100, 100 + 59, 0, 60, 64), cost_span.py_func(100, 100 + 63, 0, 60, 64)
    (60, 64)
    """
    after = max(0, -dmin)
    # left pixel 0 reads the most: right columns width - 1 + dmin + after + k
    held = right_columns - (width - 1 + dmin + after)
    return max(ndisp, min(lanes, held))


#: The 3 x 3 box's mean, rounded down, as a multiplication and a shift: ``(s * 7282) >> 16
#: == s // 9`` for every sum ``0 <= s <= 32767`` (the int16 sums; checked in the tests), the
#: same value as ``reciprocal``'s float path gives, in 16-bit lanes (AVX2: the cost volume
#: about 10 % faster than through float32).
BOX3_MULTIPLIER = 7282


@nb.njit(cache=True)
def box_scratch(width, box, span):
    """Return how many int16 values :func:`_box_row`'s column sums take.

    A row's, with ``box // 2`` repeated edge columns each side; three pixels' for the
    3 x 3 box (:func:`_box3_row`).

    >>> box_scratch.py_func(100, 5, 64), box_scratch.py_func(100, 3, 64)
    (6656, 192)
    """
    return 3 * span if box == 3 else (width + box - 1) * span


@nb.njit(cache=True)
def _box_row(ring, width, span, box, reciprocal, vertical, out_row, pad_cost, ndisp):
    """``out_row[x, k]``: the mean over the ring's rows and ``box`` columns around ``x``.

    ``vertical`` is an int16 scratch of :func:`box_scratch` values: the column sums,
    with ``box // 2`` repeated edge columns on each side (one flat loop over ``(x, k)``);
    then each pixel's ``box`` columns are summed, averaged and stored in one loop (a 3 x 3
    box by :data:`BOX3_MULTIPLIER`, others by ``reciprocal``). The ring holds ``span``
    lanes of a pixel (:func:`cost_span`), of which the first ``ndisp`` are disparities;
    lanes from ``ndisp`` on receive ``pad_cost``. A 3 x 3 box: :func:`_box3_row`, the same
    values.
    """
    if box == 3:
        _box3_row(ring, width, span, vertical, out_row, pad_cost, ndisp)
        return
    radius = box // 2
    lanes = out_row.shape[1]
    n = width * span
    body = vertical[radius * span : radius * span + n]
    first = ring[0].reshape(n)
    for i in range(n):
        body[i] = first[i]
    for t in range(1, box):
        other = ring[t].reshape(n)
        for i in range(n):
            body[i] += other[i]
    for e in range(radius):  # the repeated edge columns
        for k in range(span):
            vertical[e * span + k] = body[k]
            vertical[(radius + width + e) * span + k] = body[n - span + k]
    for x in range(width):
        dst = out_row[x]
        for k in range(span):
            total = np.int16(0)
            for dx in range(box):
                total += vertical[(x + dx) * span + k]
            dst[k] = np.int16(np.float32(total) * reciprocal)
        for k in range(ndisp, lanes):
            dst[k] = pad_cost


@nb.njit(cache=True)
def _box3_row(ring, width, span, vertical, out_row, pad_cost, ndisp):
    """:func:`_box_row` of a 3 x 3 box, its column sums three at a time.

    The first ``3 * span`` values of ``vertical`` hold the column sums of pixels ``x - 1``,
    ``x`` and ``x + 1`` in turn (the edge columns repeated), each made just before the
    pixel whose box reads it last: they stay in the first-level cache, where a whole row's
    went through the second (KITTI's rows of 1226 x 128 lanes, 314 KB: 18.4-19.0 -> 12.9-13.9
    ms a volume of 370 rows, one thread). The mean by :data:`BOX3_MULTIPLIER`.
    """
    lanes = out_row.shape[1]
    r0, r1, r2 = ring[0], ring[1], ring[2]
    cols = vertical[: 3 * span].reshape(3, span)
    edge, first = cols[0], cols[1]  # the repeated column before pixel 0, and pixel 0's
    a, b, c = r0[0], r1[0], r2[0]
    for k in range(span):
        first[k] = a[k] + b[k] + c[k]
    for k in range(span):
        edge[k] = first[k]
    for x in range(width):
        after = cols[(x + 2) % 3]  # pixel x + 1's sums (the last column repeated)
        xx = min(x + 1, width - 1)
        a, b, c = r0[xx], r1[xx], r2[xx]
        for k in range(span):
            after[k] = a[k] + b[k] + c[k]
        p, q = cols[x % 3], cols[(x + 1) % 3]
        dst = out_row[x]
        for k in range(span):
            total = np.int32(np.int16(p[k] + q[k] + after[k]))
            dst[k] = np.int16((total * BOX3_MULTIPLIER) >> 16)
        for k in range(ndisp, lanes):
            dst[k] = pad_cost


def box_reciprocal(box: int, largest: int) -> np.float32:
    """Return the float32 ``r`` nearest above ``1 / box**2``, checked exact.

    Checked to give the floor of ``s / box**2`` as ``int(float32(s) * r)`` for every sum
    ``0 <= s <= largest``.

    Raises ``ValueError`` when it does not (costs too large for the box, or a sum past the
    int16 box sums).
    """
    area = box * box
    r = np.float32(1.0 / area)
    if float(r) * area < 1.0:
        r = np.nextafter(r, np.float32(1.0))
    sums = np.arange(largest + 1, dtype=np.int64)
    exact = np.array_equal((sums.astype(np.float32) * r).astype(np.int64), sums // area)
    if largest > 32767 or not exact:
        raise ValueError(f"costs up to {largest} are too large to average over a {box} x {box} box")
    return r

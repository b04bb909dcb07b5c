"""Hand-written vector code, part 1: the building blocks and the small operations.

Where numba's loop vectorizer cannot express a loop well, it is written as LLVM vector
code: the values of ``BAND_ROWS`` lanes as one ``<R x double>`` (or ``<R x i32>``), built by
a numba ``@intrinsic`` that emits the IR; numba compiles and caches it with its callers.
Every operation here is first a plain-Python function (its plain form, run as such under
``NUMBA_DISABLE_JIT`` and by the tests), and an ``@overload`` of that function gives
compiled callers the vector form; ``tests/test_simd.py`` holds each vector form to its plain
form, byte for byte. Kernels call the plain name and get the vector code when compiled.

This module: the IR building blocks the three ``simd`` modules share, what numba compiles
for (``compile_target``), an array's address, ``floor(log2 n)`` by ``ctlz``, the cycle
counter, the rows of a band as lanes (a transposition in registers), the RGB pixels of the
matching signal, and the window SSD of ``dc``'s search. ``simd_costs`` holds the band cost
columns and their block match, ``simd_dp`` the DP cells of a band's column.
"""

import time

import numba as nb
import numpy as np
from llvmlite import binding as llvm
from llvmlite import ir
from numba.core import cgutils, config, types
from numba.extending import intrinsic, overload

from dcstereo._vector import VECTOR

#: Rows of a band, the lanes of the vector code: eight float64 values fill one AVX-512
#: vector. A module constant, not an argument, on purpose: the compiler must see the trip
#: count of the innermost loops to turn each of them into whole vector operations without a
#: remainder loop.
BAND_ROWS = 8

# --------------------------------------------------------------------------- IR building blocks

_VEC_F64 = ir.VectorType(ir.DoubleType(), BAND_ROWS)
_VEC_I64 = ir.VectorType(ir.IntType(64), BAND_ROWS)
_VEC_I32 = ir.VectorType(ir.IntType(32), BAND_ROWS)
_I64 = ir.IntType(64)
_FLOOR = f"llvm.floor.v{BAND_ROWS}f64"
_FMA = f"llvm.fma.v{BAND_ROWS}f64"


def _vector_of(value, vtype):
    return ir.Constant(vtype, [value] * BAND_ROWS)


def _broadcast(builder, value, vtype):
    undef = ir.Constant(vtype, ir.Undefined)
    first = builder.insert_element(undef, value, ir.Constant(ir.IntType(32), 0))
    lanes = ir.Constant(ir.VectorType(ir.IntType(32), BAND_ROWS), [0] * BAND_ROWS)
    return builder.shuffle_vector(first, undef, lanes)


def _vector_call(builder, name, *values):
    signature = ir.FunctionType(_VEC_F64, [_VEC_F64] * len(values))
    return builder.call(cgutils.get_or_insert_function(builder.module, signature, name), values)


def _vector_min(builder, a, b):
    # a < b ? a : b: the value of numba's min for these operands (no NaN), one vminpd
    return builder.select(builder.fcmp_ordered("<", a, b), a, b)


def _words(*values):
    # the offsets and counts of the vector code: 64-bit integers, as its IR takes them
    return all(isinstance(v, types.Integer) and v.bitwidth == 64 for v in values)


def _contiguous(array, dtype, ndim=1):
    return (
        isinstance(array, types.Array)
        and array.ndim == ndim
        and array.layout == "C"
        and (array.dtype == dtype)
    )


def _array_data(context, builder, sig, args, i):
    """Return the data pointer of argument ``i`` of an intrinsic (an array)."""
    return context.make_array(sig.args[i])(context, builder, args[i]).data


def _element_bytes(vtype):
    element = vtype.element
    return 8 if isinstance(element, ir.DoubleType) else element.width // 8


def _load_vector(builder, data, index, vtype=_VEC_F64):
    """Load the ``R`` values of ``data`` (a pointer to ``vtype``'s elements) at ``index``."""
    pointer = builder.bitcast(builder.gep(data, [index]), vtype.as_pointer())
    return builder.load(pointer, align=_element_bytes(vtype))


def _store_vector(builder, value, data, index):
    """Store the vector ``value`` into ``data`` (a pointer to its elements) at ``index``."""
    pointer = builder.bitcast(builder.gep(data, [index]), value.type.as_pointer())
    builder.store(value, pointer, align=_element_bytes(value.type))


def _absent(arg_type):
    """Whether an optional argument of an intrinsic or overload was left out (None)."""
    return isinstance(arg_type, (types.NoneType, types.Omitted))


def compile_target():
    """Return what numba compiles for: ``(cpu name, features)``, features as ``"+avx2"`` etc.

    The host's, unless ``NUMBA_CPU_NAME`` / ``NUMBA_CPU_FEATURES`` set them.
    """
    name = config.CPU_NAME or llvm.get_host_cpu_name()
    features = config.CPU_FEATURES or llvm.get_host_cpu_features().flatten()
    return name, features.split(",")


def _wide_vectors():
    """Whether numba compiles for AVX-512 (32 vector registers, ``R`` lanes in one)."""
    return "+avx512f" in compile_target()[1]


# --------------------------------------------------------------------------- address


def _address(arr):
    """Return the address of ``arr``'s first element, an unsigned integer."""
    return np.uint64(arr.ctypes.data)


@intrinsic
def _data_pointer(typingctx, arr):
    def codegen(context, builder, signature, args):
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        return builder.ptrtoint(ary.data, context.get_value_type(types.uintp))

    return types.uintp(arr), codegen


@overload(_address)
def _address_compiled(arr):
    # ``arr.ctypes`` would keep the calling functions out of numba's cache
    return lambda arr: _data_pointer(arr)


# --------------------------------------------------------------------------- floor(log2 n)


def _floor_log2(n):
    """Return ``floor(log2(n))`` of an integer ``n >= 1``.

    Compiled code runs ``_floor_log2_ctlz``: 63 less the leading zeros of the 64-bit
    value (one ``lzcnt``), where a loop that doubles a power of two until it passes ``n``
    ends on a branch that depends on ``n``, mispredicted from one interval to the next.
    """
    return int(n).bit_length() - 1


@intrinsic
def _floor_log2_ctlz(typingctx, n):
    if not _words(n):
        return None

    def codegen(context, builder, sig, args):
        flag = ir.IntType(1)
        ctlz = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(_I64, [_I64, flag]), "llvm.ctlz.i64"
        )
        zeros = builder.call(ctlz, [args[0], ir.Constant(flag, 1)])  # n >= 1: never 64
        return builder.sub(ir.Constant(_I64, 63), zeros)

    return types.int64(n), codegen


@overload(_floor_log2)
def _floor_log2_compiled(n):
    return lambda n: _floor_log2_ctlz(n)


# --------------------------------------------------------------------------- cycle counter


def cycle_counter():
    """Plain Python's stand-in for the cycle counter (``NUMBA_DISABLE_JIT``): nanoseconds."""
    return time.perf_counter_ns()


@intrinsic
def _cycle_counter(typingctx):
    """Read the processor's cycle counter (``llvm.readcyclecounter``: the TSC on x86)."""

    def codegen(context, builder, sig, args):
        counter = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(_I64, []), "llvm.readcyclecounter"
        )
        return builder.call(counter, [])

    return types.int64(), codegen


@overload(cycle_counter)
def _cycle_counter_compiled():
    return lambda: _cycle_counter()


# --------------------------------------------------------------------------- rows as lanes


def _lane_rows_copy(src, rows, o_rows, dst, o_dst, reverse):
    """``dst[o_dst + q * R + r] = src[rows[o_rows + r], xp]``: ``R`` rows as the lanes.

    ``q = xp``, or ``wp - 1 - xp`` with ``reverse``. Compiled code runs
    ``_lane_rows_forward`` or ``_lane_rows_reversed`` for int32 signals at least ``R``
    pixels wide (vector code, the same values).
    """
    width_p = src.shape[1]
    nr = BAND_ROWS
    for r in range(nr):
        y = rows[o_rows + r]
        for xp in range(width_p):
            q = width_p - 1 - xp if reverse else xp
            dst[o_dst + q * nr + r] = src[y, xp]


_lane_rows_loop = nb.njit(cache=True, inline="always")(_lane_rows_copy)


# The copy above, scalar, stores one 32-bit value 32 bytes after the last: two loads and
# two stores a pixel of the two views. The vector form loads ``R`` pixels of each of the
# ``R`` rows, transposes the ``R x R`` block in registers and stores each pixel's ``R``
# lanes as one vector. A last block that would pass the row's end is taken ``R`` pixels
# back from it instead: it stores some values twice, the same values.


def _transpose_block(builder, vectors):
    """Return the transpose of ``n`` vectors of ``n`` lanes (``vectors[r][c]`` -> ``[c][r]``).

    ``n`` (``R`` in the band kernels) is a power of two; the tests run other sizes too.
    """
    n = len(vectors)
    mask_type = ir.VectorType(ir.IntType(32), n)

    def shuffle(a, b, lanes):
        return builder.shuffle_vector(a, b, ir.Constant(mask_type, lanes))

    if n == 8:
        # 24 shuffles that AVX2 has as single instructions (the generic rounds below cross
        # the 128-bit halves every time: 48): pairs of lanes interleaved within each half
        # (rows 2i, 2i + 1), then pairs of pairs (a column's four rows of a half), then the
        # halves exchanged
        t = []
        for i in range(0, 8, 2):
            t += [shuffle(vectors[i], vectors[i + 1], [0, 8, 1, 9, 4, 12, 5, 13]),
                  shuffle(vectors[i], vectors[i + 1], [2, 10, 3, 11, 6, 14, 7, 15])]  # fmt: skip
        u = []
        for i in (0, 4):
            for a, b in ((t[i], t[i + 2]), (t[i + 1], t[i + 3])):
                u += [shuffle(a, b, [0, 1, 8, 9, 4, 5, 12, 13]),
                      shuffle(a, b, [2, 3, 10, 11, 6, 7, 14, 15])]  # fmt: skip
        # u[c] (c < 4): column c of rows 0-3 in its low half, column c + 4 in its high half
        low, high = [0, 1, 2, 3, 8, 9, 10, 11], [4, 5, 6, 7, 12, 13, 14, 15]
        return [shuffle(u[c % 4], u[c % 4 + 4], low if c < 4 else high) for c in range(8)]
    # any other n: log2 n rounds of interleaving rows i and i + n / 2, each of which
    # rotates the bits of a value's (row, column) index by one place
    half = n // 2
    low = [i // 2 + (n if i % 2 else 0) for i in range(n)]
    high = [half + i // 2 + (n if i % 2 else 0) for i in range(n)]
    for _ in range(n.bit_length() - 1):
        out = []
        for i in range(half):
            out.append(shuffle(vectors[i], vectors[i + half], low))
            out.append(shuffle(vectors[i], vectors[i + half], high))
        vectors = out
    return vectors


def _lane_rows_codegen(reverse):
    def codegen(context, builder, sig, args):
        _, _, o_rows, _, o_dst = args
        source = context.make_array(sig.args[0])(context, builder, args[0])
        width_p = cgutils.unpack_tuple(builder, source.shape, 2)[1]
        rows = _array_data(context, builder, sig, args, 1)
        dst = _array_data(context, builder, sig, args, 3)
        nr = ir.Constant(_I64, BAND_ROWS)
        starts = []  # the first pixel of each lane's row
        for r in range(BAND_ROWS):
            y = builder.load(builder.gep(rows, [builder.add(o_rows, ir.Constant(_I64, r))]))
            starts.append(builder.gep(source.data, [builder.mul(y, width_p)]))
        last = builder.sub(width_p, nr)
        blocks = builder.udiv(builder.add(width_p, ir.Constant(_I64, BAND_ROWS - 1)), nr)
        with cgutils.for_range(builder, blocks) as loop:
            xp = builder.mul(loop.index, nr)
            xp = builder.select(builder.icmp_unsigned(">", xp, last), last, xp)
            loaded = [_load_vector(builder, start, xp, _VEC_I32) for start in starts]
            for c, lanes in enumerate(_transpose_block(builder, loaded)):
                q = builder.add(xp, ir.Constant(_I64, c))
                if reverse:
                    q = builder.sub(builder.sub(width_p, ir.Constant(_I64, 1)), q)
                _store_vector(builder, lanes, dst, builder.add(o_dst, builder.mul(q, nr)))
        return context.get_dummy_value()

    return codegen


def _lane_rows_intrinsic(reverse):
    @intrinsic
    def vector(typingctx, src, rows, o_rows, dst, o_dst):
        if not (
            _contiguous(src, types.int32, 2)
            and _contiguous(rows, types.int64)
            and _contiguous(dst, types.int32)
            and _words(o_rows, o_dst)
        ):
            return None
        return types.void(src, rows, o_rows, dst, o_dst), _lane_rows_codegen(reverse)

    return vector


_lane_rows_forward = _lane_rows_intrinsic(False)
_lane_rows_reversed = _lane_rows_intrinsic(True)


@overload(_lane_rows_copy)
def _lane_rows_compiled(src, rows, o_rows, dst, o_dst, reverse):
    if not VECTOR:  # DCSTEREO_VECTOR=0: numba compiles the plain form
        return _lane_rows_copy
    if not (
        _contiguous(src, types.int32, 2)
        and _contiguous(rows, types.int64)
        and _contiguous(dst, types.int32)
    ):
        return _lane_rows_copy  # other signals (the tests' int64 buffers): the loop

    def run(src, rows, o_rows, dst, o_dst, reverse):
        if src.shape[1] < BAND_ROWS:
            _lane_rows_loop(src, rows, o_rows, dst, o_dst, reverse)
        elif reverse:
            _lane_rows_reversed(src, rows, np.int64(o_rows), dst, np.int64(o_dst))
        else:
            _lane_rows_forward(src, rows, np.int64(o_rows), dst, np.int64(o_dst))

    return run


# --------------------------------------------------------------------------- RGB pixels


#: Pixels of one vector of ``_rgb_pixels`` (eight float64 values: two AVX2 registers).
_LANES = 8


def _rgb_pixels(image, y, x0, weights, steps, out, yp, o_out):
    """Write ``_LANES`` pixels ``x0..`` of a ``uint8`` RGB row to ``out[yp, o_out + ..]``.

    A pixel's value is ``rint((R * w0 + G * w1) + B * w2) * steps)`` as int32, ``weights``
    the three float64 ``(w0, w1, w2)`` (``signal.LUMA``: the products and sums of
    ``signal._row_tables``, whose tables hold exactly these float64 products). ``image`` has
    three channels (the caller's test: the vector form takes a pixel as three bytes).
    Compiled code runs ``_rgb_pixels_vector`` for C-contiguous images.
    """
    for i in range(_LANES):
        x = x0 + i
        lum = (
            np.float64(image[y, x, 0]) * weights[0] + np.float64(image[y, x, 1]) * weights[1]
        ) + np.float64(image[y, x, 2]) * weights[2]
        out[yp, o_out + i] = np.int32(np.rint(lum * steps))


# The three-byte pixels keep numba's loop vectorizer away (the tables' loads are gathers,
# the arithmetic form was scalar too). The vector form loads 8 pixels' 24 bytes at once,
# takes each channel's 8 bytes out by shuffles, and does the float64 arithmetic of the
# scalar expression on 8 lanes (plain fmul and fadd, which LLVM does not fuse; llvm.rint
# rounds half to even, as np.rint does). The weights are the caller's constant tuple, which
# LLVM folds into the code.
@intrinsic
def _rgb_pixels_vector(typingctx, image, y, x0, weights, steps, out, yp, o_out):
    if not (
        isinstance(image, types.Array)
        and image.dtype == types.uint8
        and image.ndim == 3
        and image.layout == "C"
        and isinstance(out, types.Array)
        and out.dtype == types.int32
        and out.ndim == 2
        and out.layout == "C"
        and all(isinstance(v, types.Integer) for v in (y, x0, steps, yp, o_out))
        and weights == types.UniTuple(types.float64, 3)
    ):
        return None
    i64 = ir.IntType(64)

    def codegen(context, builder, sig, args):
        y_v, x0_v, steps_v, yp_v, o_v = (
            context.cast(builder, args[i], sig.args[i], types.int64) for i in (1, 2, 4, 6, 7)
        )
        weights_v = [builder.extract_value(args[3], i) for i in range(3)]
        source = context.make_array(sig.args[0])(context, builder, args[0])
        target = context.make_array(sig.args[5])(context, builder, args[5])
        width = cgutils.unpack_tuple(builder, source.shape, 3)[1]
        width_out = cgutils.unpack_tuple(builder, target.shape, 2)[1]
        first = builder.mul(builder.add(builder.mul(y_v, width), x0_v), ir.Constant(i64, 3))
        bytes_type = ir.VectorType(ir.IntType(8), 3 * _LANES)
        pointer = builder.bitcast(builder.gep(source.data, [first]), bytes_type.as_pointer())
        packed = builder.load(pointer, align=1)
        f64x = ir.VectorType(ir.DoubleType(), _LANES)
        lanes = ir.VectorType(ir.IntType(32), _LANES)

        undef = ir.Constant(f64x, ir.Undefined)

        def spread(value):  # one float64 in every lane
            first = builder.insert_element(undef, value, ir.Constant(ir.IntType(32), 0))
            return builder.shuffle_vector(first, undef, ir.Constant(lanes, [0] * _LANES))

        def channel(c):
            picked = builder.shuffle_vector(
                packed,
                ir.Constant(bytes_type, ir.Undefined),
                ir.Constant(lanes, [3 * i + c for i in range(_LANES)]),
            )
            value = builder.uitofp(picked, f64x)
            return builder.fmul(value, spread(weights_v[c]))

        lum = builder.fadd(builder.fadd(channel(0), channel(1)), channel(2))
        scale_v = spread(builder.sitofp(steps_v, ir.DoubleType()))
        rint = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(f64x, [f64x]), f"llvm.rint.v{_LANES}f64"
        )
        rounded = builder.call(rint, [builder.fmul(lum, scale_v)])
        values = builder.fptosi(rounded, lanes)
        at = builder.add(builder.mul(yp_v, width_out), o_v)
        target_pointer = builder.bitcast(builder.gep(target.data, [at]), lanes.as_pointer())
        builder.store(values, target_pointer, align=4)
        return context.get_dummy_value()

    return types.void(image, y, x0, weights, steps, out, yp, o_out), codegen


@overload(_rgb_pixels)
def _rgb_pixels_compiled(image, y, x0, weights, steps, out, yp, o_out):
    if not VECTOR:  # DCSTEREO_VECTOR=0: numba compiles the plain form
        return _rgb_pixels
    if not (isinstance(image, types.Array) and image.layout == "C" and image.dtype == types.uint8):
        return _rgb_pixels
    return lambda image, y, x0, weights, steps, out, yp, o_out: _rgb_pixels_vector(
        image, y, x0, weights, steps, out, yp, o_out
    )


# --------------------------------------------------------------------------- window SSD


#: The forms of ``_window_ssd``'s compiled code (its ``form``, a constant where it is
#: called): the sums in 64-bit lanes, a window row in pieces of ``R`` pixels (any window);
#: in 32-bit lanes, a window of at most ``R`` pixels a side whose sums fit them
#: (``_narrow_sums``; on the matching signal of any image, 0..4080, every such window).
SSD_WIDE, SSD_SHORT = 0, 1


def _window_ssd(left_p, right_p, y, x, j, radius, form):
    """Return ``(ssd, sm, sq)`` of the pair ``x <-> j`` of padded row ``y``.

    ``ssd`` (float64) is the window sum of squared signal differences, ``sm`` and ``sq``
    (int64) the right window's sum and sum of squares, from which the search makes the
    right pixel's window variance (``_window_variance``): the right view's variance is
    read only at the candidates' matches, so it is made there, from the loads of the SSD.
    Both windows inside the image (every feature candidate): exact integers, ``ssd`` the
    value of ``features.window_ssd``. Compiled code runs the vector code of ``form``
    (``SSD_WIDE``, ``SSD_SHORT``: the same sums for int32 signals below 2**30 in
    magnitude, where the form's conditions hold), which must be a constant where it is
    called: one form compiled; here ``form`` is not read, the sums are Python's integers.
    """
    win = 2 * radius + 1
    si = 0
    sm = 0
    sq = 0
    for t in range(win):
        for c in range(win):
            right = np.int64(right_p[y + t, j + c])
            di = np.int64(left_p[y + t, x + c]) - right
            si += di * di
            sm += right
            sq += right * right
    return float(si), sm, sq


# The window's rows are short (5 pixels by default), too short for numba's loop
# vectorizer, which leaves a scalar loop of two loads, a subtraction, a multiplication and
# an addition per pixel. The vector code takes each row ``R`` pixels at a time: masked
# loads (nothing past the window is read), the differences as 32-bit integers (exact for
# signals below 2**30 in magnitude; the matching signal is 0..4080), their squares and
# sums as 64-bit ones, one sum at the end: the same integer, so the same float. A square
# of a sign-extended 32-bit value is one ``vpmuldq``; the difference of two 64-bit values
# was a full 64-bit product, which AVX2 lacks (three ``vpmuludq`` and shifts per four
# lanes): the SSD took about 35 ns on AVX2. The right rows' values are summed, and their
# squares, on the way (two additions and a ``vpmuldq`` a row). A window of at most ``R``
# pixels a side (the default 5, up to 7) whose sums fit 32 bits (``_narrow_sums``: on the
# matching signal of any image) takes the short form, ``SSD_SHORT``: no loop over pieces
# of a row, one masked load per view and row, the sums in 32-bit lanes without the sign
# extensions. Timed alone on 5 x 5 windows (AMD EPYC, AVX2): 60 cycles an SSD with the
# pieces' loop, 43 without it in 64-bit lanes, 24 in 32-bit ones; with the search's SSD in
# a loop of its own, tsukuba's search stage took 0.66 ms against 0.92 (docs/SPEED.md,
# stop 45).


def _window_ssd_codegen(short):
    """Return the code of ``_window_ssd`` in form ``SSD_SHORT`` (``short``) or ``SSD_WIDE``.

    ``short``: for windows of at most ``R`` pixels a side whose sums fit 32 bits (the
    caller checks), one load of a window row per view and row, without the loop over
    pieces of ``R`` pixels, the sums in 32-bit lanes. Else in 64-bit lanes.
    """
    lanes_type = _VEC_I32 if short else _VEC_I64
    sum_type = ir.IntType(32 if short else 64)

    def codegen(context, builder, sig, args):
        y_v, x_v, j_v, radius_v = args[2:]
        views = [context.make_array(sig.args[i])(context, builder, args[i]) for i in (0, 1)]
        win = builder.add(builder.mul(radius_v, ir.Constant(_I64, 2)), ir.Constant(_I64, 1))
        width = ir.Constant(_I64, BAND_ROWS)
        lanes = ir.Constant(_VEC_I64, list(range(BAND_ROWS)))
        mask_type = ir.VectorType(ir.IntType(1), BAND_ROWS)
        masked_load = cgutils.get_or_insert_function(
            builder.module,
            ir.FunctionType(_VEC_I32, [_VEC_I32.as_pointer(), ir.IntType(32), mask_type, _VEC_I32]),
            f"llvm.masked.load.v{BAND_ROWS}i32.p0",
        )
        total = cgutils.alloca_once_value(builder, _vector_of(0, lanes_type))
        right_sum = cgutils.alloca_once_value(builder, _vector_of(0, lanes_type))
        right_squares = cgutils.alloca_once_value(builder, _vector_of(0, lanes_type))

        def add_piece(c):
            # the window's columns c .. c + R - 1 (those of the window: the mask)
            mask = builder.icmp_unsigned(
                "<",
                builder.add(_broadcast(builder, c, _VEC_I64), lanes),
                _broadcast(builder, win, _VEC_I64),
            )

            def corner(view, column):
                # the window's first row in a view, from piece c on, and the row length
                length = cgutils.unpack_tuple(builder, view.shape, 2)[1]
                start = builder.add(builder.mul(y_v, length), builder.add(column, c))
                return builder.gep(view.data, [start]), length

            def window_row(first, length, t):
                # the R pixels of row t (those of the window: the mask)
                pointer = builder.gep(first, [builder.mul(t, length)])
                loaded = builder.call(
                    masked_load,
                    [builder.bitcast(pointer, _VEC_I32.as_pointer()),
                     ir.Constant(ir.IntType(32), 4), mask, _vector_of(0, _VEC_I32)],
                )  # fmt: skip
                return loaded

            left_first, right_first = corner(views[0], x_v), corner(views[1], j_v)
            with cgutils.for_range(builder, win) as rows:
                right32 = window_row(*right_first, rows.index)
                d32 = builder.sub(window_row(*left_first, rows.index), right32)
                d = d32 if short else builder.sext(d32, _VEC_I64)
                builder.store(builder.add(builder.load(total), builder.mul(d, d)), total)
                right = right32 if short else builder.sext(right32, _VEC_I64)
                builder.store(builder.add(builder.load(right_sum), right), right_sum)
                squares = builder.mul(right, right)
                builder.store(builder.add(builder.load(right_squares), squares), right_squares)

        # a short window is one piece; else the pieces of R pixels outside, the rows inside
        if short:
            add_piece(ir.Constant(_I64, 0))
        else:
            pieces = builder.udiv(builder.add(win, ir.Constant(_I64, BAND_ROWS - 1)), width)
            with cgutils.for_range(builder, pieces) as piece:
                add_piece(builder.mul(piece.index, width))
        reduce_add = cgutils.get_or_insert_function(
            builder.module,
            ir.FunctionType(sum_type, [lanes_type]),
            f"llvm.vector.reduce.add.v{BAND_ROWS}i{sum_type.width}",
        )
        ssd = builder.sitofp(builder.call(reduce_add, [builder.load(total)]), ir.DoubleType())
        sums = [builder.call(reduce_add, [builder.load(v)]) for v in (right_sum, right_squares)]
        if short:
            sums = [builder.sext(v, _I64) for v in sums]
        return context.make_tuple(builder, sig.return_type, [ssd, *sums])

    return codegen


def _window_ssd_signature(left_p, right_p, y, x, j, radius):
    """Return the signature of ``_window_ssd``'s forms, None for arguments they refuse."""
    if not (
        all(_contiguous(a, types.int32, 2) for a in (left_p, right_p)) and _words(y, x, j, radius)
    ):
        return None
    return types.Tuple((types.float64, types.int64, types.int64))(left_p, right_p, y, x, j, radius)


@intrinsic
def _window_ssd_vector(typingctx, left_p, right_p, y, x, j, radius):
    signature = _window_ssd_signature(left_p, right_p, y, x, j, radius)
    return None if signature is None else (signature, _window_ssd_codegen(False))


@intrinsic
def _window_ssd_short(typingctx, left_p, right_p, y, x, j, radius):
    signature = _window_ssd_signature(left_p, right_p, y, x, j, radius)
    return None if signature is None else (signature, _window_ssd_codegen(True))


@overload(_window_ssd, prefer_literal=True)
def _window_ssd_compiled(left_p, right_p, y, x, j, radius, form):
    if not VECTOR:  # DCSTEREO_VECTOR=0: numba compiles the plain form
        return _window_ssd
    if not all(_contiguous(a, types.int32, 2) for a in (left_p, right_p)):
        return _window_ssd  # other signals (the tests' int64 ones): the loop
    if not isinstance(form, types.IntegerLiteral):
        # a choice made as the code runs, in the search's loop, took the SSD from 24 to 44
        # cycles (docs/SPEED.md, stop 45): a constant form only
        return None
    vector = {SSD_WIDE: _window_ssd_vector, SSD_SHORT: _window_ssd_short}[form.literal_value]
    return lambda left_p, right_p, y, x, j, radius, form: vector(left_p, right_p, y, x, j, radius)

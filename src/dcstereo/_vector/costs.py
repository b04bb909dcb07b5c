"""Hand-written vector code, part 2: a band's cost columns and their block match.

Plain forms and vector forms side by side, as in :mod:`.simd` (which has the building
blocks): ``_moved_costs`` makes a column of eq. 4's window costs whose vertical sums move
down a row, ``_moved_costs_keyed`` also block-matches it as it is made (the four least
keys of each lane kept in registers), and ``_keyed_column`` block-matches a column of the
band's cost array (the least cost and the uniqueness ratio of section 2's tests).
``tests/test_simd.py`` holds each vector form to its plain form.
"""

import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic, overload

from dcstereo._vector import VECTOR
from dcstereo._vector.simd import (
    _FLOOR,
    _FMA,
    _I64,
    _VEC_F64,
    _VEC_I32,
    _VEC_I64,
    BAND_ROWS,
    _array_data,
    _broadcast,
    _contiguous,
    _load_vector,
    _store_vector,
    _vector_call,
    _vector_min,
    _vector_of,
    _words,
)


def _moved_costs(left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n, width_p):
    """One bulk column of the cost passes, its vertical sums moved down a row (``n`` cells).

    The fused form of ``_vertical_update`` for a column ``add`` whose every disparity has
    its right pixel inside the image, then the running horizontal sum: ``vs[o_add + i]``
    gains the entering rows' absolute difference and loses the leaving rows' (the left
    pixels of lane ``r`` at ``left_t[o_left + r]``, leaving, and ``width_p * R`` further,
    entering; the right ones at ``right_t[o_right + i]`` and ``width_p * R`` further), then
    ``hsum[i]`` gains it and loses ``vs[o_sub + i]``, and ``out[o_out + i]`` is the new
    ``hsum[i]`` as float64. Exact integers throughout (int32, as the arrays). Compiled code
    runs ``_moved_costs_vector`` (a block of ``R`` cells at a time, the left pixels in a
    register instead of ``_spread`` copies).
    """
    nr = BAND_ROWS
    step = np.uint64(width_p * nr)
    for i in range(np.uint64(n)):
        r = i % np.uint64(nr)
        enter = left_t[o_left + step + r]
        leave = left_t[o_left + r]
        vs[o_add + i] += abs(enter - right_t[o_right + step + i]) - abs(
            leave - right_t[o_right + i]
        )
        h = np.int32(hsum[i] + (vs[o_add + i] - vs[o_sub + i]))
        hsum[i] = h
        out[o_out + i] = h


def _moved_costs_keyed(left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n,
                       width_p, shift, wta_k, wta_ratio, i0):  # fmt: skip
    """``_moved_costs``, then the block match of the column it made, for ``band_lane_costs``.

    The column's ``n / R`` disparities are blocks ``j = k + 1``; lane ``r``'s key of block
    ``j`` is ``(h << shift) | j`` (``h`` its cost, ``2**shift`` above the blocks), an
    integer ordered as ``(h, j)``. ``wta_k[i0 + r]`` and ``wta_ratio[i0 + r]`` get the
    values of ``band_block_match`` on the column: the block of the least key, and the
    least cost over ``|j - b| >= 2`` over the least (no such block: inf). The caller
    ensures that every key is below ``2**31 - 1`` (``_keys_fit``). Compiled code runs
    ``_moved_costs_keyed_vector``: the keys in 32-bit lanes, kept as the four least of
    each lane while the costs are made, the column never read back.
    """
    _moved_costs(left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n, width_p)
    nr = BAND_ROWS
    nblocks = np.uint64(n) // np.uint64(nr)
    for r in range(nr):
        least = 2**63 - 1
        for k in range(nblocks):
            h = np.int64(out[o_out + k * np.uint64(nr) + r])
            least = min(least, (h << shift) | np.int64(k + 1))
        b = least & ((1 << shift) - 1)
        second = np.inf
        for k in range(nblocks):
            if abs(np.int64(k + 1) - b) >= 2:
                second = min(second, out[o_out + k * np.uint64(nr) + r])
        best = float(least >> shift)
        wta_k[i0 + r] = b - 1
        if best > 0:
            wta_ratio[i0 + r] = second / best
        else:
            wta_ratio[i0 + r] = np.inf if second > 0 else 1.0


def _moved_costs_codegen(keyed):
    """Return the vector code of ``_moved_costs`` (``keyed``: of ``_moved_costs_keyed``)."""

    def codegen(context, builder, sig, args):
        left, right, sums, running, costs = (
            _array_data(context, builder, sig, args, i) for i in range(5)
        )
        o_left, o_right, o_add, o_sub, o_out, n, width_p = args[5:12]
        step = builder.mul(width_p, ir.Constant(_I64, BAND_ROWS))
        no_poison = ir.Constant(ir.IntType(1), 0)
        abs32 = cgutils.get_or_insert_function(
            builder.module,
            ir.FunctionType(_VEC_I32, [_VEC_I32, ir.IntType(1)]),
            f"llvm.abs.v{BAND_ROWS}i32",
        )

        def load(array, index):
            return _load_vector(builder, array, index, _VEC_I32)

        def dist(a, b):
            return builder.call(abs32, [builder.sub(a, b), no_poison])

        def signed(op, a, b):  # the signed minimum or maximum of two int32 vectors
            return builder.select(builder.icmp_signed(op, a, b), a, b)

        if keyed:
            # the four least keys of each lane, in order (an insertion: min and max down
            # the four), and the next block's number; "none" is above every key
            shift = _broadcast(builder, builder.trunc(args[12], ir.IntType(32)), _VEC_I32)
            none = _vector_of(2**31 - 1, _VEC_I32)
            least = [cgutils.alloca_once_value(builder, none) for _ in range(4)]
            number = cgutils.alloca_once_value(builder, _vector_of(1, _VEC_I32))
        leave = load(left, o_left)
        enter = load(left, builder.add(o_left, step))
        blocks = builder.udiv(n, ir.Constant(_I64, BAND_ROWS))
        width = ir.Constant(_I64, BAND_ROWS)
        with cgutils.for_range(builder, blocks) as loop:
            i = builder.mul(loop.index, width)
            right_at = builder.add(o_right, i)
            moved = builder.add(
                load(sums, builder.add(o_add, i)),
                builder.sub(
                    dist(enter, load(right, builder.add(right_at, step))),
                    dist(leave, load(right, right_at)),
                ),
            )
            _store_vector(builder, moved, sums, builder.add(o_add, i))
            h = builder.add(load(running, i), builder.sub(moved, load(sums, builder.add(o_sub, i))))
            _store_vector(builder, h, running, i)
            _store_vector(builder, builder.sitofp(h, _VEC_F64), costs, builder.add(o_out, i))
            if keyed:
                j = builder.load(number)
                builder.store(builder.add(j, _vector_of(1, _VEC_I32)), number)
                key = builder.or_(builder.shl(h, shift), j)
                for place, slot in enumerate(least):
                    old = builder.load(slot)
                    builder.store(signed("<", old, key), slot)
                    if place < len(least) - 1:
                        key = signed(">", old, key)
        if not keyed:
            return context.get_dummy_value()
        # the match: the least key's block b; the second cost: the first of the next three
        # keys whose block is at least two from b (at most two of them are b's neighbours)
        keys = [builder.load(slot) for slot in least]
        low_bits = builder.sub(builder.shl(_vector_of(1, _VEC_I32), shift), _vector_of(1, _VEC_I32))
        block = builder.and_(keys[0], low_bits)
        second = none
        for key in reversed(keys[1:]):
            apart = builder.icmp_signed(
                ">=", dist(builder.and_(key, low_bits), block), _vector_of(2, _VEC_I32)
            )
            second = builder.select(builder.and_(apart, builder.icmp_signed("<", key, none)), key,
                                    second)  # fmt: skip
        inf = _vector_of(float("inf"), _VEC_F64)
        zero = _vector_of(0.0, _VEC_F64)
        best = builder.sitofp(builder.ashr(keys[0], shift), _VEC_F64)
        second = builder.select(
            builder.icmp_signed("<", second, none),
            builder.sitofp(builder.ashr(second, shift), _VEC_F64),
            inf,
        )
        ratio = builder.select(
            builder.fcmp_ordered(">", best, zero),
            builder.fdiv(second, best),
            builder.select(builder.fcmp_ordered(">", second, zero), inf, _vector_of(1.0, _VEC_F64)),
        )
        match = builder.sub(builder.sext(block, _VEC_I64), _vector_of(1, _VEC_I64))
        _store_vector(builder, match, _array_data(context, builder, sig, args, 13), args[15])
        _store_vector(builder, ratio, _array_data(context, builder, sig, args, 14), args[15])
        return context.get_dummy_value()

    return codegen


def _moved_arguments_ok(left_t, right_t, vs, hsum, out, offsets):
    return (
        all(_contiguous(a, types.int32) for a in (left_t, right_t, vs, hsum))
        and _contiguous(out, types.float64)
        and _words(*offsets)
    )


@intrinsic
def _moved_costs_vector(typingctx, left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub,
                        o_out, n, width_p):  # fmt: skip
    offsets = (o_left, o_right, o_add, o_sub, o_out, n, width_p)
    if not _moved_arguments_ok(left_t, right_t, vs, hsum, out, offsets):
        return None
    signature = types.void(left_t, right_t, vs, hsum, out, *offsets)
    return signature, _moved_costs_codegen(False)


@intrinsic
def _moved_costs_keyed_vector(typingctx, left_t, right_t, vs, hsum, out, o_left, o_right, o_add,
                              o_sub, o_out, n, width_p, shift, wta_k, wta_ratio, i0):  # fmt: skip
    offsets = (o_left, o_right, o_add, o_sub, o_out, n, width_p)
    if not (
        _moved_arguments_ok(left_t, right_t, vs, hsum, out, offsets + (shift, i0))
        and _contiguous(wta_k, types.int64)
        and _contiguous(wta_ratio, types.float64)
    ):
        return None
    signature = types.void(left_t, right_t, vs, hsum, out, *offsets, shift, wta_k, wta_ratio, i0)
    return signature, _moved_costs_codegen(True)


@overload(_moved_costs)
def _moved_costs_compiled(left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n,
                          width_p):  # fmt: skip
    if not VECTOR:  # DCSTEREO_VECTOR=0: numba compiles the plain form
        return _moved_costs
    if not all(_contiguous(a, types.int32) for a in (left_t, right_t, vs, hsum)):
        return _moved_costs  # other integer arrays (the tests' int64 ones): the loop

    def run(left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n, width_p):
        _moved_costs_vector(
            left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n, width_p
        )

    return run


@overload(_moved_costs_keyed)
def _moved_costs_keyed_compiled(left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub,
                                o_out, n, width_p, shift, wta_k, wta_ratio, i0):  # fmt: skip
    if not VECTOR:  # DCSTEREO_VECTOR=0: numba compiles the plain form
        return _moved_costs_keyed
    if not all(_contiguous(a, types.int32) for a in (left_t, right_t, vs, hsum)):
        return _moved_costs_keyed  # the tests' int64 arrays: the loops

    def run(left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n, width_p,
            shift, wta_k, wta_ratio, i0):  # fmt: skip
        _moved_costs_keyed_vector(
            left_t, right_t, vs, hsum, out, o_left, o_right, o_add, o_sub, o_out, n, width_p,
            shift, wta_k, wta_ratio, i0,
        )  # fmt: skip

    return run


# The keyed columns' least key and second key are one reduction per lane along the
# disparities. numba's loop vectorizer cannot express that (a flat loop over ``(k, r)``
# carries it through memory, as the prefix and suffix chains did: two stores per block
# of 8 cells, and a per-row decode after them), so the keyed column is written as LLVM
# vector code (``<R x double>``, R = ``BAND_ROWS``): ``_KEY_CHAINS`` running minima per
# pass, held in registers, and the decode of the 8 lanes at once. Plain Python runs the twin below
# (``NUMBA_DISABLE_JIT``); the tests hold both to the prefix-chain results.


def _keyed_column(cost, o, nblocks, scale, numbers, wta_k, wta_ratio, i0):
    """Block match of a keyed column: its ``R`` lanes' ``wta_k`` and ``wta_ratio`` at ``i0``.

    ``cost[o + j * R + r]``, blocks ``j = 0 .. nblocks - 1`` (the first and the last are the
    inf padding), holds integers below ``2**31`` or inf; the key of block ``j`` is
    ``cost * scale + j`` (``scale`` a power of two above ``nblocks``), exact and ordered as
    ``(cost, j)``. The least key gives the match (block ``b = k + 1``, the first of the
    least costs) and the least key over ``|j - b| >= 2`` the second cost of the uniqueness
    ratio: the values of ``features.block_match``, bit for bit. ``numbers[j]`` is ``j``
    (float64, at least ``nblocks`` values): the vector code loads each block's ``j``
    instead of counting it up in a vector register (an addition per block, on the
    floating-point pipes the key's fused multiply-add and the minimum need).
    Compiled code runs ``_keyed_column_vector`` instead (the same operations, the lanes as
    one vector).
    """
    nr = BAND_ROWS
    unscale = 1.0 / scale
    for r in range(nr):
        least = np.inf
        for j in range(nblocks):
            least = min(least, cost[o + j * nr + r] * scale + numbers[j])
        i = i0 + r
        if not least < np.inf:
            wta_k[i] = -1
            wta_ratio[i] = 0.0
            continue
        best = np.floor(least * unscale)
        b = int(least - best * scale)
        second = np.inf
        for j in range(nblocks):
            if abs(j - b) >= 2:
                second = min(second, cost[o + j * nr + r] * scale + numbers[j])
        second = np.floor(second * unscale)
        wta_k[i] = b - 1
        if best > 0:
            wta_ratio[i] = second / best
        else:
            wta_ratio[i] = np.inf if second > 0 else 1.0


#: Running minima of ``_keyed_column_vector`` (blocks taken this many at a time).
_KEY_CHAINS = 4


@intrinsic
def _keyed_column_vector(typingctx, cost, o, nblocks, scale, numbers, wta_k, wta_ratio, i0):
    if not (
        _contiguous(cost, types.float64)
        and _contiguous(numbers, types.float64)
        and _contiguous(wta_k, types.int64)
        and _contiguous(wta_ratio, types.float64)
        and scale == types.float64
        and _words(o, nblocks, i0)
    ):
        return None
    signature = types.void(cost, o, nblocks, scale, numbers, wta_k, wta_ratio, i0)

    def codegen(context, builder, sig, args):
        _, o_v, nblocks_v, scale_v, _, _, _, i0_v = args
        data = _array_data(context, builder, sig, args, 0)
        number = _array_data(context, builder, sig, args, 4)
        width = ir.Constant(_I64, BAND_ROWS)
        inf = _vector_of(float("inf"), _VEC_F64)
        one = _vector_of(1.0, _VEC_F64)
        zero = _vector_of(0.0, _VEC_F64)
        scale_vec = _broadcast(builder, scale_v, _VEC_F64)
        unscale = builder.fdiv(one, scale_vec)  # exact: a power of two
        # blocks in groups of _KEY_CHAINS, one running minimum per place in the group (the
        # chains are short: the next column's can start before this one's end); the
        # blocks left over (nblocks % _KEY_CHAINS) go first, into the first minimum
        chains = ir.Constant(_I64, _KEY_CHAINS)
        groups = builder.udiv(nblocks_v, chains)
        rest = builder.urem(nblocks_v, chains)
        least = [cgutils.alloca_once_value(builder, inf) for _ in range(_KEY_CHAINS)]

        def block_number(j):
            return _broadcast(builder, builder.load(builder.gep(number, [j])), _VEC_F64)

        def key(j):
            # cost * scale + j: exact (below 2**53), so the fused multiply-add rounds nothing
            values = _load_vector(builder, data, builder.add(o_v, builder.mul(j, width)))
            return _vector_call(builder, _FMA, values, scale_vec, block_number(j))

        def fold(slot, value, keep=None):
            # keep: the lanes that take the value (a masked minimum, no blend)
            old = builder.load(slot)
            new = _vector_min(builder, old, value)
            builder.store(new if keep is None else builder.select(keep, new, old), slot)

        def fold_all(keep):
            # keep(j): the lanes that block j takes part in (None: all)
            with cgutils.for_range(builder, rest) as loop:
                fold(least[0], key(loop.index), keep(loop.index))
            with cgutils.for_range(builder, groups) as loop:
                j0 = builder.add(rest, builder.mul(loop.index, chains))
                for place in range(_KEY_CHAINS):
                    j = builder.add(j0, ir.Constant(_I64, place))
                    fold(least[place], key(j), keep(j))
            result = builder.load(least[0])
            for slot in least[1:]:
                result = _vector_min(builder, result, builder.load(slot))
            return result

        least_key = fold_all(lambda j: None)  # the least key
        valid = builder.fcmp_ordered("<", least_key, inf)
        best = _vector_call(builder, _FLOOR, builder.fmul(least_key, unscale))
        block = builder.fsub(least_key, builder.fmul(best, scale_vec))  # b = k + 1
        block = builder.select(valid, block, one)
        # the second key: the blocks with |j - b| >= 2, compared as float64 (exact small
        # integers; 64-bit integer lanes would take an unsigned compare, which AVX2 lacks)
        for slot in least:
            builder.store(inf, slot)
        two = _vector_of(2.0, _VEC_F64)
        fabs = f"llvm.fabs.v{BAND_ROWS}f64"

        def apart(j):
            distance = _vector_call(builder, fabs, builder.fsub(block_number(j), block))
            return builder.fcmp_ordered(">=", distance, two)

        second_key = fold_all(apart)
        second = _vector_call(builder, _FLOOR, builder.fmul(second_key, unscale))
        ratio = builder.select(
            builder.fcmp_ordered(">", best, zero),
            builder.fdiv(second, best),
            builder.select(builder.fcmp_ordered(">", second, zero), inf, one),
        )
        # k = b - 1 as an integer: b + 2**52 holds b in its low mantissa bits (exact for
        # 0 <= b < 2**52), one addition and one integer subtraction a vector (AVX2 has no
        # vector conversion of float64 to 64-bit integers: fptosi was eight scalar ones)
        magic = _vector_of(float(2**52), _VEC_F64)
        block_bits = builder.bitcast(builder.fadd(block, magic), _VEC_I64)
        match = builder.sub(block_bits, _vector_of((0x433 << 52) + 1, _VEC_I64))
        match = builder.select(valid, match, _vector_of(-1, _VEC_I64))
        ratio = builder.select(valid, ratio, zero)
        _store_vector(builder, match, _array_data(context, builder, sig, args, 5), i0_v)
        _store_vector(builder, ratio, _array_data(context, builder, sig, args, 6), i0_v)
        return context.get_dummy_value()

    return signature, codegen


@overload(_keyed_column)
def _keyed_column_compiled(cost, o, nblocks, scale, numbers, wta_k, wta_ratio, i0):
    if not VECTOR:  # DCSTEREO_VECTOR=0: numba compiles the plain form
        return _keyed_column
    return lambda cost, o, nblocks, scale, numbers, wta_k, wta_ratio, i0: _keyed_column_vector(
        cost, o, nblocks, scale, numbers, wta_k, wta_ratio, i0
    )

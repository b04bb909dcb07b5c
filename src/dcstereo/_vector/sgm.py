"""Vector code of the semi-global aggregation: 16 costs of 16 bits at a time.

The aggregation's inner loops run over the disparities of one pixel, in ``int16``. numba
types integer arithmetic at 64 bits, so its own loops over ``int16`` arrays vectorize at a
quarter of the width, with a 64-bit reduction; these loops are written as LLVM vector code
instead (an ``@intrinsic`` builds the IR, numba compiles and caches it with its callers).

Each operation is first a plain Python function, the definition: it runs as such under
``NUMBA_DISABLE_JIT`` and in the tests, which hold the compiled form to it on random
inputs (``tests/test_sgm_kernels.py``). The compiled form is given by ``overload``. Every
count ``n`` is a multiple of :data:`LANES` (the cost rows are padded to it), offsets and
counts are ``int64``, and the arrays are C-contiguous ``int16``, read and written at flat
offsets.

One more operation is not vector code: :func:`next_task`, the shared counter from which the
parallel loops of the aggregation and the costs take their tasks (an atomic add).

Sums saturate at the ``int16`` bounds (``llvm.sadd.sat``, one instruction on x86); the
parameters are validated so that no real cost comes near them (:mod:`dcstereo.methods.sgm`).
"""

import numba as nb
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic, overload

from dcstereo._vector import VECTOR

#: Disparities per vector: 16 lanes of 16 bits (one AVX2 register, half an AVX-512 one).
LANES = 16

#: The largest and smallest ``int16``.
HIGH = 32767
LOW = -32768

_I16 = ir.IntType(16)
_I64 = ir.IntType(64)
_VEC = ir.VectorType(_I16, LANES)


# compiled too: numba compiles the plain forms (DCSTEREO_VECTOR=0), which call these
@nb.njit(cache=True)
def _saturate(value):
    return min(max(value, LOW), HIGH)


@nb.njit(cache=True)
def _wrap(value):
    return (value - LOW) % 65536 + LOW


# --------------------------------------------------------------------------- plain forms


def path_step(cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin):
    """One step of a semi-global path (Hirschmueller 2008, eq. 13) over ``n`` disparities.

    ``L(p, d) = C(p, d) + min(L(q, d), L(q, d - 1) + P1, L(q, d + 1) + P1,
    min_k L(q, k) + P2) - min_k L(q, k)`` for the pixel ``p`` whose predecessor on the path
    is ``q``: ``cost[c_off + k]`` is ``C(p, k)``, ``prev[p_off + 1 + k]`` is ``L(q, k)``
    (``prev[p_off]`` and ``prev[p_off + n + 1]`` are the pads, never smaller than a cost),
    ``pmin`` is ``min_k L(q, k)``; ``L(p, k)`` goes to ``cur[q_off + 1 + k]``. The sums
    with P1 and with P2 saturate at ``int16``'s bound. Returns ``min_k L(p, k)``.
    """
    jump = _saturate(pmin + p2)
    best = HIGH
    for k in range(n):
        before = _saturate(int(prev[p_off + k]) + p1)
        after = _saturate(int(prev[p_off + k + 2]) + p1)
        step = min(int(prev[p_off + k + 1]), before, after, jump)
        value = _wrap(int(cost[c_off + k]) + step - pmin)  # wraps as the vector code does
        cur[q_off + k + 1] = value
        best = min(best, value)
    return best


def path_start(cost, c_off, cur, q_off, n):
    """Start a path: ``L(p, k) = C(p, k)`` into ``cur[q_off + 1 + k]``.

    Returns ``min_k L(p, k)``.
    """
    best = HIGH
    for k in range(n):
        cur[q_off + k + 1] = cost[c_off + k]
        best = min(best, int(cost[c_off + k]))
    return best


def add_saturated(out, o_off, a, a_off, b, b_off, n):
    """``out[o_off + k] = a[a_off + k] + b[b_off + k]``, saturated at the ``int16`` bounds."""
    for k in range(n):
        out[o_off + k] = _saturate(int(a[a_off + k]) + int(b[b_off + k]))


def paths_step(cost, c_off, prev, p_offs, cur, q_offs, n, p1, p2s, pmins, sums, s_off):
    """:func:`path_step` of several paths through one pixel, and the sum of their values.

    ``p_offs``, ``q_offs`` and ``p2s`` are tuples of one entry per path: path ``i`` reads
    ``prev`` at ``p_offs[i]``, writes ``cur`` at ``q_offs[i]``, with ``p2s[i]`` and
    ``pmins[i]`` (an int64 array), which receives its new least value; ``sums[s_off + k]``
    the sum of the paths' ``L(p, k)``, added in order, saturated. A path's first pixel is a
    step from a predecessor of all zeros (``L = C`` exactly, since ``P1, P2 >= 0``).
    """
    for i in range(len(p_offs)):
        pmins[i] = path_step(cost, c_off, prev, p_offs[i], cur, q_offs[i], n, p1, p2s[i], pmins[i])
    for k in range(n):
        total = 0
        for i in range(len(q_offs)):
            total = _saturate(total + int(cur[q_offs[i] + 1 + k]))
        sums[s_off + k] = total


def path_total_step(
    cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin, parts, offs, total, t_off
):
    """:func:`path_step`, then the total of the pixel: the path's value plus three parts.

    ``total[t_off + k] = L(p, k) + parts[0][offs[0] + k] + parts[1][offs[1] + k] +
    parts[2][offs[2] + k]``, summed in that order and saturated. Returns ``(min_k L(p, k),
    k_best, total[t_off + k_best])`` with ``k_best`` the first least total.
    """
    least = path_step(cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin)
    for k in range(n):
        value = int(cur[q_off + 1 + k])
        for i in range(3):
            value = _saturate(value + int(parts[i][offs[i] + k]))
        total[t_off + k] = value
    k_best, best = first_min(total, t_off, n)
    return least, k_best, best


def first_min(values, off, n):
    """Return ``(k, values[off + k])`` of the least of ``values[off:off + n]``, first on ties."""
    best_k = 0
    best = int(values[off])
    for k in range(1, n):
        if values[off + k] < best:
            best = int(values[off + k])
            best_k = k
    return best_k, best


# --------------------------------------------------------------------------- vector forms


def _int16_array(array):
    return isinstance(array, types.Array) and array.layout == "C" and array.dtype == types.int16


def _words(*values):
    return all(isinstance(v, types.Integer) and v.bitwidth == 64 for v in values)


def _data(context, builder, sig, args, i):
    return context.make_array(sig.args[i])(context, builder, args[i]).data


def _load(builder, data, index):
    pointer = builder.bitcast(builder.gep(data, [index]), _VEC.as_pointer())
    return builder.load(pointer, align=2)


def _store(builder, value, data, index):
    pointer = builder.bitcast(builder.gep(data, [index]), _VEC.as_pointer())
    builder.store(value, pointer, align=2)


def _splat(builder, value, vtype=_VEC):
    undef = ir.Constant(vtype, ir.Undefined)
    first = builder.insert_element(undef, value, ir.Constant(ir.IntType(32), 0))
    lanes = ir.Constant(ir.VectorType(ir.IntType(32), LANES), [0] * LANES)
    return builder.shuffle_vector(first, undef, lanes)


def _call(builder, name, result, *values):
    signature = ir.FunctionType(result, [v.type for v in values])
    return builder.call(cgutils.get_or_insert_function(builder.module, signature, name), values)


def _min(builder, a, b):
    return _call(builder, f"llvm.smin.v{LANES}i16", _VEC, a, b)


def _add_sat(builder, a, b):
    return _call(builder, f"llvm.sadd.sat.v{LANES}i16", _VEC, a, b)


def _reduce_min(builder, vector):
    return _call(builder, f"llvm.vector.reduce.smin.v{LANES}i16", _I16, vector)


def _saturated_i16(builder, value):
    """Clamp an ``int64`` to the ``int16`` range, as ``i16``."""
    high, low = ir.Constant(_I64, HIGH), ir.Constant(_I64, LOW)
    value = builder.select(builder.icmp_signed(">", value, high), high, value)
    value = builder.select(builder.icmp_signed("<", value, low), low, value)
    return builder.trunc(value, _I16)


def _chunks(builder, n):
    """Loop over the vector offsets ``0, LANES, ..., n - LANES`` (``n`` a multiple of it)."""
    count = builder.udiv(n, ir.Constant(_I64, LANES))
    return cgutils.for_range(builder, count)


def _path_step_codegen(context, builder, sig, args):
    _, c_off, _, p_off, _, q_off, n, p1, p2, pmin = args
    cost = _data(context, builder, sig, args, 0)
    prev = _data(context, builder, sig, args, 2)
    cur = _data(context, builder, sig, args, 4)
    p1v = _splat(builder, _saturated_i16(builder, p1))
    jump = _splat(builder, _saturated_i16(builder, builder.add(pmin, p2)))
    pminv = _splat(builder, builder.trunc(pmin, _I16))
    best = cgutils.alloca_once_value(builder, _splat(builder, ir.Constant(_I16, HIGH)))
    one = ir.Constant(_I64, 1)
    with _chunks(builder, n) as loop:
        k = builder.mul(loop.index, ir.Constant(_I64, LANES))
        at = builder.add(p_off, k)
        before = _add_sat(builder, _load(builder, prev, at), p1v)
        same = _load(builder, prev, builder.add(at, one))
        after = _add_sat(builder, _load(builder, prev, builder.add(at, ir.Constant(_I64, 2))), p1v)
        step = _min(builder, _min(builder, same, before), _min(builder, after, jump))
        value = builder.add(_load(builder, cost, builder.add(c_off, k)), builder.sub(step, pminv))
        _store(builder, value, cur, builder.add(builder.add(q_off, k), one))
        builder.store(_min(builder, builder.load(best), value), best)
    return builder.sext(_reduce_min(builder, builder.load(best)), _I64)


@intrinsic
def _path_step_vector(typingctx, cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin):
    if not (
        _int16_array(cost)
        and _int16_array(prev)
        and _int16_array(cur)
        and _words(c_off, p_off, q_off, n, p1, p2, pmin)
    ):
        return None
    sig = types.int64(cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin)
    return sig, _path_step_codegen


def _path_start_codegen(context, builder, sig, args):
    _, c_off, _, q_off, n = args
    cost = _data(context, builder, sig, args, 0)
    cur = _data(context, builder, sig, args, 2)
    best = cgutils.alloca_once_value(builder, _splat(builder, ir.Constant(_I16, HIGH)))
    with _chunks(builder, n) as loop:
        k = builder.mul(loop.index, ir.Constant(_I64, LANES))
        value = _load(builder, cost, builder.add(c_off, k))
        _store(builder, value, cur, builder.add(builder.add(q_off, k), ir.Constant(_I64, 1)))
        builder.store(_min(builder, builder.load(best), value), best)
    return builder.sext(_reduce_min(builder, builder.load(best)), _I64)


@intrinsic
def _path_start_vector(typingctx, cost, c_off, cur, q_off, n):
    if not (_int16_array(cost) and _int16_array(cur) and _words(c_off, q_off, n)):
        return None
    return types.int64(cost, c_off, cur, q_off, n), _path_start_codegen


def _add_saturated_codegen(context, builder, sig, args):
    _, o_off, _, a_off, _, b_off, n = args
    out = _data(context, builder, sig, args, 0)
    a = _data(context, builder, sig, args, 2)
    b = _data(context, builder, sig, args, 4)
    with _chunks(builder, n) as loop:
        k = builder.mul(loop.index, ir.Constant(_I64, LANES))
        total = _add_sat(
            builder,
            _load(builder, a, builder.add(a_off, k)),
            _load(builder, b, builder.add(b_off, k)),
        )
        _store(builder, total, out, builder.add(o_off, k))
    return context.get_dummy_value()


@intrinsic
def _add_saturated_vector(typingctx, out, o_off, a, a_off, b, b_off, n):
    if not (
        _int16_array(out) and _int16_array(a) and _int16_array(b) and _words(o_off, a_off, b_off, n)
    ):
        return None
    return types.void(out, o_off, a, a_off, b, b_off, n), _add_saturated_codegen


def _argmin_start(builder):
    """Allocate the lane-wise arg-min of a chunked loop: (least values, their offsets)."""
    index_type = ir.VectorType(ir.IntType(32), LANES)
    best = cgutils.alloca_once_value(builder, _splat(builder, ir.Constant(_I16, HIGH)))
    where = cgutils.alloca_once_value(builder, ir.Constant(index_type, [0] * LANES))
    return best, where


def _argmin_step(builder, state, value, k):
    """Keep in each lane the least of ``value`` (the chunk at offset ``k``) and its offset."""
    best, where = state
    index_type = ir.VectorType(ir.IntType(32), LANES)
    lanes = ir.Constant(index_type, list(range(LANES)))
    old = builder.load(best)
    less = builder.icmp_signed("<", value, old)
    builder.store(builder.select(less, value, old), best)
    here = builder.add(_splat(builder, builder.trunc(k, ir.IntType(32)), index_type), lanes)
    builder.store(builder.select(less, here, builder.load(where)), where)


def _argmin_end(builder, state):
    """Return ``(offset, value)`` (i32, i16): the least value, at its least offset."""
    best, where = state
    index_type = ir.VectorType(ir.IntType(32), LANES)
    final = builder.load(best)
    least = _reduce_min(builder, final)
    holds = builder.icmp_signed("==", final, _splat(builder, least))
    first = builder.select(holds, builder.load(where), ir.Constant(index_type, [2**31 - 1] * LANES))
    index = _call(builder, f"llvm.vector.reduce.umin.v{LANES}i32", ir.IntType(32), first)
    return index, least


def _first_min_codegen(context, builder, sig, args):
    # one pass: each lane keeps its least value and the first offset holding it; then the
    # least of the lanes, and the least offset among the lanes that hold it
    _, off, n = args
    values = _data(context, builder, sig, args, 0)
    state = _argmin_start(builder)
    with _chunks(builder, n) as loop:
        k = builder.mul(loop.index, ir.Constant(_I64, LANES))
        _argmin_step(builder, state, _load(builder, values, builder.add(off, k)), k)
    index, least = _argmin_end(builder, state)
    result = context.make_tuple(
        builder, sig.return_type, [builder.sext(index, _I64), builder.sext(least, _I64)]
    )
    return result


@intrinsic
def _first_min_vector(typingctx, values, off, n):
    if not (_int16_array(values) and _words(off, n)):
        return None
    return types.UniTuple(types.int64, 2)(values, off, n), _first_min_codegen


def _paths_step_codegen(context, builder, sig, args):
    count = sig.args[3].count
    _, c_off, _, p_offs, _, q_offs, n, p1, p2s, _, _, s_off = args
    cost = _data(context, builder, sig, args, 0)
    prev = _data(context, builder, sig, args, 2)
    cur = _data(context, builder, sig, args, 4)
    pmins = _data(context, builder, sig, args, 9)
    sums = _data(context, builder, sig, args, 10)
    p_offs = cgutils.unpack_tuple(builder, p_offs, count)
    q_offs = cgutils.unpack_tuple(builder, q_offs, count)
    p2s = cgutils.unpack_tuple(builder, p2s, count)
    p1v = _splat(builder, _saturated_i16(builder, p1))
    jumps, pminvs, bests = [], [], []
    for i in range(count):
        pmin = builder.load(builder.gep(pmins, [ir.Constant(_I64, i)]))
        jumps.append(_splat(builder, _saturated_i16(builder, builder.add(pmin, p2s[i]))))
        pminvs.append(_splat(builder, builder.trunc(pmin, _I16)))
        bests.append(cgutils.alloca_once_value(builder, _splat(builder, ir.Constant(_I16, HIGH))))
    one, two = ir.Constant(_I64, 1), ir.Constant(_I64, 2)
    with _chunks(builder, n) as loop:
        k = builder.mul(loop.index, ir.Constant(_I64, LANES))
        c = _load(builder, cost, builder.add(c_off, k))
        total = ir.Constant(_VEC, [0] * LANES)
        for i in range(count):
            at = builder.add(p_offs[i], k)
            before = _add_sat(builder, _load(builder, prev, at), p1v)
            same = _load(builder, prev, builder.add(at, one))
            after = _add_sat(builder, _load(builder, prev, builder.add(at, two)), p1v)
            step = _min(builder, _min(builder, same, before), _min(builder, after, jumps[i]))
            value = builder.add(c, builder.sub(step, pminvs[i]))
            _store(builder, value, cur, builder.add(builder.add(q_offs[i], k), one))
            builder.store(_min(builder, builder.load(bests[i]), value), bests[i])
            total = _add_sat(builder, total, value)
        _store(builder, total, sums, builder.add(s_off, k))
    for i in range(count):
        least = builder.sext(_reduce_min(builder, builder.load(bests[i])), _I64)
        builder.store(least, builder.gep(pmins, [ir.Constant(_I64, i)]))
    return context.get_dummy_value()


def _word_tuple(value):
    return isinstance(value, types.UniTuple) and _words(value.dtype)


def _int64_array(array):
    return isinstance(array, types.Array) and array.layout == "C" and array.dtype == types.int64


@intrinsic
def _paths_step_vector(
    typingctx, cost, c_off, prev, p_offs, cur, q_offs, n, p1, p2s, pmins, sums, s_off
):
    if not (
        _int16_array(cost)
        and _int16_array(prev)
        and _int16_array(cur)
        and _int16_array(sums)
        and _int64_array(pmins)
        and _word_tuple(p_offs)
        and _word_tuple(q_offs)
        and _word_tuple(p2s)
        and p_offs.count == q_offs.count == p2s.count
        and _words(c_off, n, p1, s_off)
    ):
        return None
    sig = types.void(cost, c_off, prev, p_offs, cur, q_offs, n, p1, p2s, pmins, sums, s_off)
    return sig, _paths_step_codegen


def _path_total_codegen(context, builder, sig, args):
    _, c_off, _, p_off, _, q_off, n, p1, p2, pmin, parts, offs, _, t_off = args
    cost = _data(context, builder, sig, args, 0)
    prev = _data(context, builder, sig, args, 2)
    cur = _data(context, builder, sig, args, 4)
    total_data = _data(context, builder, sig, args, 12)
    part_type = sig.args[10].dtype
    part_data = [
        context.make_array(part_type)(context, builder, value).data
        for value in cgutils.unpack_tuple(builder, parts, 3)
    ]
    offs = cgutils.unpack_tuple(builder, offs, 3)
    p1v = _splat(builder, _saturated_i16(builder, p1))
    jump = _splat(builder, _saturated_i16(builder, builder.add(pmin, p2)))
    pminv = _splat(builder, builder.trunc(pmin, _I16))
    high = _splat(builder, ir.Constant(_I16, HIGH))
    least = cgutils.alloca_once_value(builder, high)
    state = _argmin_start(builder)
    one, two = ir.Constant(_I64, 1), ir.Constant(_I64, 2)
    with _chunks(builder, n) as loop:
        k = builder.mul(loop.index, ir.Constant(_I64, LANES))
        at = builder.add(p_off, k)
        before = _add_sat(builder, _load(builder, prev, at), p1v)
        same = _load(builder, prev, builder.add(at, one))
        after = _add_sat(builder, _load(builder, prev, builder.add(at, two)), p1v)
        step = _min(builder, _min(builder, same, before), _min(builder, after, jump))
        value = builder.add(_load(builder, cost, builder.add(c_off, k)), builder.sub(step, pminv))
        _store(builder, value, cur, builder.add(builder.add(q_off, k), one))
        builder.store(_min(builder, builder.load(least), value), least)
        total = value
        for data, off in zip(part_data, offs, strict=True):
            total = _add_sat(builder, total, _load(builder, data, builder.add(off, k)))
        _store(builder, total, total_data, builder.add(t_off, k))
        _argmin_step(builder, state, total, k)
    index, smallest = _argmin_end(builder, state)
    values = [
        builder.sext(_reduce_min(builder, builder.load(least)), _I64),
        builder.sext(index, _I64),
        builder.sext(smallest, _I64),
    ]
    return context.make_tuple(builder, sig.return_type, values)


@intrinsic
def _path_total_vector(
    typingctx, cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin, parts, offs, total, t_off
):
    if not (
        _int16_array(cost)
        and _int16_array(prev)
        and _int16_array(cur)
        and _int16_array(total)
        and isinstance(parts, types.UniTuple)
        and parts.count == 3
        and _int16_array(parts.dtype)
        and _word_tuple(offs)
        and offs.count == 3
        and _words(c_off, p_off, q_off, n, p1, p2, pmin, t_off)
    ):
        return None
    sig = types.UniTuple(types.int64, 3)(
        cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin, parts, offs, total, t_off
    )
    return sig, _path_total_codegen


# The operations a pixel calls are inlined in numba's IR: left to LLVM's inliner, each
# stayed a call, its arrays and offsets pushed on the stack a pixel (44 words for
# ``paths_step``), which cost more than the vector loop itself at 64 disparities (the
# vertical passes on a 64 x 64 x 64 volume, in cache: 2.2 -> 1.2 ns a disparity; ``sgm`` on
# teddy 46.6 -> 40.5 ms, one thread, an AMD EPYC VM, Zen 3, AVX2). Compile time unchanged.
@overload(paths_step, inline="always")
def _paths_step_compiled(cost, c_off, prev, p_offs, cur, q_offs, n, p1, p2s, pmins, sums, s_off):
    if not VECTOR:  # DCSTEREO_VECTOR=0: numba compiles the plain form
        return paths_step

    def compiled(cost, c_off, prev, p_offs, cur, q_offs, n, p1, p2s, pmins, sums, s_off):
        _paths_step_vector(cost, c_off, prev, p_offs, cur, q_offs, n, p1, p2s, pmins, sums, s_off)

    return compiled


@overload(path_total_step, inline="always")
def _path_total_compiled(
    cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin, parts, offs, total, t_off
):
    if not VECTOR:  # DCSTEREO_VECTOR=0: numba compiles the plain form
        return path_total_step

    def compiled(cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin, parts, offs, total, t_off):
        return _path_total_vector(
            cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin, parts, offs, total, t_off
        )

    return compiled


@overload(path_step, inline="always")
def _path_step_compiled(cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin):
    if not VECTOR:  # DCSTEREO_VECTOR=0: numba compiles the plain form
        return path_step
    return lambda cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin: _path_step_vector(
        cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin
    )


@overload(path_start)
def _path_start_compiled(cost, c_off, cur, q_off, n):
    if not VECTOR:  # DCSTEREO_VECTOR=0: numba compiles the plain form
        return path_start
    return lambda cost, c_off, cur, q_off, n: _path_start_vector(cost, c_off, cur, q_off, n)


@overload(add_saturated, inline="always")
def _add_saturated_compiled(out, o_off, a, a_off, b, b_off, n):
    if not VECTOR:  # DCSTEREO_VECTOR=0: numba compiles the plain form
        return add_saturated
    return lambda out, o_off, a, a_off, b, b_off, n: _add_saturated_vector(
        out, o_off, a, a_off, b, b_off, n
    )


@overload(first_min)
def _first_min_compiled(values, off, n):
    if not VECTOR:  # DCSTEREO_VECTOR=0: numba compiles the plain form
        return first_min
    return lambda values, off, n: _first_min_vector(values, off, n)


#: A compiled caller of each operation, for the tests (the plain forms are the functions).
@nb.njit(cache=True)
def compiled_path_step(cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin):
    """``path_step`` as compiled code runs it (the vector form)."""
    return path_step(cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin)


@nb.njit(cache=True)
def compiled_path_start(cost, c_off, cur, q_off, n):
    """``path_start`` as compiled code runs it."""
    return path_start(cost, c_off, cur, q_off, n)


@nb.njit(cache=True)
def compiled_add_saturated(out, o_off, a, a_off, b, b_off, n):
    """``add_saturated`` as compiled code runs it."""
    add_saturated(out, o_off, a, a_off, b, b_off, n)


@nb.njit(cache=True)
def compiled_paths_step(cost, c_off, prev, p_offs, cur, q_offs, n, p1, p2s, pmins, sums, s_off):
    """``paths_step`` as compiled code runs it."""
    paths_step(cost, c_off, prev, p_offs, cur, q_offs, n, p1, p2s, pmins, sums, s_off)


@nb.njit(cache=True)
def compiled_path_total_step(
    cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin, parts, offs, total, t_off
):
    """``path_total_step`` as compiled code runs it."""
    return path_total_step(
        cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin, parts, offs, total, t_off
    )


@nb.njit(cache=True)
def compiled_first_min(values, off, n):
    """``first_min`` as compiled code runs it."""
    return first_min(values, off, n)


# --------------------------------------------------------------------------- task counter


def next_task(counter):
    """Return ``counter[0]`` and add one to it, atomically when compiled (``counter``: int64).

    The threads of a parallel loop share one counter and take tasks ``0, 1, ...`` from it,
    each the next when it is done with its last, so that a thread that waits for a core
    holds back one task, not a fixed share of them.
    """
    task = counter[0]
    counter[0] += 1
    return task


@intrinsic
def _fetch_add(typingctx, counter):
    if not (isinstance(counter, types.Array) and counter.dtype == types.int64):
        return None

    def codegen(context, builder, sig, args):
        array = context.make_array(sig.args[0])(context, builder, args[0])
        return builder.atomic_rmw("add", array.data, ir.Constant(_I64, 1), "monotonic")

    return types.int64(counter), codegen


@overload(next_task)
def _next_task_compiled(counter):
    return lambda counter: _fetch_add(counter)


# --------------------------------------------------------------------------- prefetch

#: Bytes of a cache line: :func:`prefetch_pixel` asks for one line in each.
CACHE_LINE = 64


def prefetch_pixel(array, off, n):
    """Ask the processor to bring ``array[off:off + n]`` (int16) into its caches; no effect else.

    A hint only (``llvm.prefetch`` of each 64-byte line when compiled, nothing in the plain
    form): no value changes, and an address outside the array never faults.
    """
    return None


@intrinsic
def _prefetch_line(typingctx, array, off):
    if not (_int16_array(array) and _words(off)):
        return None

    def codegen(context, builder, sig, args):
        data = context.make_array(sig.args[0])(context, builder, args[0]).data
        address = builder.bitcast(builder.gep(data, [args[1]]), ir.IntType(8).as_pointer())
        i32 = ir.IntType(32)
        signature = ir.FunctionType(ir.VoidType(), [address.type, i32, i32, i32])
        function = cgutils.get_or_insert_function(builder.module, signature, "llvm.prefetch.p0")
        # a read (0), kept in every cache level (3), of data (1)
        builder.call(
            function, [address, ir.Constant(i32, 0), ir.Constant(i32, 3), ir.Constant(i32, 1)]
        )
        return context.get_dummy_value()

    return types.void(array, off), codegen


@overload(prefetch_pixel)
def _prefetch_pixel_compiled(array, off, n):
    if not VECTOR:  # DCSTEREO_VECTOR=0: numba compiles the plain form
        return prefetch_pixel
    step = CACHE_LINE // 2  # int16 values a line

    def compiled(array, off, n):
        for k in range(0, n, step):
            _prefetch_line(array, off + k)

    return compiled


@nb.njit(cache=True)
def compiled_prefetch_pixel(array, off, n):
    """``prefetch_pixel`` as compiled code runs it."""
    prefetch_pixel(array, off, n)

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

Sums saturate at the ``int16`` bounds (``llvm.sadd.sat``, one instruction on x86); the
parameters are validated so that no real cost comes near them (:mod:`dcstereo.sgm`).
"""

import numba as nb
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic, overload

#: Disparities per vector: 16 lanes of 16 bits (one AVX2 register, half an AVX-512 one).
LANES = 16

#: The largest and smallest ``int16``.
HIGH = 32767
LOW = -32768

_I16 = ir.IntType(16)
_I64 = ir.IntType(64)
_VEC = ir.VectorType(_I16, LANES)


def _saturate(value):
    return min(max(value, LOW), HIGH)


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
    """The first pixel of a path: ``L(p, k) = C(p, k)`` into ``cur[q_off + 1 + k]``.

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
    """An ``int64`` clamped to the ``int16`` range, as ``i16``."""
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


def _first_min_codegen(context, builder, sig, args):
    # one pass: each lane keeps its least value and the first offset holding it; then the
    # least of the lanes, and the least offset among the lanes that hold it
    _, off, n = args
    values = _data(context, builder, sig, args, 0)
    index_type = ir.VectorType(ir.IntType(32), LANES)
    best = cgutils.alloca_once_value(builder, _splat(builder, ir.Constant(_I16, HIGH)))
    where = cgutils.alloca_once_value(builder, ir.Constant(index_type, [0] * LANES))
    lanes = ir.Constant(index_type, list(range(LANES)))
    with _chunks(builder, n) as loop:
        k = builder.mul(loop.index, ir.Constant(_I64, LANES))
        value = _load(builder, values, builder.add(off, k))
        old = builder.load(best)
        less = builder.icmp_signed("<", value, old)
        builder.store(builder.select(less, value, old), best)
        here = builder.add(_splat(builder, builder.trunc(k, ir.IntType(32)), index_type), lanes)
        builder.store(builder.select(less, here, builder.load(where)), where)
    final = builder.load(best)
    least = _reduce_min(builder, final)
    holds = builder.icmp_signed("==", final, _splat(builder, least))
    big = ir.Constant(index_type, [2**31 - 1] * LANES)
    first = builder.select(holds, builder.load(where), big)
    index = _call(builder, f"llvm.vector.reduce.umin.v{LANES}i32", ir.IntType(32), first)
    result = context.make_tuple(
        builder, sig.return_type, [builder.sext(index, _I64), builder.sext(least, _I64)]
    )
    return result


@intrinsic
def _first_min_vector(typingctx, values, off, n):
    if not (_int16_array(values) and _words(off, n)):
        return None
    return types.UniTuple(types.int64, 2)(values, off, n), _first_min_codegen


@overload(path_step)
def _path_step_compiled(cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin):
    return lambda cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin: _path_step_vector(
        cost, c_off, prev, p_off, cur, q_off, n, p1, p2, pmin
    )


@overload(path_start)
def _path_start_compiled(cost, c_off, cur, q_off, n):
    return lambda cost, c_off, cur, q_off, n: _path_start_vector(cost, c_off, cur, q_off, n)


@overload(add_saturated)
def _add_saturated_compiled(out, o_off, a, a_off, b, b_off, n):
    return lambda out, o_off, a, a_off, b, b_off, n: _add_saturated_vector(
        out, o_off, a, a_off, b, b_off, n
    )


@overload(first_min)
def _first_min_compiled(values, off, n):
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
def compiled_first_min(values, off, n):
    """``first_min`` as compiled code runs it."""
    return first_min(values, off, n)

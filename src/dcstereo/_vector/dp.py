"""Hand-written vector code, part 3: the cells of one column of a band's DP (eq. 5).

Plain forms and vector forms side by side, as in :mod:`.simd`: ``_cells5_chain`` (the five
steps of eq. 5; with the pins of ``band_forward``: the e-step guard and the column's
restart at an anchor) and ``_cells3_chain`` (the three steps of Intille and Bobick). The
forward pass records, per block of ``R`` cells, which steps reach each cell's value in one
32-bit word (``STEP_LANE``); the layout of that word (``STEP_BYTE_*``, ``_cell_step``,
``_set_cell_steps``) is defined here, where it is written. ``tests/test_simd.py`` holds
each vector form to its plain form.
"""

import numba as nb
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic, overload

from dcstereo._vector.simd import (
    _I64,
    _VEC_F64,
    _VEC_I64,
    BAND_ROWS,
    _absent,
    _array_data,
    _broadcast,
    _contiguous,
    _load_vector,
    _store_vector,
    _vector_min,
    _vector_of,
    _wide_vectors,
    _words,
)
from dcstereo.scanline.dp import STEP_A, STEP_B, STEP_C, STEP_D, STEP_E, STEP_NONE

# --------------------------------------------------------------------------- the step words
#
# The costs are flat: cell ``k`` of band row ``r`` in column ``x`` is
# ``cost[x * nk + (k + 1) * R + r]``; the column functions get the offsets of their columns
# (unsigned, see band_costs) and loop over ``p = (k + 1) * R + r``, so that a step to ``k + 1``
# is ``p + R``. The forward pass keeps the DP values of only three columns (``x``, ``x - 1``
# and ``x - 2``: all a step reads), and records for every cell, in ``steps`` (one 32-bit
# word per block of ``R`` cells, see ``STEP_LANE``), which steps reach its value. The
# backtrack takes the first of them in the order of preference of
# ``dp.scanline_dp``'s backtrack (c, d, e, a, then b: ``_cell_step``) instead of
# recomputing the five candidates from the costs and the table: the same comparisons of
# the same values, made once in vector loops.

#: Bytes of a block's step word (see ``STEP_LANE``): the one whose bit ``r`` says that step
#: c (d, e, a) reaches row ``r``'s cell. The vector code, its twins and ``_cell_step`` all
#: take the layout from these.
STEP_BYTE_C = 0
STEP_BYTE_D = 1
STEP_BYTE_E = 2
STEP_BYTE_A = 3

#: The forward pass records the steps of a block of ``R`` cells (one disparity, the band's
#: rows) in one 32-bit word: byte ``STEP_BYTE_C`` has bit ``r`` set where step c reaches
#: row ``r``'s value, the other bytes the same for d, e and a (b always reaches it: the
#: value is at most the cell above's plus ``occ2``). The vector code makes each byte from
#: one compare's lane mask (``vmovmskpd`` / ``kmovb``) instead of narrowing eight 64-bit
#: masks to bytes, which on AVX2 took a third of the five-step cell's instructions.
#: ``STEP_LANE << r`` are row ``r``'s four bits.
STEP_LANE = 0x01010101


@nb.njit(cache=True, inline="always")
def _cell_step(steps, o, r):
    """Return the step into lane ``r``'s cell of block word ``steps[o]``: c, d, e, a, else b."""
    w = (steps[o] >> r) & STEP_LANE
    if w & (1 << 8 * STEP_BYTE_C):
        return STEP_C
    if w & (1 << 8 * STEP_BYTE_D):
        return STEP_D
    if w & (1 << 8 * STEP_BYTE_E):
        return STEP_E
    if w & (1 << 8 * STEP_BYTE_A):
        return STEP_A
    return STEP_B


def _set_cell_steps(steps, o, r, c, d, e, a):
    """Record which of the steps c, d, e, a reach lane ``r``'s cell of block word ``steps[o]``."""
    word = 0
    for reached, byte in ((c, STEP_BYTE_C), (d, STEP_BYTE_D), (e, STEP_BYTE_E), (a, STEP_BYTE_A)):
        word |= int(reached) << (8 * byte + r)
    steps[o] = (steps[o] & np.uint32(0xFFFFFFFF ^ (STEP_LANE << r))) | np.uint32(word)


@nb.njit(cache=True, inline="always")
def _anchor_step(c, d, e):
    """Return ``(value, step)`` of an anchor cell from its match steps c, d and e.

    The value is ``min(min(c, d), e)``; the step the first of c, d, e that reaches it
    (``STEP_NONE`` if none does). Of ``_cells5_chain``'s pinned lanes and of
    ``band_forward``'s anchors in scalar code.
    """
    best = min(min(c, d), e)
    step = STEP_E if e == best else STEP_NONE
    step = STEP_D if d == best else step
    return best, STEP_C if c == best else step


def _cells5_chain(
    cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2, slant2, e_off=None,
    pin_k=None, pin_total=None, pin_steps=None, o_pin=0,
):  # fmt: skip
    """Five-step cells ``k_lo..k_hi`` of one column, in one descending loop.

    ``cur``, ``prev`` and ``prev2``: the values of columns ``x``, ``x - 1`` and ``x - 2``.
    The steps from earlier columns (c, d, e, a: ``_earlier_steps5``, the same expressions
    in the same order), then the b step from the cell above: ``min`` with its value plus
    ``occ2`` (the value of ``scanline_dp``'s branch). Which steps reach the cell's value
    goes to the word of its block, ``steps[o_steps + p // R]`` (see ``band_forward``).
    Compiled code runs ``_cells5_vector`` (the same operations, a block of ``R`` cells at a
    time).

    The pins of ``band_forward``, per lane ``r`` (None: none in this column):

    * ``e_off[r]`` (float64, ``R``): 0, or inf for a lane pinned at ``x - 1``, added to
      ``prev2`` in the e step, which then cannot jump over the anchor (``v + 0`` is ``v``:
      the other lanes' values are unchanged, bit for bit);
    * ``pin_k[r]`` (float64, ``R``): ``k`` of the lane's anchor in this column, or -1.
      A pinned lane's earlier steps are replaced by 0 at the anchor and inf elsewhere, so
      the b chain leaves the anchor at 0, the cells below it at ``occ2``, ``2 occ2``, ...
      (the sums in that order) and inf above it: the column restarts at the anchor.
      Its step words are those of these values; the backtrack never reads them
      (``band_backtrack_row`` ends a segment on reaching an anchor's column). With
      ``pin_k``, ``pin_total[o_pin + r]`` (float64) gets the anchor's value by a match
      step, ``min(min(c, d), e)`` of its cell (the total of the segment it ends), and
      ``pin_steps[o_pin + r]`` (int64) the first of c, d, e that reaches it (``STEP_C``,
      ``STEP_D``, ``STEP_E``; ``STEP_NONE`` if none does); the unpinned lanes' entries
      are not written. Every pinned lane's ``k`` must lie in ``k_lo..k_hi``.
    """
    nr = np.uint64(BAND_ROWS)
    top = np.uint64((k_hi + 2) * BAND_ROWS - 1)
    for i in range(np.uint64((k_hi - k_lo + 1) * BAND_ROWS)):
        p = top - i
        h2 = 2.0 * cost[o_here + p]
        c = prev[p] + h2
        u = h2 + cost[o_left + p] + slant2
        d = prev[p + nr] + cost[o_here + p + nr] + u
        if e_off is None:
            e = prev2[p - nr] + cost[o_left + p - nr] + u
        else:
            e = prev2[p - nr] + e_off[p % nr] + cost[o_left + p - nr] + u
        a = prev[p - nr] + occ2
        cell = min(min(c, d), min(e, a))
        if pin_k is not None and pin_k[p % nr] >= 0:
            at = pin_k[p % nr] == np.float64(p // nr - 1)
            if at:
                i_pin = int(o_pin) + int(p % nr)  # ints: np.int64 + np.uint64 is float
                pin_total[i_pin], pin_steps[i_pin] = _anchor_step(c, d, e)
            cell = 0.0 if at else np.inf
        v = min(cell, cur[p + nr] + occ2)
        cur[p] = v
        _set_cell_steps(steps, o_steps + p // nr, int(p % nr), c == v, d == v, e == v, a == v)


def _cells3_chain(cur, prev, cost, o_here, steps, o_steps, k_lo, k_hi, occ2):
    """Three-step cells: steps c and a (``_earlier_steps3``), then b (see ``_cells5_chain``)."""
    nr = np.uint64(BAND_ROWS)
    top = np.uint64((k_hi + 2) * BAND_ROWS - 1)
    for i in range(np.uint64((k_hi - k_lo + 1) * BAND_ROWS)):
        p = top - i
        c = prev[p] + 2.0 * cost[o_here + p]
        a = prev[p - nr] + occ2
        v = min(min(c, a), cur[p + nr] + occ2)
        cur[p] = v
        _set_cell_steps(steps, o_steps + p // nr, int(p % nr), c == v, False, False, a == v)


# The b step makes each column one chain down the disparities (a cell's value is the
# least of its earlier steps and the value of the cell above plus ``occ2``). numba's
# vectorized form of the flat loop over ``(k, r)`` kept that chain in memory: each block
# of 8 cells stored, loaded back by the next block, and reversed twice (the loop runs
# down, and the vector lanes up), about 18 cycles of latency per block. Here the chain and
# the neighbouring blocks (``prev`` at ``k + 1`` and ``k - 1``, the costs at ``k + 1``)
# stay in registers from one block to the next: the block's new loads are ``prev`` and
# ``prev2`` below it, its cost here and the left column's cost below it.

#: Whether the cells' vector code carries the blocks it has loaded (the left and upper
#: neighbours of the next block) in registers from one block to the next. With AVX-512's
#: 32 registers it does. With AVX2's 16, where each value of ``R`` lanes takes two, the
#: carried values were spilled to the stack and loaded back every block: loading them
#: again from the arrays (in L1) made dsi5 4-7 % faster (A/B in one process, tsukuba,
#: venus, teddy). Tests exercise the branch of the host they run on.
_CARRY = _wide_vectors()


def _cells_codegen(five, guarded=False, pinning=False):
    def codegen(context, builder, sig, args):
        if five:
            _, _, _, _, o_here, o_left, _, o_steps, k_lo, k_hi, occ2, slant2 = args[:12]
        else:
            _, _, _, o_here, _, o_steps, k_lo, k_hi, occ2 = args

        def data(*indices):
            return (_array_data(context, builder, sig, args, i) for i in indices)

        if five:
            cur, prev, prev2, cost, steps_data = data(0, 1, 2, 3, 6)
        else:
            cur, prev, cost, steps_data = data(0, 1, 2, 4)
        steps_data = builder.gep(steps_data, [o_steps])
        width = ir.Constant(_I64, BAND_ROWS)
        word_type = ir.IntType(32)
        occ2_vec = _broadcast(builder, occ2, _VEC_F64)
        two = _vector_of(2.0, _VEC_F64)

        def lanes(mask, byte):
            # the lanes' compare results as the bits of one byte of the block's word
            bits = builder.zext(builder.bitcast(mask, ir.IntType(BAND_ROWS)), word_type)
            return builder.shl(bits, ir.Constant(word_type, 8 * byte))

        top = builder.mul(builder.add(k_hi, ir.Constant(_I64, 1)), width)  # block k_hi + 1
        above = builder.add(top, width)
        count = builder.add(builder.sub(k_hi, k_lo), ir.Constant(_I64, 1))
        # the values carried from the block above (each alloca becomes a register; without
        # _CARRY, a load at the start of each block)
        chain = cgutils.alloca_once_value(builder, _load_vector(builder, cur, above))
        prev_here = cgutils.alloca_once_value(builder, _load_vector(builder, prev, top))
        zero = ir.Constant(_I64, 0)
        if guarded:
            e_off_vec = _load_vector(builder, _array_data(context, builder, sig, args, 12), zero)
        if pinning:
            pin_k_vec = _load_vector(builder, _array_data(context, builder, sig, args, 13), zero)
            pinned_lanes = builder.fcmp_ordered(">=", pin_k_vec, _vector_of(0.0, _VEC_F64))
            inf_vec = _vector_of(float("inf"), _VEC_F64)
            zero_vec = _vector_of(0.0, _VEC_F64)
            # the match steps c, d, e of each pinned lane's anchor cell, kept as the loop
            # passes it (a select each), for the anchor's value and step after the loop
            at_anchor = [cgutils.alloca_once_value(builder, inf_vec) for _ in range(3)]
        if five:
            slant2_vec = _broadcast(builder, slant2, _VEC_F64)
            prev_up = cgutils.alloca_once_value(builder, _load_vector(builder, prev, above))
            cost_up = cgutils.alloca_once_value(
                builder, _load_vector(builder, cost, builder.add(o_here, above))
            )
            left_here = cgutils.alloca_once_value(
                builder, _load_vector(builder, cost, builder.add(o_left, top))
            )
        with cgutils.for_range(builder, count) as loop:
            p = builder.sub(top, builder.mul(loop.index, width))
            below = builder.sub(p, width)
            if not _CARRY:
                up = builder.add(p, width)
                builder.store(_load_vector(builder, prev, p), prev_here)
                if five:
                    builder.store(_load_vector(builder, prev, up), prev_up)
                    builder.store(_load_vector(builder, cost, builder.add(o_here, up)), cost_up)
                    builder.store(_load_vector(builder, cost, builder.add(o_left, p)), left_here)
            prev_below = _load_vector(builder, prev, below)
            here = _load_vector(builder, cost, builder.add(o_here, p))
            h2 = builder.fmul(two, here)
            c = builder.fadd(builder.load(prev_here), h2)
            a = builder.fadd(prev_below, occ2_vec)
            if five:
                left_below = _load_vector(builder, cost, builder.add(o_left, below))
                u = builder.fadd(builder.fadd(h2, builder.load(left_here)), slant2_vec)
                d = builder.fadd(builder.fadd(builder.load(prev_up), builder.load(cost_up)), u)
                e2 = _load_vector(builder, prev2, below)
                if guarded:
                    e2 = builder.fadd(e2, e_off_vec)
                e = builder.fadd(builder.fadd(e2, left_below), u)
                cell = _vector_min(builder, _vector_min(builder, c, d), _vector_min(builder, e, a))
                if pinning:
                    k_here = builder.sub(builder.udiv(p, width), ir.Constant(_I64, 1))
                    k_vec = _broadcast(builder, builder.sitofp(k_here, ir.DoubleType()), _VEC_F64)
                    at = builder.fcmp_ordered("==", pin_k_vec, k_vec)
                    for slot, step_value in zip(at_anchor, (c, d, e), strict=True):
                        builder.store(builder.select(at, step_value, builder.load(slot)), slot)
                    pin_value = builder.select(at, zero_vec, inf_vec)
                    cell = builder.select(pinned_lanes, pin_value, cell)
            else:
                cell = _vector_min(builder, c, a)
            v = _vector_min(builder, cell, builder.fadd(builder.load(chain), occ2_vec))
            _store_vector(builder, v, cur, p)
            steps = builder.or_(
                lanes(builder.fcmp_ordered("==", c, v), STEP_BYTE_C),
                lanes(builder.fcmp_ordered("==", a, v), STEP_BYTE_A),
            )
            if five:
                steps = builder.or_(steps, lanes(builder.fcmp_ordered("==", d, v), STEP_BYTE_D))
                steps = builder.or_(steps, lanes(builder.fcmp_ordered("==", e, v), STEP_BYTE_E))
            block = builder.udiv(p, width)
            builder.store(steps, builder.gep(steps_data, [block]), align=4)
            builder.store(v, chain)
            if five:
                builder.store(builder.load(prev_here), prev_up)
                builder.store(here, cost_up)
                builder.store(left_below, left_here)
            builder.store(prev_below, prev_here)
        if pinning:
            match_steps = [builder.load(slot) for slot in at_anchor]
            _store_anchors(context, builder, sig, args, match_steps, pinned_lanes)
        return context.get_dummy_value()

    return codegen


def _store_anchors(context, builder, sig, args, match_steps, pinned_lanes):
    """Store the pinned lanes' anchor values and steps (masked stores).

    ``_cells5_chain``'s ``pin_total`` and ``pin_steps``, from the match steps
    ``(c, d, e)`` at the anchors.
    """
    c, d, e = match_steps
    best = _vector_min(builder, _vector_min(builder, c, d), e)
    step = _vector_of(STEP_NONE, _VEC_I64)
    for value, code in ((e, STEP_E), (d, STEP_D), (c, STEP_C)):  # the first that reaches it
        step = builder.select(builder.fcmp_ordered("==", value, best), _vector_of(code, _VEC_I64),
                              step)  # fmt: skip
    o_pin = args[16]
    for value, index, kind in ((best, 14, "f64"), (step, 15, "i64")):
        data = _array_data(context, builder, sig, args, index)
        masked_store = cgutils.get_or_insert_function(
            builder.module,
            ir.FunctionType(
                ir.VoidType(),
                [value.type, value.type.as_pointer(), ir.IntType(32), pinned_lanes.type],
            ),
            f"llvm.masked.store.v{BAND_ROWS}{kind}.p0",
        )
        pointer = builder.bitcast(builder.gep(data, [o_pin]), value.type.as_pointer())
        builder.call(masked_store, [value, pointer, ir.Constant(ir.IntType(32), 8), pinned_lanes])


def _cells_arguments_ok(arrays, offsets, floats):
    return (
        all(_contiguous(a, types.float64) for a in arrays[:-1])
        and _contiguous(arrays[-1], types.uint32)
        and _words(*offsets)
        and all(f == types.float64 for f in floats)
    )


@intrinsic
def _cells5_vector(typingctx, cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi,
                   occ2, slant2, e_off, pin_k, pin_total, pin_steps, o_pin):  # fmt: skip
    guarded, pinning = not _absent(e_off), not _absent(pin_k)
    if not (
        _cells_arguments_ok(
            (cur, prev, prev2, cost, steps), (o_here, o_left, o_steps, k_lo, k_hi), (occ2, slant2)
        )
        and (not guarded or _contiguous(e_off, types.float64))
        and (
            not pinning
            or _contiguous(pin_k, types.float64)
            and _contiguous(pin_total, types.float64)
            and _contiguous(pin_steps, types.int64)
            and _words(o_pin)
        )
    ):
        return None
    signature = types.void(
        cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2, slant2, e_off,
        pin_k, pin_total, pin_steps, o_pin,
    )  # fmt: skip
    return signature, _cells_codegen(True, guarded, pinning)


@intrinsic
def _cells3_vector(typingctx, cur, prev, cost, o_here, steps, o_steps, k_lo, k_hi, occ2):
    if not _cells_arguments_ok((cur, prev, cost, steps), (o_here, o_steps, k_lo, k_hi), (occ2,)):
        return None
    signature = types.void(cur, prev, cost, o_here, steps, o_steps, k_lo, k_hi, occ2)
    return signature, _cells_codegen(False)


# inlined in numba's IR (a small function: one intrinsic), not left to LLVM's inliner,
# which at stop 43 kept the larger pinned forms of that time out of band_forward (a call a
# column)
@overload(_cells5_chain, inline="always")
def _cells5_compiled(cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2,
                     slant2, e_off=None, pin_k=None, pin_total=None, pin_steps=None,
                     o_pin=0):  # fmt: skip

    def run(cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2, slant2,
            e_off=None, pin_k=None, pin_total=None, pin_steps=None, o_pin=0):  # fmt: skip
        _cells5_vector(
            cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2, slant2,
            e_off, pin_k, pin_total, pin_steps, np.int64(o_pin),
        )  # fmt: skip

    return run


@overload(_cells3_chain)
def _cells3_compiled(cur, prev, cost, o_here, steps, o_steps, k_lo, k_hi, occ2):

    def run(cur, prev, cost, o_here, steps, o_steps, k_lo, k_hi, occ2):
        _cells3_vector(cur, prev, cost, o_here, steps, o_steps, k_lo, k_hi, occ2)

    return run

"""The scanline DP of eq. 5 on ``BAND_ROWS`` scanlines in lockstep, free or pinned.

The per-row DP (:mod:`.dp`) loops over the disparity axis ``k`` (16..256 cells); the
compiler's vector loops step 32 or more cells at a time, so most of a row runs in their
scalar remainder, and the b-step chain down a column is one sequential chain per row.
Here ``BAND_ROWS`` rows run together with the row as the innermost, contiguous axis: the
costs of a band and the steps its DP takes are ``[x, (k + 1) * BAND_ROWS + r]`` (cell
``k`` of row ``r`` of the band; one padding cell on each side of the band, inf), and every
per-cell operation, the b-chain included (it is independent across rows), is one vector
operation over the rows (:mod:`.simd_dp`). The forward pass keeps the values of the last
three columns only and records, per cell, which steps reach its value; backtracking stays
per row and follows those records.

The results are *bitwise* those of ``dp.scanline_dp`` over whole rows: every cell is
computed by the same float64 expression, in the same order of operations, and the step
recorded for it is the first of c, d, e, a, b (``scanline_dp``'s backtrack's order of
preference) whose value equals the cell's. The padding cells replace ``scanline_dp``'s
bounds-checked slow cells: a step that would read outside the band reads inf, and ``min``
with inf changes nothing.

Anchors: a row may be pinned at pairs ``x <-> j`` (``dc``'s feature pairs, ``dsi3-gcp``'s
control points), and then its result is that of running ``scanline_dp`` segment by
segment, free start -> first anchor -> ... -> last anchor -> free end, as ``gcp.gcp_row``
does, in one pass over the row: at an anchor column the match-step value of the anchor
cell is kept as that segment's total, the column is cleared and the anchor cell set to 0
(the anchored start of the next segment; the b-chain then fills the cells below it, and
their recorded step is b), the e step from the column before the anchor to the column
after it reads inf, and the virtual start cells (``j = -1``) are off after the first
anchor. Cells outside the next segment's rectangle then hold either inf (``j`` below the
anchor's) or values that no cell of the segment reads (``j`` beyond the segment's end:
steps never decrease ``j``, and the next anchor column clears them).
"""

import numba as nb
import numpy as np

from dcstereo._vector.dp import _anchor_step, _cell_step, _cells3_chain, _cells5_chain
from dcstereo._vector.simd import BAND_ROWS, _wide_vectors
from dcstereo.costs.band import _cost_column
from dcstereo.result import FLAG_OCCLUDED
from dcstereo.scanline.dp import STEP_A, STEP_B, STEP_C, STEP_D, STEP_E

#: Whether ``band_forward`` makes the anchors inside the five-step cells' vector code (the
#: pinned forms of ``_cells5_chain``: the column's restart at the anchor and the anchor's
#: match steps, a select or two a block; AVX-512), or, after the column's cells, makes each
#: pinned row's anchor from its neighbours and stores the row's restart (scalar code, a
#: store per cell of that row; AVX2). The e-step guard (``e_off``, an addition a block) is
#: in the vector code on both (on AVX2 in every column after the first, without a branch).
#: With AVX-512's 32 registers the vector form was 0.93-0.99 of dc's time (docs/SPEED.md,
#: stop 30). With AVX2's 16, where each value of ``R`` lanes takes two, the pinned forms
#: spilled to the stack every block: the scalar form is 0.91-0.94 of dc's time on the
#: Middlebury scenes there, and about as fast where nearly every pixel is a pair
#: (docs/SPEED.md, stop 44). Tests exercise the branch of the host they run on (and the
#: plain-Python one both); the pinned forms are tested against their twin on every host.
_PINS_IN_LOOP = _wide_vectors()


@nb.njit(cache=True)
def band_forward(cost, width, dsi, step_costs, anchored, anchors, ring, steps, ends, make_costs):
    """Forward pass of the whole-scanline DP (eq. 5) of the ``BAND_ROWS`` rows of a band.

    ``dsi`` (``records.Dsi``): the disparities; ``step_costs`` (``records.StepCosts``): the
    DP's step costs and model. ``make_costs`` None: ``cost`` comes from ``band_lane_costs``.
    Otherwise it is a ``records.CostPass`` (its ``sums``: ``SUMS_READY`` after
    ``band_block_match`` made the costs), ``cost`` is scratch of two columns (``2 * nk``),
    and the pass makes each column's costs itself, just before the column's cells
    (``_cost_column``): the same values, without the band's cost array, which on wide images
    and disparity ranges leaves the caches. (None is a type of its own to the compiler: the
    two uses are two compiled functions, and the one with the array has no trace of the
    other.)

    Node ``(x, dmin + k)`` of band row ``r`` gets the value of ``scanline_dp``'s table
    (with ``x_lo = j_lo = 0``, ``x_hi = j_hi = width - 1``) and the steps that reach it to
    bits ``r``, ``8 + r``, ``16 + r`` and ``24 + r`` (c, d, e, a) of the word
    ``steps[x * (ndisp + 2) + k + 1]`` (uint32, ``width * (ndisp + 2)``; ``STEP_LANE``,
    ``_cell_step``). ``ring`` (float64, ``(3, nk)``) holds the values of the last three
    columns (the cells of a column are
    made by ``_cells5_chain`` or ``_cells3_chain``, vector code). ``ends`` (float64,
    ``2 * ndisp * R``) gets the values of the free end's nodes: at ``k * R + r`` the node
    with ``j = width - 1`` and ``x < width - 1`` of disparity index ``k`` (inf where there
    is none), at ``(ndisp + k) * R + r`` the node of the last column.

    With ``anchored``, ``anchors`` (``records.Anchors``) holds the pins:
    ``anchors.pins[x * R + r]`` (int64) is the right pixel band row ``r`` is pinned to at
    ``x`` (-1: none; increasing in ``x`` along a row, every pair inside the disparity range),
    ``anchors.pinned[x]`` whether any row of the band is pinned at ``x``; the match-step
    value of each anchor cell (the total of the segment it ends) goes to
    ``anchors.total[x * R + r]`` and the step into it (the first of c, d, e that reaches
    its value; ``STEP_NONE`` if none does) to ``anchors.steps[x * R + r]``. The column of
    an anchor then holds only the anchor (0) and the b steps below it (their step bits are
    not read: the backtrack ends a segment on reaching the anchor's column,
    ``band_backtrack_row``);
    the e step over an anchor, from column ``x - 2`` to ``x``, reads inf. Where
    ``_PINS_IN_LOOP`` (AVX-512), the five-step cells' vector code does both
    (``_cells5_chain``'s ``pin_k`` and ``e_off``, in the columns that need them) and makes
    the anchors' values and steps (a select per block of the three match steps, masked
    stores after the column): ``dc`` 0.93-0.99 of its time on tsukuba and venus against
    the scalar form, 0.83 on the 3000 x 2000 x 256 pair (docs/SPEED.md, stop 30).
    Otherwise (AVX2), and for the three-step DP and the first column, the columns run the
    plain cells (or the guard's form), and then each pinned row's anchor is made from its
    neighbours by the same operations and its cells of the column are stored.
    """
    dmin, ndisp, _ = dsi
    occ2, slant2, five = step_costs
    pins, pinned, anchor_total, anchor_steps = anchors
    nr = BAND_ROWS
    nk = (ndisp + 2) * nr
    unk = np.uint64(nk)
    inf = np.inf
    free = np.ones(nr, dtype=np.bool_)  # the virtual start: before a row's first anchor
    e_off = np.zeros(nr)
    pin_k = np.full(nr, -1.0)
    # the cells of an anchor's column, from restart[ndisp + 1 + k_a - k]: inf above the
    # anchor (k > k_a), then the anchor (0) and the cells m b steps below it (0 + occ2 +
    # ... + occ2, in that order), so that one loop of fixed length stores a column
    restart = np.empty(2 * ndisp + 2)
    for m in range(ndisp + 1):
        restart[m] = inf
    restart[ndisp + 1] = 0.0
    for m in range(ndisp + 2, 2 * ndisp + 2):
        restart[m] = restart[m - 1] + occ2
    cur = ring[0]
    prev = ring[1]  # column -1, the virtual start
    prev2 = ring[2]  # column -2
    for i in range(unk):
        prev[i] = inf
        prev2[i] = inf
    for k in range(min(ndisp, -dmin + 1)):  # j = -1 - dmin - k >= -1
        for r in range(nr):
            prev[(k + 1) * nr + r] = 0.0
    for i in range(np.uint64(2 * ndisp * nr)):
        ends[i] = inf
    for x in range(width):
        o_steps = np.uint64(x * (ndisp + 2))
        if make_costs is None:
            o_here = np.uint64(x * nk)
            o_left = o_here - unk if x >= 1 else o_here
        else:
            o_here = np.uint64((x % 2) * nk)
            o_left = np.uint64(((x + 1) % 2) * nk) if x >= 1 else o_here
            left_t, right_t, _, radius, spread, vs, incremental, hsum = make_costs
            _cost_column(
                left_t,
                right_t,
                x,
                width,
                dmin,
                ndisp,
                radius,
                spread,
                vs,
                incremental,
                hsum,
                cost,
                o_here,
            )
        k_lo = max(0, x - (width - 1) - dmin)
        k_hi = min(ndisp - 1, x - dmin)
        pin_here = anchored and pinned[x]
        # the e step's guard: on AVX2 every column after the first takes it (e_off 0 in
        # the rows not pinned at x - 1; e2 + 0.0 is e2), one form of the cells instead of
        # a branch on the pins of x - 1 that the processor could not predict (dc 0.97 of
        # its time, docs/SPEED.md, stop 45)
        guard = anchored and five and x >= 1 and (not _PINS_IN_LOOP or pinned[x - 1])
        if guard:
            # rows pinned at x - 1: no e step from x - 2 over the anchor
            for r in range(nr):
                e_off[r] = inf if pins[(x - 1) * nr + r] >= 0 else 0.0
        if pin_here:
            for r in range(nr):
                j = pins[x * nr + r]
                if _PINS_IN_LOOP:
                    pin_k[r] = np.float64(x - j - dmin) if j >= 0 else -1.0  # the anchor's k
                if j >= 0:
                    free[r] = False
        if k_lo > k_hi:
            for i in range(unk):
                cur[i] = inf
        else:
            for i in range(np.uint64((k_lo + 1) * nr)):
                cur[i] = inf
            for i in range(np.uint64((k_hi + 2) * nr), unk):
                cur[i] = inf
        k_virtual = x - dmin + 1  # j = -1
        if 0 <= k_virtual < ndisp:
            for r in range(nr):
                cur[(k_virtual + 1) * nr + r] = 0.0 if free[r] else inf
        if k_lo <= k_hi:
            slant_ok = five and x >= 1
            in_loop = _PINS_IN_LOOP and slant_ok
            # the pins in the cells' vector code: a compiled form for each set of them,
            # each column the one it needs (e_off, pin_k or both cost a vector operation or
            # three per block; without in_loop, e_off only). Spelled-out calls: the
            # arguments passed as one tuple (*cells) made dc 1.06-1.09x slower on tsukuba
            # and venus (A/B in one process)
            o_pin = np.int64(x * nr)
            if in_loop and guard and pin_here:
                _cells5_chain(
                    cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2,
                    slant2, e_off, pin_k, anchor_total, anchor_steps, o_pin,
                )  # fmt: skip
            elif in_loop and pin_here:
                _cells5_chain(
                    cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2,
                    slant2, None, pin_k, anchor_total, anchor_steps, o_pin,
                )  # fmt: skip
            elif slant_ok and guard:
                _cells5_chain(
                    cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2,
                    slant2, e_off,
                )  # fmt: skip
            elif slant_ok:
                _cells5_chain(
                    cur, prev, prev2, cost, o_here, o_left, steps, o_steps, k_lo, k_hi, occ2,
                    slant2,
                )  # fmt: skip
            else:
                _cells3_chain(cur, prev, cost, o_here, steps, o_steps, k_lo, k_hi, occ2)
            if pin_here and not in_loop:
                # the pins in scalar code, after the column's cells (every column on AVX2;
                # the three-step cells and the first column): each pinned row's cells of
                # this column are replaced, and its anchor made from the columns before (an
                # e step over an anchor at x - 1 adds e_off's inf, as the vector code does)
                for r in range(nr):
                    j = pins[x * nr + r]
                    if j < 0:
                        continue
                    # the anchor ends a segment: its value by a match step (c, d, e; no a,
                    # no b: those of _cells5_chain's, the same operations in the same
                    # order), and the first of them that reaches it ...
                    k_a = x - j - dmin
                    p = int((k_a + 1) * nr + r)  # an int: np.uint64 + np.int64 is float
                    h2 = 2.0 * cost[o_here + p]
                    c = prev[p] + h2
                    best = c
                    step = STEP_C
                    if slant_ok:
                        u = h2 + cost[o_left + p] + slant2
                        d = prev[p + nr] + cost[o_here + p + nr] + u
                        e2 = prev2[p - nr]
                        if guard:
                            e2 += e_off[r]  # inf: an anchor at x - 1 (0: e2 itself)
                        e = e2 + cost[o_left + p - nr] + u
                        best, step = _anchor_step(c, d, e)
                    anchor_total[x * nr + r] = best
                    anchor_steps[x * nr + r] = step
                    # ... and starts the next one: the column holds only the anchor (0)
                    # and the b steps below it (the values of clearing it and running the
                    # b-chain), which the backtrack of that segment takes without reading
                    # their steps
                    # (one loop whose length is the column's, not two that end at the
                    # anchor: an exit the processor predicts)
                    o_restart = ndisp + 1 + k_a
                    for k in range(k_lo, k_hi + 1):
                        cur[(k + 1) * nr + r] = restart[o_restart - k]
        # the free end's nodes: j == width - 1 before the last column, then the last column
        k_end = x - (width - 1) - dmin
        if x < width - 1 and 0 <= k_end < ndisp:
            for r in range(nr):
                ends[k_end * nr + r] = cur[(k_end + 1) * nr + r]
        if x == width - 1:
            for k in range(ndisp):
                for r in range(nr):
                    ends[(ndisp + k) * nr + r] = cur[(k + 1) * nr + r]
        prev2, prev, cur = prev, cur, prev2


@nb.njit(cache=True)
def band_backtrack_row(steps, ends, width, dsi, r, anchor_x, nanchors, anchors, disp_row, flag_row):
    """Paths of band row ``r`` after ``band_forward``: write disparities, flags; return the total.

    As ``gcp_row``, segment by segment: each segment that ends at an anchor (from the free
    start or the anchor before) is traced from it when its value is finite, and the anchor
    pixel gets ``x - j``, flag 0; the last segment ends free (none when the last anchor is
    the row's last pixel). The total is the sum of the segment totals in order (inf when a
    segment has no path). The anchors are the columns ``anchor_x[:nanchors]``, increasing
    (those with ``anchors.pins[x * R + r] >= 0``; none in free mode). ``disp_row``/``flag_row``
    must hold NaN/border. ``dsi``: ``records.Dsi``.

    One walk down the row from its end, segment after segment: a segment writes only its
    own columns (after its starting anchor, up to its end), so the order in which the
    segments are traced changes nothing, and a walk that reaches the starting anchor's
    column goes on from that anchor, without a call and a loop exit per segment. The
    steps are those of ``steps`` (``ndisp + 2`` words a column, see ``band_forward``),
    and into an anchor ``anchors.steps``; the writes are those of ``apply_path``. A path
    that reaches the starting anchor's column is at the anchor or below it, and from
    there only b steps lead to it (``band_forward`` keeps the other cells of that column
    at inf, and no e step crosses it), which write nothing: the segment ends there.
    """
    dmin, ndisp, _ = dsi
    pins, anchor_total, anchor_steps = anchors.pins, anchors.total, anchors.steps
    nr = BAND_ROWS
    nwords = ndisp + 2
    inf = np.inf
    total = 0.0
    for i in range(nanchors):
        total += anchor_total[anchor_x[i] * nr + r]
    anchored = nanchors > 0  # the segment being walked starts at an anchor
    x_lo = 0
    j_lo = 0
    if anchored:
        x_lo = anchor_x[nanchors - 1]
        j_lo = pins[x_lo * nr + r]
    # the free end: nodes with x == width - 1, then nodes with j == width - 1
    walking = False
    x = k = s = -1
    if not (anchored and x_lo == width - 1):
        value = inf
        for kk in range(ndisp):
            j = width - 1 - dmin - kk
            if j_lo <= j <= width - 1:
                v = ends[(ndisp + kk) * nr + r]
                if v < value:
                    value = v
                    x = width - 1
                    k = kk
        for kk in range(ndisp):
            xx = width - 1 + dmin + kk
            if x_lo <= xx < width - 1:
                v = ends[kk * nr + r]
                if v < value:
                    value = v
                    x = xx
                    k = kk
        total += value
        if value < inf:
            walking = True
            s = _cell_step(steps, x * nwords + k + 1, r)
    i = nanchors  # the segment being walked ends at anchor i (nanchors: the free end)
    while True:
        while walking:
            if anchored and x == x_lo:
                break  # the rest are b steps up the anchor's column, which write nothing
            d = dmin + k
            if s == STEP_C or s == STEP_D:
                disp_row[x] = d
                flag_row[x] = 0
            elif s == STEP_E:
                disp_row[x] = d
                flag_row[x] = 0
                disp_row[x - 1] = d - 0.5
                flag_row[x - 1] = 0
            elif s == STEP_A:
                disp_row[x] = np.nan
                flag_row[x] = FLAG_OCCLUDED
            if s == STEP_C:
                x -= 1
            elif s == STEP_A:
                x -= 1
                k -= 1
            elif s == STEP_B:
                k += 1
            elif s == STEP_D:
                x -= 1
                k += 1
            else:  # STEP_E (and, as in scanline_dp, STEP_NONE)
                x -= 2
                k -= 1
            if not anchored and (x == -1 or x - dmin - k == -1):
                break
            s = _cell_step(steps, x * nwords + k + 1, r)
        # the next segment down ends at anchor i - 1
        i -= 1
        if i < 0:
            break
        x = anchor_x[i]
        j = pins[x * nr + r]
        disp_row[x] = x - j
        flag_row[x] = 0
        walking = anchor_total[x * nr + r] < inf
        k = x - j - dmin
        s = anchor_steps[x * nr + r]
        anchored = i > 0
        x_lo = anchor_x[i - 1] if anchored else 0
    return total

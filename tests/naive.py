"""Slow, obviously correct twins of the compiled kernels.

Each function here follows the written definition (NOTES.md, eq. 4 and eq. 5) in plain
Python, in the DSI's own ``(i, j) = (x_left, x_right)`` coordinates rather than the band
form the kernels use, so the two share no index arithmetic.
"""

import math

import numpy as np

C, A, B, D, E = "c", "a", "b", "d", "e"


def window_sad(left_signal, right_signal, y, x_left, x_right, radius):
    """Eq. 4 for one DSI cell, as documented in ``costs.row_costs``.

    Rows outside the image are edge-replicated (the same rows in both views); columns
    ``s`` where ``x_left + s`` or ``x_right + s`` leaves an image are skipped and the sum
    is rescaled to the full window.
    """
    height, width = left_signal.shape
    total = 0
    used = 0
    for s in range(-radius, radius + 1):
        xl, xr = x_left + s, x_right + s
        if not (0 <= xl < width and 0 <= xr < width):
            continue
        used += 1
        for t in range(-radius, radius + 1):
            yy = min(max(y + t, 0), height - 1)
            total += abs(int(left_signal[yy, xl]) - int(right_signal[yy, xr]))
    win = 2 * radius + 1
    return total if used == win else total * win / used


def row_costs(left_signal, right_signal, y, dmin, ndisp, radius):
    """Banded DSI of row ``y``: ``out[x, k]`` for ``d = dmin + k``, inf outside the image."""
    width = left_signal.shape[1]
    out = np.full((width, ndisp), np.inf)
    for x in range(width):
        for k in range(ndisp):
            j = x - (dmin + k)
            if 0 <= j < width:
                out[x, k] = window_sad(left_signal, right_signal, y, x, j, radius)
    return out


def dsi_cell(cost, dmin, i, j):
    """DSI(i, j) from the band form; inf outside the band or the image."""
    k = i - j - dmin
    if i < 0 or j < 0 or i >= cost.shape[0] or k < 0 or k >= cost.shape[1]:
        return math.inf
    return cost[i, k]


def step_cost(cost, dmin, occ, name, i, j):
    """Cost of entering node ``(i, j)`` by step ``name`` (eq. 5, *not* doubled)."""
    here = dsi_cell(cost, dmin, i, j)
    if name == C:
        return here
    if name in (A, B):
        return occ
    if name == D:  # from (i-1, j-2): cells b = (i, j-1), c = (i-1, j-1)
        return here + (dsi_cell(cost, dmin, i, j - 1) + dsi_cell(cost, dmin, i - 1, j - 1)) / 2
    if name == E:  # from (i-2, j-1): cells a = (i-1, j), c = (i-1, j-1)
        return here + (dsi_cell(cost, dmin, i - 1, j) + dsi_cell(cost, dmin, i - 1, j - 1)) / 2
    raise ValueError(name)


_MOVES = {C: (1, 1), A: (1, 0), B: (0, 1), D: (1, 2), E: (2, 1)}


def enumerate_paths(cost, dmin, occ, five, box, anchor_start=False, anchor_end=False):
    """Every admissible path of the segment ``box = (x_lo, x_hi, j_lo, j_hi)`` with its cost.

    Yields ``(total, nodes, steps)``: ``nodes`` from the start (a virtual node, or the
    anchor) to the end, ``steps[n]`` the step that entered ``nodes[n + 1]``.

    Rules (the documented boundary rules of ``scanline_dp``):

    * every node ``(i, j)`` lies in the disparity band, ``dmin <= i - j <= dmin + ndisp - 1``;
    * free start: any band node with ``i == x_lo - 1`` or ``j == j_lo - 1`` and both
      ``i >= x_lo - 1``, ``j >= j_lo - 1``; anchored start: exactly ``(x_lo, j_lo)``;
    * nodes after the start lie inside the box;
    * steps that match a cell (c, d, e) need every cell they charge to be finite;
    * free end: any node with ``i == x_hi`` or ``j == j_hi``; anchored end: exactly
      ``(x_hi, j_hi)`` entered by c, d or e.
    """
    x_lo, x_hi, j_lo, j_hi = box
    ndisp = cost.shape[1]
    names = (C, A, B, D, E) if five else (C, A, B)

    def in_band(i, j):
        return dmin <= i - j <= dmin + ndisp - 1

    if anchor_start:
        starts = [(x_lo, j_lo)]
    else:
        starts = []
        for i in range(x_lo - 1, x_hi + 1):
            for j in range(j_lo - 1, j_hi + 1):
                if (i == x_lo - 1 or j == j_lo - 1) and in_band(i, j):
                    starts.append((i, j))

    def is_end(node, last_step):
        i, j = node
        if anchor_end:
            return node == (x_hi, j_hi) and last_step in (C, D, E)
        return i == x_hi or j == j_hi

    def walk(nodes, steps, total):
        i, j = nodes[-1]
        if len(nodes) > 1 and is_end(nodes[-1], steps[-1]):
            yield total, list(nodes), list(steps)
        for name in names:
            di, dj = _MOVES[name]
            ni, nj = i + di, j + dj
            if not (x_lo <= ni <= x_hi and j_lo <= nj <= j_hi and in_band(ni, nj)):
                continue
            if anchor_end and (ni, nj) == (x_hi, j_hi) and name in (A, B):
                continue
            c = step_cost(cost, dmin, occ, name, ni, nj)
            if not c < math.inf:
                continue
            nodes.append((ni, nj))
            steps.append(name)
            yield from walk(nodes, steps, total + c)
            nodes.pop()
            steps.pop()

    for start in starts:
        yield from walk([start], [], 0.0)


def best_path_cost(cost, dmin, occ, five, box, anchor_start=False, anchor_end=False):
    """The optimal cost over all admissible paths (inf when there is none)."""
    best = math.inf
    for total, _, _ in enumerate_paths(cost, dmin, occ, five, box, anchor_start, anchor_end):
        best = min(best, total)
    return best


def path_is_admissible(nodes, steps, cost, dmin, occ, five, box, anchor_start, anchor_end):
    """Return the cost of a given path under the oracle's rules, or raise AssertionError."""
    x_lo, x_hi, j_lo, j_hi = box
    ndisp = cost.shape[1]
    i0, j0 = nodes[0]
    if anchor_start:
        assert (i0, j0) == (x_lo, j_lo), f"path does not start at the anchor: {nodes[0]}"
    else:
        assert i0 == x_lo - 1 or j0 == j_lo - 1, f"bad virtual start {nodes[0]}"
        assert i0 >= x_lo - 1 and j0 >= j_lo - 1
    total = 0.0
    for (pi, pj), (ni, nj), name in zip(nodes[:-1], nodes[1:], steps, strict=True):
        assert name in ((C, A, B, D, E) if five else (C, A, B)), f"step {name} not allowed"
        assert (ni - pi, nj - pj) == _MOVES[name], f"step {name} does not move {_MOVES[name]}"
        assert x_lo <= ni <= x_hi and j_lo <= nj <= j_hi, f"node {(ni, nj)} outside the box"
        assert dmin <= ni - nj <= dmin + ndisp - 1, f"node {(ni, nj)} outside the band"
        total += step_cost(cost, dmin, occ, name, ni, nj)
    i1, j1 = nodes[-1]
    if anchor_end:
        assert (i1, j1) == (x_hi, j_hi) and steps[-1] in (C, D, E)
    else:
        assert i1 == x_hi or j1 == j_hi, f"path ends at {nodes[-1]}, not on the far edge"
    return total


def naive_block_match(column):
    """Per row of ``column`` (shape (ndisp, R)): first least index (-1: all inf) and the
    uniqueness ratio (second least over ``|k - best| > 1`` over the least; 0 without a
    match, inf over a zero least cost, 1 when both are zero)."""
    ks, ratios = [], []
    for values in column.T:
        if not np.isfinite(values).any():
            ks.append(-1)
            ratios.append(0.0)
            continue
        best_k = int(np.argmin(values))  # the first of the least
        far = [v for k, v in enumerate(values) if abs(k - best_k) > 1]
        second = min(far, default=np.inf)
        best = values[best_k]
        ratios.append(second / best if best > 0 else (np.inf if second > 0 else 1.0))
        ks.append(best_k)
    return ks, ratios

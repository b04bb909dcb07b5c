"""Slow, obviously correct twins of the ``redert`` kernels (``redert.py``).

The cost functions follow the written definition (sheared window, linear interpolation)
pixel by pixel; the DP is an exhaustive enumeration of every admissible path in the
DSI's own ``(i, j) = (x_left, x_right)`` coordinates, with explicit states, so the two
share no index arithmetic with the kernels.
"""

import math

import numpy as np

#: Path states: ("m", o) matched with orientation index o; ("l", c) / ("r", c) left /
#: right pixel occluded, the c-th pixel of its run of occlusions (c == run_cap: that one
#: or a later one); ("s",) the virtual start; ("lb",) / ("rb",) left / right pixel
#: occluded in a run that began at the virtual start (a border run).
START = ("s",)
LEFT_BORDER, RIGHT_BORDER = ("lb",), ("rb",)


def pixel_cost(left, right, y, x, e, q, radius, steps=4):
    """Sheared window SAD of left pixel ``x`` at disparity ``e / steps``, slope ``q / steps``.

    In units of ``1 / steps`` signal step: ``sum |steps L - steps R(position)|`` with the
    right image linearly interpolated at ``position = x + s - (e + q s) / steps``. Rows
    outside the image repeat the edge row (in both views); columns where either position
    leaves its image are skipped and the sum rescaled to the full window; inf when the
    centre is outside. ``steps`` 4 is quarter-pixel sampling.
    """
    height, width = left.shape
    win = 2 * radius + 1
    if not 0 <= steps * x - e <= steps * (width - 1):
        return math.inf
    total = 0
    used = 0
    for s in range(-radius, radius + 1):
        xl = x + s
        pos = steps * xl - (e + q * s)  # right position in 1/steps of a pixel
        if not (0 <= xl < width and 0 <= pos <= steps * (width - 1)):
            continue
        used += 1
        base, frac = divmod(pos, steps)
        for t in range(-radius, radius + 1):
            yy = min(max(y + t, 0), height - 1)
            sample = (steps - frac) * int(right[yy, base])
            if frac:
                sample += frac * int(right[yy, base + 1])
            total += abs(steps * int(left[yy, xl]) - sample)
    return float(total) if used == win else total * win / used


def segment(q, steps=4):
    """``(length, delta)`` of a segment of slope ``q / steps``: the pixels it spans and the
    disparity change between its end nodes (slope 0: one pixel; slope +-1/L: L pixels)."""
    if q == 0:
        return 1, 0
    slope = abs(q) / steps
    length = round(1 / slope)
    assert length * slope == 1, f"slope {q}/{steps} is not 1/L"
    return length, (1 if q > 0 else -1)


def row_costs(left, right, y, dmin, ndisp, oq, radius, steps=4):
    """``node[x, k, o]`` and ``seg[x, k, o]`` of row ``y`` as documented in the kernels."""
    width = left.shape[1]
    node = np.full((width, ndisp, len(oq)), np.inf)
    seg = np.full((width, ndisp, len(oq)), np.inf)
    for x in range(width):
        for k in range(ndisp):
            d = dmin + k
            if not 0 <= x - d < width:
                continue
            for o, q in enumerate(oq):
                node[x, k, o] = pixel_cost(left, right, y, x, steps * d, q, radius, steps)
                length, delta = segment(q, steps)
                x0, d0 = x - length, d - delta
                if not (0 <= x0 and 0 <= x0 - d0 < width and dmin <= d0 < dmin + ndisp):
                    continue
                # pixels x0 + 1 .. x on the line from (x0, d0) to (x, d)
                seg[x, k, o] = sum(
                    pixel_cost(left, right, y, p, steps * d0 + q * (p - x0), q, radius, steps)
                    for p in range(x0 + 1, x + 1)
                )
    return node, seg


def _cell(array, dmin, i, j, o):
    k = i - j - dmin
    if i < 0 or j < 0 or i >= array.shape[0] or not 0 <= k < array.shape[1]:
        return math.inf
    return array[i, k, o]


def moves(
    node_ij, state, node, seg, dmin, oq, occ, orient, slant, steps=4, discount=0.0, run_cap=1
):
    """Every move out of ``node_ij`` in ``state``: yields ``(next_node, next_state, cost)``.

    * a matched state ``o2`` is entered either by a segment of slope ``oq[o2] / steps`` from a
      matched state ``o1``: ``(i, j) -> (i + L, j + L - delta)``, cost
      ``seg + orient * (o1 != o2) + slant * (delta != 0)``; or diagonally,
      ``(i, j) -> (i + 1, j + 1)``, from an occlusion state or the start, cost ``node``;
      both need a finite cost;
    * a left occlusion ``(i, j) -> (i + 1, j)`` and a right occlusion ``(i, j) -> (i, j + 1)``
      from any state cost ``occ``, less ``discount`` for the 2nd to ``run_cap``-th pixel
      of a run (consecutive occlusions, left and right alike) that began after a match;
      a run from the start is a border run (its own states, never discounted). Without
      a discount (``run_cap == 1`` or ``discount == 0``) a run from the start uses the
      ordinary states, as the kernel does;
    * every node after the start lies inside both images and in the band
      ``dmin <= i - j < dmin + ndisp``.
    """
    width, ndisp, _ = node.shape
    i, j = node_ij

    def inside(a, b):
        return 0 <= a < width and 0 <= b < width and dmin <= a - b <= dmin + ndisp - 1

    for o2, q in enumerate(oq):
        if state[0] == "m":
            length, delta = segment(q, steps)
            ni, nj = i + length, j + length - delta
            if inside(ni, nj) and _cell(seg, dmin, ni, nj, o2) < math.inf:
                extra = (orient if state[1] != o2 else 0.0) + (slant if delta else 0.0)
                yield (ni, nj), ("m", o2), _cell(seg, dmin, ni, nj, o2) + extra
        elif inside(i + 1, j + 1) and _cell(node, dmin, i + 1, j + 1, o2) < math.inf:
            yield (i + 1, j + 1), ("m", o2), _cell(node, dmin, i + 1, j + 1, o2)
    border = run_cap > 1 and discount > 0
    if state[0] in ("l", "r"):  # the run goes on
        count = state[1] + 1
        cost = occ - discount if count <= run_cap else occ
        count = min(count, run_cap)
        left, right = ("l", count), ("r", count)
    elif state[0] == "m" or not border:  # a run begins
        left, right, cost = ("l", 1), ("r", 1), occ
    else:  # a border run begins or goes on
        left, right, cost = LEFT_BORDER, RIGHT_BORDER, occ
    if inside(i + 1, j):
        yield (i + 1, j), left, cost
    if inside(i, j + 1):
        yield (i, j + 1), right, cost


def enumerate_paths(node, seg, dmin, oq, occ, orient, slant, steps=4, discount=0.0, run_cap=1):
    """Every admissible path of one whole scanline, with its cost.

    Yields ``(total, path)``, ``path`` a list of ``((i, j), state)`` from the virtual start
    to the end: the start is any virtual node with ``i == -1`` or ``j == -1`` (both
    ``>= -1``) in the band, at no cost; the moves are those of :func:`moves`; the path ends
    at any node after the start with ``i == W - 1`` or ``j == W - 1``.
    """
    width, ndisp, _ = node.shape

    def walk(path, total):
        (i, j), state = path[-1]
        if len(path) > 1 and (i == width - 1 or j == width - 1):
            yield total, list(path)
        for nxt, nstate, c in moves(
            (i, j), state, node, seg, dmin, oq, occ, orient, slant, steps, discount, run_cap
        ):
            path.append((nxt, nstate))
            yield from walk(path, total + c)
            path.pop()

    for i in range(-1, width):
        for j in range(-1, width):
            if (i == -1 or j == -1) and dmin <= i - j <= dmin + ndisp - 1:
                yield from walk([((i, j), START)], 0.0)


def best_path_cost(node, seg, dmin, oq, occ, orient, slant, steps=4, discount=0.0, run_cap=1):
    """The optimal cost over all admissible paths (inf when there is none)."""
    paths = enumerate_paths(node, seg, dmin, oq, occ, orient, slant, steps, discount, run_cap)
    return min((t for t, _ in paths), default=math.inf)


def path_cost(path, node, seg, dmin, oq, occ, orient, slant, steps=4, discount=0.0, run_cap=1):
    """Cost of a given path under the oracle's rules, or raise AssertionError."""
    width = node.shape[0]
    (i, j), state = path[0]
    assert state == START and (i == -1 or j == -1), f"bad start {path[0]}"
    total = 0.0
    for (prev, prev_state), (cur, cur_state) in zip(path[:-1], path[1:], strict=True):
        options = {
            (n, s): c
            for n, s, c in moves(
                prev, prev_state, node, seg, dmin, oq, occ, orient, slant, steps, discount, run_cap
            )
        }
        assert (cur, cur_state) in options, f"inadmissible step {prev} {prev_state} -> {cur}"
        total += options[(cur, cur_state)]
    i, j = path[-1][0]
    assert len(path) > 1 and (i == width - 1 or j == width - 1), f"bad end {path[-1]}"
    return total

"""Slow, obviously correct twin of the MGM paths (``kernels.mgm``)."""

import numpy as np


def message(prev_vector, p1, p2):
    """min over d' of L(q, d') + V(d, d'), minus min L(q): one predecessor's message."""
    ndisp = prev_vector.size
    low = prev_vector.min()
    out = np.empty(ndisp, dtype=np.int64)
    for d in range(ndisp):
        best = low + p2
        for e in range(ndisp):
            step = abs(d - e)
            penalty = 0 if step == 0 else (p1 if step == 1 else p2)
            best = min(best, prev_vector[e] + penalty)
        out[d] = best - low
    return out


def path(cost, luma, predecessors, order, p1, table, ndisp):
    """``L`` of one path: ``predecessors(y, x)`` lists its in-image predecessors."""
    height, width = luma.shape
    values = {}
    for y, x in order:
        messages = [
            message(values[q], p1, table[abs(int(luma[y, x]) - int(luma[q]))])
            for q in predecessors(y, x)
        ]
        own = cost[y, x, :ndisp].astype(np.int64)
        if len(messages) == 1:
            own = own + messages[0]
        elif len(messages) == 2:
            own = own + ((messages[0] + messages[1]) >> 1)
        values[(y, x)] = own
    return values


def mgm_sums(cost, luma, p1, table, diagonals, ndisp):
    """``(down, up)``: the sums of the paths from above and from below, ``(H, W, ndisp)``."""
    height, width = luma.shape
    inside = lambda y, x: 0 <= y < height and 0 <= x < width  # noqa: E731
    out = []
    for sy in (1, -1):
        rows = range(height) if sy > 0 else range(height - 1, -1, -1)
        total = np.zeros((height, width, ndisp), dtype=np.int64)
        kinds = (1, -1, 0) if diagonals else (1, -1)
        for kind in kinds:
            if kind == 0:
                cols = range(width)
                pred = lambda y, x, sy=sy: [  # noqa: E731
                    q for q in ((y - sy, x - 1), (y - sy, x + 1)) if inside(*q)
                ]
            else:
                cols = range(width) if kind > 0 else range(width - 1, -1, -1)
                pred = lambda y, x, sy=sy, sx=kind: [  # noqa: E731
                    q for q in ((y, x - sx), (y - sy, x)) if inside(*q)
                ]
            order = [(y, x) for y in rows for x in cols]
            for (y, x), value in path(cost, luma, pred, order, p1, table, ndisp).items():
                total[y, x] += value
        out.append(total)
    return out

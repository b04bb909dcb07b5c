"""The slow twin of ``dcstereo.refine.local_planes``: each pixel's plane by least squares."""

import numpy as np

from dcstereo.refine._local_planes import RIDGE


def local_planes(disparity, guide, moved, radius, tolerance, colour_scale, space_weight):
    """Each moved pixel's value of its window's weighted plane, one pixel at a time.

    ``guide`` ``(C, H, W)`` levels 0..255; ``space_weight`` the ``(2r+1, 2r+1)`` table of the
    distance. A window sample with an estimate within ``tolerance`` of the pixel's weighs
    ``exp(-g / colour_scale) * space_weight[dy + r, dx + r]``, ``g`` the largest channel
    difference; the plane ``d - d_pixel = a dx + b dy + c`` minimises the weighted squares
    plus ``RIDGE * sum(w) * (a**2 + b**2)`` (numpy's least squares on the weighted rows,
    the ridge as two more rows); the pixel takes ``d_pixel + c``.
    """
    height, width = disparity.shape
    out = disparity.astype(np.float64).copy()
    for y in range(height):
        for x in range(width):
            if not moved[y, x]:
                continue
            rows, values, weights = [], [], []
            for dy in range(-radius, radius + 1):
                for dx in range(-radius, radius + 1):
                    yy, xx = y + dy, x + dx
                    if not (0 <= yy < height and 0 <= xx < width):
                        continue
                    r = float(disparity[yy, xx]) - float(disparity[y, x])
                    if not abs(r) <= tolerance:
                        continue
                    g = max(
                        abs(int(guide[c, yy, xx]) - int(guide[c, y, x]))
                        for c in range(guide.shape[0])
                    )
                    w = np.exp(-g / colour_scale) * float(space_weight[dy + radius, dx + radius])
                    rows.append((dx, dy, 1.0))
                    values.append(r)
                    weights.append(w)
            if not weights:
                continue
            root = np.sqrt(np.array(weights))
            a = np.array(rows) * root[:, None]
            b = np.array(values) * root
            ridge = np.sqrt(RIDGE * sum(weights))
            a = np.vstack([a, [[ridge, 0.0, 0.0], [0.0, ridge, 0.0]]])
            b = np.concatenate([b, [0.0, 0.0]])
            out[y, x] = float(disparity[y, x]) + np.linalg.lstsq(a, b, rcond=None)[0][2]
    return out

"""Slow, obviously correct twins of the kernels of ``dcstereo.refine._planes``.

Plain Python loops over plain lists: SLIC with a seed grid and the 3 x 3 cells' search,
RANSAC with the same 31-bit generator, the least-squares refit by ``numpy.linalg.lstsq``,
the replacement rule. The kernels must agree with them (tests/test_planes.py).
"""

import numpy as np

LCG_A, LCG_C, LCG_M = 1103515245, 12345, 2147483648


def grid_shape(height, width, step):
    return max(1, int(round(height / step))), max(1, int(round(width / step)))


def slic(colour, step, compactness, iterations):
    colour = np.asarray(colour, dtype=np.float64)
    channels, height, width = colour.shape
    ny, nx = grid_shape(height, width, step)
    centres = []
    for j in range(ny):
        for i in range(nx):
            y = min(height - 1, int((j + 0.5) * height / ny))
            x = min(width - 1, int((i + 0.5) * width / nx))
            centres.append([float(y), float(x)] + [float(v) for v in colour[:, y, x]])
    weight = (compactness / step) ** 2
    labels = np.zeros((height, width), dtype=np.int32)
    for it in range(iterations + 1):
        for y in range(height):
            gy = min(ny - 1, (y * ny) // height)
            for x in range(width):
                gx = min(nx - 1, (x * nx) // width)
                best, best_label = np.inf, gy * nx + gx
                for j in range(max(0, gy - 1), min(ny, gy + 2)):
                    for i in range(max(0, gx - 1), min(nx, gx + 2)):
                        k = j * nx + i
                        c = centres[k]
                        dist = weight * ((y - c[0]) ** 2 + (x - c[1]) ** 2)
                        dist += sum((colour[ch, y, x] - c[2 + ch]) ** 2 for ch in range(channels))
                        if dist < best:
                            best, best_label = dist, k
                labels[y, x] = best_label
        if it == iterations:
            break
        for k in range(ny * nx):
            ys, xs = np.nonzero(labels == k)
            if len(ys):
                means = [colour[ch][ys, xs].mean() for ch in range(channels)]
                centres[k] = [ys.mean(), xs.mean()] + means
    return labels


def fit_segment(xs, ys, ds, iterations, inlier, stop, seed, max_scored=2**30):
    """(plane (a, b, c), inlier count) as the kernel's: RANSAC, then least squares."""
    n = len(xs)
    if n < 3:
        return None, 0
    stride = max(1, n // max_scored)
    scored = list(range(0, n, stride))
    state = (seed * 7919 + 1) % LCG_M
    best, best_count = None, -1
    for _ in range(iterations):
        draws = []
        for _k in range(3):
            state = (state * LCG_A + LCG_C) % LCG_M
            draws.append((state >> 8) % n)
        i, j, k = draws
        if len({i, j, k}) < 3:
            continue
        x1, y1, d1 = xs[j] - xs[i], ys[j] - ys[i], ds[j] - ds[i]
        x2, y2, d2 = xs[k] - xs[i], ys[k] - ys[i], ds[k] - ds[i]
        det = x1 * y2 - x2 * y1
        if abs(det) < 0.5:
            continue
        a = (d1 * y2 - d2 * y1) / det
        b = (x1 * d2 - x2 * d1) / det
        plane = (a, b, ds[i] - a * xs[i] - b * ys[i])
        count = sum(
            abs(plane[0] * xs[p] + plane[1] * ys[p] + plane[2] - ds[p]) <= inlier for p in scored
        )
        if count > best_count:
            best, best_count = plane, count
            if count >= stop * len(scored):
                break
    if best_count < 3:
        return None, 0
    near = [
        abs(best[0] * x + best[1] * y + best[2] - d) <= inlier
        for x, y, d in zip(xs, ys, ds, strict=True)
    ]
    px = np.array([x for x, m in zip(xs, near, strict=True) if m])
    py = np.array([y for y, m in zip(ys, near, strict=True) if m])
    pd = np.array([d for d, m in zip(ds, near, strict=True) if m])
    refined = best
    if len(px) >= 3:
        a_matrix = np.column_stack([px - px.mean(), py - py.mean()])
        if np.linalg.matrix_rank(a_matrix) == 2:
            (a, b), *_ = np.linalg.lstsq(a_matrix, pd - pd.mean(), rcond=None)
            refined = (a, b, pd.mean() - a * px.mean() - b * py.mean())
    count = sum(
        abs(refined[0] * x + refined[1] * y + refined[2] - d) <= inlier
        for x, y, d in zip(xs, ys, ds, strict=True)
    )
    return refined, count


def fit_planes(disparity, usable, labels, n, iterations, inlier, stop, max_scored=2**30,
               wanted=None, min_support=0.0, lattice=1):  # fmt: skip
    """Per label: (plane or None, used, inliers, size); pixels taken in raster order.

    A label none of whose pixels is ``wanted``, or whose estimates are under three or under
    ``min_support`` of its pixels, is not fitted: (None, used, 0, size). Only the pixels of
    every ``lattice``-th row and column count (but any wanted pixel makes a label wanted).
    """
    out = []
    for k in range(n):
        all_ys, all_xs = np.nonzero(labels == k)  # raster order, as the kernel's counting sort
        needed = wanted is None or bool(wanted[all_ys, all_xs].any())
        on = (all_ys % lattice == 0) & (all_xs % lattice == 0)
        ys, xs = all_ys[on], all_xs[on]
        keep = usable[ys, xs]
        sx, sy = xs[keep].astype(float), ys[keep].astype(float)
        sd = disparity[ys[keep], xs[keep]].astype(float)
        if not needed or len(sx) < 3 or len(sx) < min_support * len(ys):
            out.append((None, len(sx), 0, len(ys)))
            continue
        plane, count = fit_segment(
            list(sx), list(sy), list(sd), iterations, inlier, stop, k, max_scored
        )
        out.append((plane, len(sx), count, len(ys)))
    return out


def apply_planes(disparity, replaceable, labels, planes, trusted, outlier, low, high):
    out = disparity.copy()
    for y in range(disparity.shape[0]):
        for x in range(disparity.shape[1]):
            k = labels[y, x]
            if not trusted[k] or not replaceable[y, x]:
                continue
            a, b, c = planes[k]
            value = a * x + b * y + c
            d = disparity[y, x]
            if np.isnan(d) or abs(d - value) > outlier:
                out[y, x] = min(high, max(low, value))
    return out


def refine(
    disparity,
    kept,
    colour,
    margin,
    steps,
    *,
    compactness,
    slic_iterations,
    iterations,
    inlier,
    stop,
    min_support,
    min_ratio,
    outlier,
    fit_margin,
    replace_margin,
    low,
    high,
    max_scored=2**30,
    lattice=1,
):
    """``dcstereo.refine.planes.refine_planes``'s passes from the functions above: the new map.

    The superpixels on the image itself (``slic_scale`` 1).
    """
    out = disparity.astype(np.float32)
    height, width = out.shape
    for step in steps:
        labels = slic(colour, step, compactness, slic_iterations)
        ny, nx = grid_shape(height, width, step)
        holes = np.isnan(out)
        usable = (margin >= fit_margin) & ~holes
        replaceable = ~kept & (holes | (margin < replace_margin))
        fits = fit_planes(out, usable, labels, ny * nx, iterations, inlier, stop, max_scored,
                          wanted=replaceable, min_support=min_support,
                          lattice=lattice)  # fmt: skip
        planes = [p if p is not None else (0.0, 0.0, 0.0) for p, *_ in fits]
        trusted = [
            p is not None
            and used >= 3
            and used >= min_support * size
            and count >= min_ratio * max(used, 1)
            for p, used, count, size in fits
        ]
        out = apply_planes(out, replaceable, labels, planes, trusted, outlier, low, high)
    return out

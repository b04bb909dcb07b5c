"""Slow, obviously correct twins of the guided cost filter and the sparse census."""

import numpy as np


def box_mean(image, radius):
    """Mean over the clipped ``(2r + 1)^2`` square of each pixel, by explicit slicing."""
    height, width = image.shape[:2]
    out = np.empty(image.shape, dtype=np.float64)
    for y in range(height):
        for x in range(width):
            window = image[max(0, y - radius) : y + radius + 1, max(0, x - radius) : x + radius + 1]
            out[y, x] = window.reshape((-1,) + image.shape[2:]).mean(axis=0)
    return out


def guided_filter(volume, guide, ndisp, radius, eps):
    """He et al.'s gray-guide filter of each slice ``k < ndisp``, rounded, clipped at 0."""
    out = volume.copy()
    mean_i = box_mean(guide, radius)
    var_i = box_mean(guide * guide, radius) - mean_i**2
    for k in range(ndisp):
        p = volume[:, :, k].astype(np.float64)
        mean_p = box_mean(p, radius)
        a = (box_mean(guide * p, radius) - mean_i * mean_p) / (var_i + eps)
        b = mean_p - a * mean_i
        q = box_mean(a, radius) * guide + box_mean(b, radius)
        out[:, :, k] = np.floor(np.maximum(q, 0.0) + 0.5).astype(np.int16)
    return out


def sparse_census(signal, rows, cols, step):
    """Census codes over samples ``step`` apart, edges repeated (raster order, centre out)."""
    height, width = signal.shape
    out = np.zeros((height, width), dtype=np.uint64)
    for y in range(height):
        for x in range(width):
            code = 0
            for i in range(-(rows // 2), rows // 2 + 1):
                for j in range(-(cols // 2), cols // 2 + 1):
                    if i == 0 and j == 0:
                        continue
                    yy = min(max(y + step * i, 0), height - 1)
                    xx = min(max(x + step * j, 0), width - 1)
                    code = code * 2 + int(signal[yy, xx] < signal[y, x])
            out[y, x] = code
    return out

"""The guided filter of a cost volume, each disparity's slice guided by the left intensity.

He, Sun and Tang, *Guided image filtering*, ECCV 2010 (gray guide, eqs. 3-8); applied to
the slices of a stereo cost volume by Rhemann et al., *Fast cost-volume filtering for
visual correspondence and beyond*, CVPR 2011. For a guide ``I`` and a slice ``p``, with
``mean`` the average over the ``(2r + 1)^2`` square (clipped at the image's edges: the mean
of the pixels inside)::

    a = (mean(I p) - mean(I) mean(p)) / (var(I) + eps)
    b = mean(p) - a mean(I)
    q = mean(a) I + mean(b)

``q`` is written back to the int16 volume rounded to the nearest integer and clipped at 0.
Volumes are ``(H, W, Dp)`` int16 as the ``sgm`` kernels hold them; only the lanes
``k < ndisp`` change. All sums in float64 (exact for the sizes ``sgm`` runs); the box is
made by running sums along each row, then by running sums down the columns.
"""

import numba as nb
import numpy as np


@nb.njit(cache=True, parallel=True)
def _box_rows(src, radius, out):
    """``out[y, x, k]``: the sum of ``src[y, x - r .. x + r, k]`` (clipped), rows in parallel."""
    height, width, depth = src.shape
    for y in nb.prange(height):
        total = np.zeros(depth, dtype=np.float64)
        for x in range(min(radius, width - 1) + 1):
            for k in range(depth):
                total[k] += src[y, x, k]
        for x in range(width):
            dst = out[y, x]
            for k in range(depth):
                dst[k] = total[k]
            add = x + radius + 1
            drop = x - radius
            if add < width:
                for k in range(depth):
                    total[k] += src[y, add, k]
            if drop >= 0:
                for k in range(depth):
                    total[k] -= src[y, drop, k]


@nb.njit(cache=True)
def _box_columns(src, radius, out):
    """``out[y, x, k]``: the sum of ``src[y - r .. y + r, x, k]`` (clipped), serially."""
    height, width, depth = src.shape
    total = np.zeros((width, depth), dtype=np.float64)
    for y in range(min(radius, height - 1) + 1):
        total += src[y]
    for y in range(height):
        out[y] = total
        add = y + radius + 1
        drop = y - radius
        if add < height:
            total += src[add]
        if drop >= 0:
            total -= src[drop]


@nb.njit(cache=True)
def box_mean(src, radius, count, scratch, out):
    """Write the mean over the ``(2r + 1)^2`` square of each ``(y, x)``: ``(H, W, K)`` float64.

    ``count`` ``(H, W)`` holds the number of pixels of each clipped square.
    """
    _box_rows(src, radius, scratch)
    _box_columns(scratch, radius, out)
    height, width, depth = src.shape
    for y in range(height):
        for x in range(width):
            scale = 1.0 / count[y, x]
            for k in range(depth):
                out[y, x, k] *= scale


@nb.njit(cache=True, parallel=True)
def _products(volume, guide, ndisp, p, ip):
    """``p = volume[..., :ndisp]`` and ``ip = guide * p`` as float64, rows in parallel."""
    height, width = guide.shape
    for y in nb.prange(height):
        for x in range(width):
            g = guide[y, x]
            for k in range(ndisp):
                value = np.float64(volume[y, x, k])
                p[y, x, k] = value
                ip[y, x, k] = g * value


@nb.njit(cache=True, parallel=True)
def _coefficients(mean_p, mean_ip, mean_i, var_i, eps, a, b):
    """Write ``a`` and ``b`` of the filter (``a`` into ``mean_ip``'s place is allowed)."""
    height, width, depth = mean_p.shape
    for y in nb.prange(height):
        for x in range(width):
            mi = mean_i[y, x, 0]
            den = var_i[y, x] + eps
            for k in range(depth):
                slope = (mean_ip[y, x, k] - mi * mean_p[y, x, k]) / den
                a[y, x, k] = slope
                b[y, x, k] = mean_p[y, x, k] - slope * mi


@nb.njit(cache=True, parallel=True)
def _output(mean_a, mean_b, guide, ndisp, volume):
    """``volume[..., :ndisp] = round(max(0, mean_a * I + mean_b))``, rows in parallel."""
    height, width = guide.shape
    for y in nb.prange(height):
        for x in range(width):
            g = guide[y, x]
            for k in range(ndisp):
                value = mean_a[y, x, k] * g + mean_b[y, x, k]
                volume[y, x, k] = np.int16(np.floor(max(0.0, value) + 0.5))


@nb.njit(cache=True)
def guided_filter(volume, guide, ndisp, radius, eps):
    """Filter the lanes ``k < ndisp`` of ``volume`` (``(H, W, Dp)`` int16) in place.

    ``guide``: ``(H, W)`` float64 intensity; ``eps`` in the guide's units squared.
    """
    height, width = guide.shape
    count = np.empty((height, width), dtype=np.float64)
    ones = np.ones((height, width, 1), dtype=np.float64)
    one_scratch = np.empty((height, width, 1), dtype=np.float64)
    one_out = np.empty((height, width, 1), dtype=np.float64)
    _box_rows(ones, radius, one_scratch)
    _box_columns(one_scratch, radius, one_out)
    for y in range(height):
        for x in range(width):
            count[y, x] = one_out[y, x, 0]
    g = guide.reshape(height, width, 1).copy()
    mean_i = np.empty((height, width, 1), dtype=np.float64)
    mean_ii = np.empty((height, width, 1), dtype=np.float64)
    box_mean(g, radius, count, one_scratch, mean_i)
    box_mean(g * g, radius, count, one_scratch, mean_ii)
    var_i = np.empty((height, width), dtype=np.float64)
    for y in range(height):
        for x in range(width):
            var_i[y, x] = mean_ii[y, x, 0] - mean_i[y, x, 0] * mean_i[y, x, 0]
    p = np.empty((height, width, ndisp), dtype=np.float64)
    ip = np.empty((height, width, ndisp), dtype=np.float64)
    scratch = np.empty((height, width, ndisp), dtype=np.float64)
    _products(volume, guide, ndisp, p, ip)
    box_mean(p, radius, count, scratch, p)  # mean_p (the rows' sums are in scratch first)
    box_mean(ip, radius, count, scratch, ip)  # mean_ip
    _coefficients(p, ip, mean_i, var_i, eps, ip, p)  # a into ip, b into p
    box_mean(ip, radius, count, scratch, ip)
    box_mean(p, radius, count, scratch, p)
    _output(ip, p, guide, ndisp, volume)

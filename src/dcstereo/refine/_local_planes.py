"""The kernel of the local planes (:mod:`dcstereo.refine.local_planes`).

For each pixel, the weighted sums of its window's estimates within ``tolerance`` of its
own: their offsets, their offsets' squares and products, and their differences from the
pixel's estimate times 1 and the offsets, in a fixed order (the window's rows, each summed
over its columns first in float32, their totals in float64); then the plane through them
by weighted least squares (the slopes lightly regularised), evaluated at the pixel.
"""

import numba as nb
import numpy as np

#: The slopes' regularisation, per unit of weight: keeps the fit defined where the
#: window's estimates lie on a line, and leaves it the weighted mean where they are one.
RIDGE = 1e-3


@nb.njit(cache=True, parallel=True)
def local_plane_rows(disparity, guide, moved, radius, tolerance, colour_powers, space_weight,
                     out):  # fmt: skip
    """Write into ``out`` the local plane's value at each moved pixel (the others copied).

    ``disparity`` float32 ``(H, W)`` (NaN: no estimate), ``guide`` ``(3, H, W)`` levels
    0..255, ``moved`` bool ``(H, W)``; a window sample counts when it has an estimate within
    ``tolerance`` of the pixel's, weighing ``exp(-g / colour_scale) * space_weight[dy +
    radius, dx + radius]``, ``g`` (0..255) the largest channel difference to the pixel's
    colour; ``colour_powers[b]`` is ``exp(-2**b / colour_scale)`` (b 0..7), whose product
    over ``g``'s bits is the colour factor.

    Rows in parallel. For each row of the window, the sums over its columns first (of
    ``w``, ``w dx``, ``w dx**2``, ``w r``, ``w r dx``, ``r`` the difference from the pixel's
    estimate), over slices that start at the first column inside the image (vector code),
    then the row's share of the nine sums of :func:`plane_offset`.
    """
    height, width = disparity.shape
    one, zero, tol = np.float32(1.0), np.float32(0.0), np.float32(tolerance)
    e0, e1, e2, e3 = colour_powers[0], colour_powers[1], colour_powers[2], colour_powers[3]
    e4, e5, e6, e7 = colour_powers[4], colour_powers[5], colour_powers[6], colour_powers[7]
    for y in nb.prange(height):
        sums = np.zeros((9, width))  # w, w dx, w dy, w dx2, w dx dy, w dy2, w r, w r dx, w r dy
        # one window row's sums: w, w dx, w dx2, w r, w r dx (1-D arrays: their slices
        # stay contiguous for the compiler, which makes vector code of them)
        p0, p1 = np.zeros(width, dtype=np.float32), np.zeros(width, dtype=np.float32)
        p2 = np.zeros(width, dtype=np.float32)
        p3, p4 = np.zeros(width, dtype=np.float32), np.zeros(width, dtype=np.float32)
        for dy in range(-radius, radius + 1):
            yy = y + dy
            if yy < 0 or yy >= height:
                continue
            p0[:], p1[:], p2[:], p3[:], p4[:] = 0, 0, 0, 0, 0
            for dx in range(-radius, radius + 1):
                space = np.float32(space_weight[dy + radius, dx + radius])
                fx = np.float32(dx)
                fxx = fx * fx
                a, b = max(0, -dx), min(width, width - dx)  # the pixels, their samples + dx
                row, centre = disparity[yy, a + dx : b + dx], disparity[y, a:b]
                g0, g1, g2 = (
                    guide[0, yy, a + dx : b + dx],
                    guide[1, yy, a + dx : b + dx],
                    guide[2, yy, a + dx : b + dx],
                )
                c0, c1, c2 = guide[0, y, a:b], guide[1, y, a:b], guide[2, y, a:b]
                w_sum, wx_sum, wxx_sum, wr_sum, wrx_sum = (
                    p0[a:b],
                    p1[a:b],
                    p2[a:b],
                    p3[a:b],
                    p4[a:b],
                )
                for i in range(b - a):  # branch-free, written out here: vector code
                    r = row[i] - centre[i]
                    near = abs(r) <= tol  # NaN on either side: False
                    g = max(
                        abs(np.int32(g0[i]) - np.int32(c0[i])),
                        abs(np.int32(g1[i]) - np.int32(c1[i])),
                        abs(np.int32(g2[i]) - np.int32(c2[i])),
                    )
                    # exp(-g / colour_scale) as the product of its powers of two (a table
                    # lookup would be a gather, which the compiler leaves scalar)
                    w = (
                        space
                        * (e0 if g & 1 else one) * (e1 if g & 2 else one)
                        * (e2 if g & 4 else one) * (e3 if g & 8 else one)
                        * (e4 if g & 16 else one) * (e5 if g & 32 else one)
                        * (e6 if g & 64 else one) * (e7 if g & 128 else one)
                    )  # fmt: skip
                    w = w if near else zero
                    wr = w * r if near else zero
                    w_sum[i] += w
                    wx_sum[i] += fx * w
                    wxx_sum[i] += fxx * w
                    wr_sum[i] += wr
                    wrx_sum[i] += fx * wr
            fy = np.float64(dy)
            for x in range(width):
                w, wx, wxx = np.float64(p0[x]), np.float64(p1[x]), np.float64(p2[x])
                wr, wrx = np.float64(p3[x]), np.float64(p4[x])
                sums[0, x] += w
                sums[1, x] += wx
                sums[2, x] += fy * w
                sums[3, x] += wxx
                sums[4, x] += fy * wx
                sums[5, x] += fy * fy * w
                sums[6, x] += wr
                sums[7, x] += wrx
                sums[8, x] += fy * wr
        centre = disparity[y]
        for x in range(width):
            out[y, x] = centre[x]
            if moved[y, x] and sums[0, x] > 0:
                offset = plane_offset(
                    sums[0, x], sums[1, x], sums[2, x], sums[3, x], sums[4, x], sums[5, x],
                    sums[6, x], sums[7, x], sums[8, x],
                )  # fmt: skip
                out[y, x] = np.float32(np.float64(centre[x]) + offset)


@nb.njit(cache=True)
def plane_offset(s0, sx, sy, sxx, sxy, syy, sr, sxr, syr):
    """Return the value at offset 0 of the weighted least-squares plane of the sums.

    ``r = a dx + b dy + c`` fitted to the samples whose weighted sums are given (``s0``:
    the weights; ``sx``: of ``w dx``; ... ``syr``: of ``w dy r``); the slopes' normal
    equations about the weighted mean offset, with :data:`RIDGE` ``* s0`` added to their
    diagonal, then ``c`` = the mean of ``r`` less the slopes times the mean offsets.
    """
    mx, my, mr = sx / s0, sy / s0, sr / s0
    cxx = sxx - sx * mx + RIDGE * s0
    cyy = syy - sy * my + RIDGE * s0
    cxy = sxy - sx * my
    cxr = sxr - sx * mr
    cyr = syr - sy * mr
    det = cxx * cyy - cxy * cxy
    a = (cyy * cxr - cxy * cyr) / det
    b = (cxx * cyr - cxy * cxr) / det
    return mr - a * mx - b * my

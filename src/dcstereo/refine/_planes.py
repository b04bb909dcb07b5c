"""Kernels of :mod:`dcstereo.refine.planes`: superpixels of the left image, a plane per segment.

* :func:`slic`: SLIC superpixels (Achanta et al. 2012) on a regular grid of seeds, each
  pixel assigned to the nearest of the seeds of its own grid cell and the eight around it
  (colour distance plus ``compactness``-weighted distance in the image), the seeds moved to
  their pixels' means, ``iterations`` times. Labels are grid cells: ``gy * nx + gx``.
* :func:`fit_planes`: per segment, RANSAC over the segment's estimates (a plane
  ``d = a x + b y + c`` through three of them, the one with most estimates within
  ``inlier`` pixels of it), then a least-squares fit to those inliers. The random draws
  come from a 31-bit linear congruential generator seeded by the segment's label, so the
  result does not depend on threads or on a global state.
* :func:`apply_planes`: the pixels of a segment with a trusted plane that have no
  estimate, or one farther than ``outlier`` from the plane, take the plane's value.
"""

import numba as nb
import numpy as np

from dcstereo._vector.sgm import next_task

#: The generator's multiplier, increment and modulus (glibc's ``rand``).
LCG_A = 1103515245
LCG_C = 12345
LCG_M = 2147483648


@nb.njit(cache=True)
def lcg_next(state):
    """Return the generator's next state (all below 2**31: no overflow in int64)."""
    return (state * LCG_A + LCG_C) % LCG_M


@nb.njit(cache=True)
def grid_shape(height, width, step):
    """Rows and columns of the seed grid: about one seed per ``step x step`` pixels."""
    ny = max(1, int(round(height / step)))
    nx = max(1, int(round(width / step)))
    return ny, nx


@nb.njit(cache=True)
def cell_starts(size, cells):
    """First pixel of each of ``cells`` grid cells along ``size`` pixels, and ``size``.

    Pixel ``x`` lies in cell ``(x * cells) // size``, so cell ``i`` starts at
    ``ceil(i * size / cells)``.
    """
    starts = np.empty(cells + 1, dtype=np.int64)
    for i in range(cells + 1):
        starts[i] = (i * size + cells - 1) // cells
    return starts


@nb.njit(cache=True)
def _assign_row(colour, y, centres, ny, nx, weight, xstarts, best, dist, labels):
    """Label row ``y``: the nearest seed of the 3 x 3 grid cells around the pixel's own.

    Seed by seed (ascending label, as a pixel's 3 x 3 search goes), over the run of pixels
    whose cells are next to the seed's: the same distances in the same order, in loops
    over contiguous pixels. ``best``, ``dist``: ``(W,)`` float64 scratch (the caller's,
    reused row after row).
    """
    channels, height, width = colour.shape
    gy = min(ny - 1, (y * ny) // height)
    best[:] = np.inf
    row = labels[y]
    for i in range(nx):
        for x in range(xstarts[i], xstarts[i + 1]):
            row[x] = gy * nx + i
    for j in range(max(0, gy - 1), min(ny, gy + 2)):
        for i in range(nx):
            k = j * nx + i
            x0, x1 = xstarts[max(0, i - 1)], xstarts[min(nx, i + 2)]
            run = x1 - x0
            dy = y - centres[k, 0]
            cx = centres[k, 1]
            least = best[x0:x1]
            chosen = row[x0:x1]
            if channels == 3 or channels == 1:  # one loop: the distance and the choice
                mean0 = centres[k, 2]
                mean1 = centres[k, 3] if channels == 3 else 0.0
                mean2 = centres[k, 4] if channels == 3 else 0.0
                first = colour[0, y, x0:x1]
                second = colour[channels // 2, y, x0:x1]  # unread for one channel
                third = colour[channels - 1, y, x0:x1]
                for t in range(run):
                    dx = (x0 + t) - cx
                    value = weight * (dy * dy + dx * dx)
                    dc = first[t] - mean0
                    value += dc * dc
                    if channels == 3:
                        dc = second[t] - mean1
                        value += dc * dc
                        dc = third[t] - mean2
                        value += dc * dc
                    low = least[t]
                    closer = value < low  # branch-free, so that it runs in vector lanes
                    least[t] = value if closer else low
                    chosen[t] = k if closer else chosen[t]
                continue
            near = dist[x0:x1]
            for t in range(run):
                dx = (x0 + t) - cx
                near[t] = weight * (dy * dy + dx * dx)
            for c in range(channels):
                mean = centres[k, 2 + c]
                values = colour[c, y, x0:x1]
                for t in range(run):
                    dc = values[t] - mean
                    near[t] += dc * dc
            for t in range(run):
                value, low = near[t], least[t]
                closer = value < low
                least[t] = value if closer else low
                chosen[t] = k if closer else chosen[t]


@nb.njit(cache=True)
def _move_centres(colour, labels, sums, centres):
    """Move each seed to the mean position and colour of its pixels (``labels``).

    ``sums``: ``(n, 3 + C)`` scratch. Each row is taken run by run (pixels of one label
    in a row): the colours are added in raster order as one pixel at a time would (the same
    sums, to the bit) but in registers, not through ``sums`` in memory each pixel; a run's
    rows and columns are integers, their sums exact in any order.
    """
    channels, height, width = colour.shape
    n = centres.shape[0]
    sums[:] = 0.0
    for y in range(height):
        row = labels[y]
        x0 = 0
        while x0 < width:
            k = row[x0]
            x1 = x0 + 1
            while x1 < width and row[x1] == k:
                x1 += 1
            run = x1 - x0
            sums[k, 0] += y * run
            sums[k, 1] += (x0 + x1 - 1) * run // 2
            if channels == 3:  # three independent chains of additions, side by side
                first, second, third = colour[0, y], colour[1, y], colour[2, y]
                t0, t1, t2 = sums[k, 2], sums[k, 3], sums[k, 4]
                for x in range(x0, x1):
                    t0 += first[x]
                    t1 += second[x]
                    t2 += third[x]
                sums[k, 2], sums[k, 3], sums[k, 4] = t0, t1, t2
            else:
                for c in range(channels):
                    total = sums[k, 2 + c]
                    values = colour[c, y]
                    for x in range(x0, x1):
                        total += values[x]
                    sums[k, 2 + c] = total
            sums[k, 2 + channels] += run
            x0 = x1
    for k in range(n):
        count = sums[k, 2 + channels]
        if count > 0:
            for f in range(2 + channels):
                centres[k, f] = sums[k, f] / count


@nb.njit(cache=True, parallel=True)
def slic(colour, step, compactness, iterations, labels, threads=1):
    """SLIC superpixels of ``colour`` (``(C, H, W)``) into ``labels`` (``(H, W)`` int32).

    Seeds on a grid of about ``step`` pixels (:func:`grid_shape`) at their cells' centres;
    ``compactness``: the colour distance (gray levels) worth ``step`` pixels of distance.
    Returns the number of labels (``ny * nx``); a seed left without pixels keeps its place.
    ``threads``: numba's thread count; the rows are handed out one at a time to whichever
    thread is free.
    """
    channels, height, width = colour.shape
    ny, nx = grid_shape(height, width, step)
    n = ny * nx
    centres = np.empty((n, 2 + channels), dtype=np.float64)
    for j in range(ny):
        for i in range(nx):
            k = j * nx + i
            y = min(height - 1, int((j + 0.5) * height / ny))
            x = min(width - 1, int((i + 0.5) * width / nx))
            centres[k, 0] = y
            centres[k, 1] = x
            for c in range(channels):
                centres[k, 2 + c] = colour[c, y, x]
    weight = (compactness / step) ** 2
    xstarts = cell_starts(width, nx)
    sums = np.empty((n, 3 + channels), dtype=np.float64)
    # the rows handed out one at a time to whichever thread is free, one scratch a thread
    tasks = max(1, min(threads, height))
    counter = np.zeros(1, dtype=np.int64)
    for it in range(iterations + 1):
        counter[0] = 0
        for _ in nb.prange(tasks):
            best = np.empty(width)
            dist = np.empty(width)
            y = next_task(counter)
            while y < height:
                _assign_row(colour, y, centres, ny, nx, weight, xstarts, best, dist, labels)
                y = next_task(counter)
        if it == iterations:
            break
        _move_centres(colour, labels, sums, centres)
    return n


@nb.njit(cache=True)
def _plane_through(xs, ys, ds, i, j, k, out):
    """Write the plane through points ``i, j, k`` into ``out``; False if degenerate."""
    x1, y1, d1 = xs[j] - xs[i], ys[j] - ys[i], ds[j] - ds[i]
    x2, y2, d2 = xs[k] - xs[i], ys[k] - ys[i], ds[k] - ds[i]
    det = x1 * y2 - x2 * y1
    if abs(det) < 0.5:  # (nearly) collinear: twice the triangle's area under half a pixel
        return False
    a = (d1 * y2 - d2 * y1) / det
    b = (x1 * d2 - x2 * d1) / det
    out[0] = a
    out[1] = b
    out[2] = ds[i] - a * xs[i] - b * ys[i]
    return True


@nb.njit(cache=True)
def _least_squares(xs, ys, ds, plane, inlier, out):
    """Least-squares plane of the points within ``inlier`` of ``plane``; returns their count.

    Coordinates centred on the inliers' mean; ``out`` keeps ``plane`` if the system is
    singular (fewer than three non-collinear inliers).
    """
    n = xs.shape[0]
    count = 0
    mx = my = md = 0.0
    for p in range(n):
        if abs(plane[0] * xs[p] + plane[1] * ys[p] + plane[2] - ds[p]) <= inlier:
            count += 1
            mx += xs[p]
            my += ys[p]
            md += ds[p]
    out[:] = plane
    if count < 3:
        return count
    mx /= count
    my /= count
    md /= count
    sxx = sxy = syy = sxd = syd = 0.0
    for p in range(n):
        if abs(plane[0] * xs[p] + plane[1] * ys[p] + plane[2] - ds[p]) <= inlier:
            x, y, d = xs[p] - mx, ys[p] - my, ds[p] - md
            sxx += x * x
            sxy += x * y
            syy += y * y
            sxd += x * d
            syd += y * d
    det = sxx * syy - sxy * sxy
    if det <= 1e-9 * max(1.0, sxx * syy):
        return count
    a = (sxd * syy - syd * sxy) / det
    b = (sxx * syd - sxy * sxd) / det
    out[0] = a
    out[1] = b
    out[2] = md - a * mx - b * my
    return count


@nb.njit(cache=True)
def fit_segment(xs, ys, ds, iterations, inlier, stop, max_scored, seed, out):
    """RANSAC then least squares over the points; returns the final inlier count.

    Each drawn plane is scored on every ``stride``-th point, ``stride = n // max_scored``
    (at least 1), for speed; the draws stop early at a plane with ``stop`` (a fraction) of
    the scored points as inliers. The refit and the count returned use every point.

    ``out``: (a, b, c) of ``d = a x + b y + c``. Fewer than three points: no plane, 0.
    """
    n = xs.shape[0]
    if n < 3:
        return 0
    stride = max(1, n // max_scored)
    scored = (n + stride - 1) // stride
    sx, sy, sd = xs, ys, ds
    if stride > 1:  # the scored points gathered once, for a contiguous loop per draw
        sx = np.empty(scored, dtype=xs.dtype)
        sy = np.empty(scored, dtype=ys.dtype)
        sd = np.empty(scored, dtype=ds.dtype)
        for q in range(scored):
            sx[q], sy[q], sd[q] = xs[q * stride], ys[q * stride], ds[q * stride]
    state = (seed * 7919 + 1) % LCG_M
    trial = np.empty(3)
    best = np.empty(3)
    best_count = -1
    for _ in range(iterations):
        state = lcg_next(state)
        i = (state >> 8) % n
        state = lcg_next(state)
        j = (state >> 8) % n
        state = lcg_next(state)
        k = (state >> 8) % n
        if i == j or j == k or i == k:
            continue
        if not _plane_through(xs, ys, ds, i, j, k, trial):
            continue
        a, b, c = trial[0], trial[1], trial[2]
        count = 0
        for q in range(scored):
            if abs(a * sx[q] + b * sy[q] + c - sd[q]) <= inlier:
                count += 1
        if count > best_count:
            best_count = count
            best[:] = trial
            if count >= stop * scored:  # enough of the points agree: no better plane to find
                break
    if best_count < 3:
        return 0
    refined = np.empty(3)
    _least_squares(xs, ys, ds, best, inlier, refined)
    count = 0
    for p in range(n):
        if abs(refined[0] * xs[p] + refined[1] * ys[p] + refined[2] - ds[p]) <= inlier:
            count += 1
    out[:] = refined
    return count


@nb.njit(cache=True)
def segment_points(disparity, usable, wanted, labels, n, lattice, xs, ys, ds):
    """Each segment's ``usable`` estimates, gathered in raster order: a counting sort.

    Only the pixels of every ``lattice``-th row and column count (1: all of them), but a
    segment is ``need``-ed when any of its pixels is ``wanted``. ``xs``, ``ys``, ``ds``:
    buffers of at least as many elements as there are ``usable`` pixels (a caller's,
    reused: a fresh array of a few megabytes costs more in page faults than the sort).
    Returns ``(starts, size, need)``: segment ``k``'s estimates are
    ``xs[starts[k]:starts[k + 1]]`` (columns; ``ys`` rows, ``ds`` disparities),
    ``size[k]`` its pixels on the lattice, ``need[k]`` whether any pixel is ``wanted``.
    """
    height, width = disparity.shape
    starts = np.zeros(n + 1, dtype=np.int64)
    size = np.zeros(n, dtype=np.int64)
    need = np.zeros(n, dtype=np.bool_)
    for y in range(height):
        row, want = labels[y], wanted[y]
        for x in range(width):
            if want[x]:
                need[row[x]] = True
    for y in range(0, height, lattice):
        row, use = labels[y], usable[y]
        for x in range(0, width, lattice):
            k = row[x]
            size[k] += 1
            starts[k + 1] += use[x]
    for k in range(n):
        starts[k + 1] += starts[k]
    fill = starts[:n].copy()
    for y in range(0, height, lattice):
        row, use, values = labels[y], usable[y], disparity[y]
        for x in range(0, width, lattice):
            if use[x]:
                k = row[x]
                q = fill[k]
                xs[q], ys[q], ds[q] = x, y, values[x]
                fill[k] = q + 1
    return starts, size, need


@nb.njit(cache=True, parallel=True)
def fit_planes(disparity, usable, wanted, labels, n, iterations, inlier, stop, max_scored,
               min_support, lattice, xs, ys, ds, planes, support, threads=1):  # fmt: skip
    """Fit a plane to each segment's ``usable`` estimates.

    ``planes[k]``: (a, b, c); ``support[k]``: (estimates used, inliers, pixels). A segment
    none of whose pixels is ``wanted``, or with under three estimates or under
    ``min_support`` of its pixels, is not fitted: plane (0, 0, 0), no inliers. ``xs``,
    ``ys``, ``ds``: :func:`segment_points`' buffers. ``threads``: numba's thread count; the
    segments are handed out one at a time to whichever thread is free (a segment's RANSAC
    draws from its own seed, so the planes do not depend on the order).
    """
    starts, size, need = segment_points(disparity, usable, wanted, labels, n, lattice, xs, ys,
                                        ds)  # fmt: skip
    counter = np.zeros(1, dtype=np.int64)
    for _ in nb.prange(max(1, min(threads, n))):
        plane = np.zeros(3)
        k = next_task(counter)
        while k < n:
            s0, s1 = starts[k], starts[k + 1]
            m = s1 - s0
            count = 0
            plane[:] = 0.0
            if need[k] and m >= 3 and m >= min_support * size[k]:
                count = fit_segment(xs[s0:s1], ys[s0:s1], ds[s0:s1], iterations, inlier, stop,
                                    max_scored, k, plane)  # fmt: skip
            planes[k, :] = plane
            support[k, 0] = m
            support[k, 1] = count
            support[k, 2] = size[k]
            k = next_task(counter)


@nb.njit(cache=True, parallel=True)
def apply_planes(disparity, replaceable, labels, planes, trusted, outlier, low, high, out):
    """Write the refined map into ``out``.

    A pixel of a ``trusted`` segment takes the plane's value (limited to ``low..high``)
    when it is ``replaceable`` and either has no estimate or one farther than ``outlier``
    from the plane; every other pixel keeps its value. Returns nothing.
    """
    height, width = disparity.shape
    for y in nb.prange(height):
        source, row, replace, target = disparity[y], labels[y], replaceable[y], out[y]
        for x in range(width):  # a loop, not a slice copy: ``out`` may be ``disparity``
            target[x] = source[x]
        for x in range(width):
            if not replace[x]:  # most pixels: their own value, the plane unread
                continue
            k = row[x]
            if not trusted[k]:
                continue
            d = source[x]
            value = planes[k, 0] * x + planes[k, 1] * y + planes[k, 2]
            if not (np.isnan(d) or abs(d - value) > outlier):
                continue
            target[x] = min(high, max(low, value))


@nb.njit(cache=True, parallel=True)
def shrink(colour, scale, out):
    """Mean of each ``scale x scale`` block of ``colour`` (``(C, H, W)``) into ``out``.

    ``out``: ``(C, ceil(H / scale), ceil(W / scale))`` float64; a block cut by the image's
    edge is the mean of the pixels it has. The block's rows are added first (whole rows at a
    time, in vector lanes), then each block's columns in order (blocks side by side in vector
    lanes): for integer images (the exact sums of at most ``2**53``) the same sums as in
    any order.
    """
    channels, height, width = colour.shape
    rows, cols = out.shape[1], out.shape[2]
    for r in nb.prange(rows):
        y0, y1 = r * scale, min(height, (r + 1) * scale)
        column = np.empty(width)
        total = np.empty(cols)
        whole = width // scale  # the blocks not cut by the right edge
        for c in range(channels):
            column[:] = 0.0
            for y in range(y0, y1):
                source = colour[c, y]
                for x in range(width):
                    column[x] += source[x]
            # each block's columns added in order, a block per vector lane: offset by offset
            total[:] = 0.0
            for dx in range(scale):
                for q in range(whole):
                    total[q] += column[q * scale + dx]
            for x in range(whole * scale, width):
                total[whole] += column[x]
            target = out[c, r]
            area = (y1 - y0) * scale
            for q in range(whole):
                target[q] = total[q] / area
            if whole < cols:
                target[whole] = total[whole] / ((y1 - y0) * (width - whole * scale))


@nb.njit(cache=True, parallel=True)
def expand(labels, scale, out):
    """Label each pixel of ``out`` (``(H, W)``) as its ``scale x scale`` block in ``labels``.

    A block row's first pixel row is spread once, then copied to its other rows.
    """
    height, width = out.shape
    rows, cols = labels.shape
    for r in nb.prange(rows):
        source = labels[r]
        y0 = r * scale
        row = out[y0]
        for q in range(cols):
            x0 = q * scale
            value = source[q]
            for x in range(x0, min(width, x0 + scale)):
                row[x] = value
        for y in range(y0 + 1, min(height, y0 + scale)):
            out[y, :] = row

"""The right view's rows moved onto the left's, where a pair is not quite rectified.

Stereo matching searches along rows: a left pixel's match is sought in the same row of the
right view. Where the rectification is off (a camera turned a little, focal lengths that
differ, a calibration of last month), the match lies a fraction of a row above or below,
and every cost compares pixels of slightly different scene points; weak texture suffers
first. Middlebury's 2014 pairs are given with such an imperfect rectification, and the
KITTI 2012 pairs of the development set are off by up to about a pixel and a half in
their corners.

:func:`estimate_from` measures it (:func:`dcstereo.methods.sgm.sgm_row_field` runs it on a
pair, with its coarse pass). On a grid of left pixels with vertical texture, a patch is
matched in the right view around the disparity of a coarse pass (the census alone,
:data:`~dcstereo.costs.photometric.COARSE_FACTOR` times smaller each way, as
``photometric`` uses), over offsets of a fraction of a row (both views smoothed and
interpolated between their rows, :func:`patch_curves`). Per tile of a :data:`GRID` x
:data:`GRID` grid of the right view, the summed costs give the tile's offset, and a smooth
field through the tiles (:class:`RowField`) gives each right pixel its own: ``a + b u + c v
+ e u v + f v^2`` with ``u``, ``v`` the pixel's place across and down the image (from -0.5
to 0.5), the terms a small turn of one camera about each axis and a difference of scale
make. :func:`moved_view` then moves the right view by it (linear interpolation between
rows) before the costs; :func:`shift_image_rows` does the same keeping the image's dtype,
for other matchers.
"""

from dataclasses import dataclass

import numba as nb
import numpy as np

from dcstereo._vector.sgm import next_task

#: The tiles across and down the right view, each giving one offset to the field.
GRID = 6

#: Half the side of a matched patch (9 x 9 pixels).
PATCH_RADIUS = 4

#: How far (pixels) a patch's match is sought on either side of the coarse disparity.
X_REACH = 3

#: The whole offsets tried first (rows of the right view): -4 to 4.
WHOLE_OFFSETS = np.arange(-4, 5, dtype=np.float64)

#: The offsets tried then around each tile's best whole one: -1 to 1 by a quarter.
FINE_OFFSETS = np.arange(-4, 5) / 4.0

#: The spacing (pixels) of the grid of left pixels the patches are taken from.
SAMPLE_STEP = 4

#: The most patches a tile measures (those of most vertical texture).
TILE_PATCHES = 64

#: The patches a thread of :func:`patch_curves` takes at a time.
TASK_PATCHES = 32

#: The patches :func:`patch_curves` measures side by side, each sum over them at once (a
#: call on teddy's 2304 patches, one thread, AVX2: 13.3 ms one patch at a time, 8.5 ms 16 a
#: time, the costs the same bit for bit).
LANES = 16

#: The fewest patches a tile needs to give an offset.
MIN_PATCHES = 12

#: The least mean absolute difference between neighbouring rows (gray levels) of a patch
#: that is measured: flat patches say nothing about rows.
MIN_TEXTURE = 1.0

#: The largest offset (rows, over the image) below which the views are left as they are:
#: the interpolation's smoothing costs about what so small a correction gains.
MIN_OFFSET = 0.25

#: The most a tile's distance from a field counts when fields are compared (rows).
OUTLIER = 0.5

#: The fewest tiles whose field moves a view: a field through fewer has no tile to tell
#: an outlier by (its robust fit needs three), and the view is left as it is.
MIN_TILES = 4

#: The sigma (pixels) of the Gaussian that smooths both intensities before the patches are
#: matched. Between rows, interpolation averages two rows' noise, so that without it a
#: noisy pair's costs are least at the offsets that interpolate most (halfway between
#: rows) and the tiles' offsets lean towards them; smoothed first, the noise of
#: neighbouring rows is alike and their average hardly less noisy.
SMOOTHING = 1.0


def gaussian_smooth(image: np.ndarray, sigma: float) -> np.ndarray:
    """Return ``image`` (``(H, W)``) smoothed by a Gaussian of ``sigma`` pixels, float64.

    Separable (down the columns, then along the rows), truncated at ``3 sigma`` (at least
    one pixel), the edges repeated; ``sigma`` 0 returns the image as it is (as float64).
    """
    array = np.ascontiguousarray(image, dtype=np.float64)
    if sigma == 0:
        return array
    radius = max(1, int(np.ceil(3 * sigma)))
    taps = np.exp(-0.5 * (np.arange(-radius, radius + 1) / sigma) ** 2)
    out = np.empty_like(array)
    _separable(array, taps / taps.sum(), out, nb.get_num_threads())
    return out


@nb.njit(cache=True, parallel=True)
def _separable(image, taps, out, threads=1):
    """``image`` filtered by ``taps`` down the columns, then along the rows (edges repeated).

    ``threads``: numba's thread count; the rows are handed out one at a time to whichever
    thread is free, each row's sums in the same order.
    """
    height, width = image.shape
    counter = np.zeros(1, dtype=np.int64)
    for _ in nb.prange(max(1, min(threads, height))):
        columns = np.empty(width)
        padded = np.empty(width + 2 * (taps.size // 2))  # a row of columns, edges repeated
        y = next_task(counter)
        while y < height:
            _separable_row(image, taps, out, y, columns, padded)
            y = next_task(counter)


@nb.njit(cache=True)
def _separable_row(image, taps, out, y, columns, padded):
    """Row ``y`` of :func:`_separable`, with the scratch rows given."""
    height, width = image.shape
    radius = taps.size // 2
    columns[:] = 0.0
    for k in range(taps.size):
        row = image[min(max(y + k - radius, 0), height - 1)]
        for x in range(width):
            columns[x] += taps[k] * row[x]
    padded[radius : radius + width] = columns
    padded[:radius] = columns[0]
    padded[radius + width :] = columns[width - 1]
    total = out[y]
    total[:] = 0.0
    for k in range(taps.size):  # each pixel's sum in the order of the taps
        shifted = padded[k:]
        for x in range(width):
            total[x] += taps[k] * shifted[x]


@nb.njit(cache=True)
def _rows_at(view, top, x0, side, span, out, lane):
    """Write ``side`` rows of ``span`` columns of ``view`` into ``out[:, :, lane]``.

    From row ``top`` (a fraction: linearly interpolated between rows) and column ``x0``;
    False, and nothing written, where they are not all inside ``view``.
    """
    height, width = view.shape
    r0 = int(np.floor(top))
    frac = top - r0
    if r0 < 0 or r0 + side >= height or x0 < 0 or x0 + span > width:
        return False
    for a in range(side):
        for c in range(span):
            out[a, c, lane] = (1.0 - frac) * view[r0 + a, x0 + c] + frac * view[r0 + a + 1, x0 + c]
    return True


@nb.njit(cache=True, parallel=True)
def patch_curves(left, right, ys, xs, xr, centres, offsets, radius, reach, out, threads=1):
    """Write each patch's cost at each vertical offset into ``out`` (``(N, len(offsets))``).

    ``left`` and ``right`` are the views' intensities (float64, ``(H, W)``). At offset
    ``o = centres[i] + offsets[j]``, patch ``i`` is the ``(2 radius + 1)^2`` left pixels
    around row ``ys[i] - o / 2`` and column ``xs[i]``, matched against the right pixels
    around row ``ys[i] + o / 2`` and column ``xr[i] + dx`` for every ``dx`` in
    ``-reach..reach``; both views are interpolated linearly between their rows, by the
    same fraction, so that neither patch is smoother than the other (interpolating one
    view alone favours whole rows). The cost is the sum of the absolute differences of the
    two patches with their means taken away, the least over ``dx``, lowered to the vertex
    of the V through it and its two neighbours (``b - |a - c| / 2``, at least 0: the cost at
    the best fraction of a column, so that a slanted edge does not trade a fraction of a
    column for one of a row); ``inf`` where a patch, or the row after it, leaves a view.

    ``threads``: numba's thread count; the patches are handed out :data:`TASK_PATCHES` at a
    time to whichever thread is free, and a thread measures :data:`LANES` of them side by
    side (``_patch_block``).
    """
    side = 2 * radius + 1
    span = side + 2 * reach  # the right columns the patches at every dx read
    shifts = 2 * reach + 1
    tasks = (ys.size + TASK_PATCHES - 1) // TASK_PATCHES
    # no more lanes than patches: a count the compiler does not know, so that it makes
    # vector loops of the lanes (with the constant it unrolled them into scalar code)
    lanes = max(1, min(LANES, ys.size))
    counter = np.zeros(1, dtype=np.int64)
    for _ in nb.prange(max(1, min(threads, tasks))):
        patch = np.empty((side, side, lanes))
        rows = np.empty((side, span, lanes))
        column_sums = np.empty((span, lanes))
        lifts = np.empty((shifts, lanes))
        sads = np.empty((shifts, lanes))
        means = np.empty(lanes)
        inside = np.empty(lanes, dtype=np.bool_)
        task = next_task(counter)
        while task < tasks:
            end = min((task + 1) * TASK_PATCHES, ys.size)
            for first in range(task * TASK_PATCHES, end, lanes):
                _patch_block(
                    left, right, ys, xs, xr, centres, offsets, radius, reach, first,
                    min(lanes, end - first), patch, rows, column_sums, lifts, sads, means,
                    inside, out,
                )  # fmt: skip
            task = next_task(counter)


@nb.njit(cache=True)
def _patch_block(
    left, right, ys, xs, xr, centres, offsets, radius, reach, first, count, patch, rows,
    column_sums, lifts, sads, means, inside, out,
):  # fmt: skip
    """Patches ``first .. first + count - 1`` of :func:`patch_curves`, one a lane.

    The buffers hold a lane's values last (``patch[a, b, lane]``), so that every sum runs
    over the lanes at once (vector code); each lane's sums are in the order of one patch
    alone (rows, then columns; the shifts side by side), so the costs do not depend on the
    patches beside it. The lanes past ``count``, and those whose patch leaves a view at an
    offset, hold zeros and are not written out.
    """
    side = 2 * radius + 1
    size = side * side
    span = side + 2 * reach
    shifts = 2 * reach + 1
    lanes = means.size
    for j in range(offsets.size):
        for p in range(lanes):
            ok = False
            if p < count:
                i = first + p
                half = 0.5 * (centres[i] + offsets[j])
                x0 = xr[i] - reach - radius  # the first right column the patches read
                ok = _rows_at(left, ys[i] - radius - half, xs[i] - radius, side, side, patch, p)
                ok = ok and _rows_at(right, ys[i] - radius + half, x0, side, span, rows, p)
            inside[p] = ok
            if not ok:
                patch[:, :, p] = 0.0
                rows[:, :, p] = 0.0
        means[:] = 0.0
        for a in range(side):
            for b in range(side):
                value = patch[a, b]
                for p in range(lanes):
                    means[p] += value[p]
        for p in range(lanes):
            means[p] = means[p] / size
        column_sums[:] = 0.0
        for a in range(side):
            for c in range(span):
                value, total = rows[a, c], column_sums[c]
                for p in range(lanes):
                    total[p] += value[p]
        lifts[:] = 0.0
        for dx in range(shifts):
            lift = lifts[dx]
            for b in range(side):
                value = column_sums[dx + b]
                for p in range(lanes):
                    lift[p] += value[p]
            for p in range(lanes):
                lift[p] = lift[p] / size - means[p]  # the right patch's mean over the left's
        sads[:] = 0.0
        for dx in range(shifts):
            lift, sad = lifts[dx], sads[dx]
            for a in range(side):
                for b in range(side):
                    value, row = patch[a, b], rows[a, dx + b]
                    for p in range(lanes):
                        sad[p] += abs(value[p] - row[p] + lift[p])
        for p in range(count):
            if not inside[p]:
                out[first + p, j] = np.inf
                continue
            k = 0  # the first least
            for dx in range(1, shifts):
                if sads[dx, p] < sads[k, p]:
                    k = dx
            best = sads[k, p]
            if 0 < k < 2 * reach:
                best = max(best - 0.5 * abs(sads[k - 1, p] - sads[k + 1, p]), 0.0)  # the V
            out[first + p, j] = best


@nb.njit(cache=True)
def row_texture(luma, ys, xs, radius):
    """Return each patch's mean absolute difference between neighbouring rows.

    The ``(2 radius + 1)^2`` patch around ``(ys[i], xs[i])`` of ``luma``: the mean of
    ``|luma[y + 1, x] - luma[y, x]|`` over its ``2 radius`` pairs of rows and its columns.
    """
    side = 2 * radius + 1
    out = np.empty(ys.size)
    for i in range(ys.size):
        total = 0.0
        for a in range(-radius, radius):
            for b in range(-radius, radius + 1):
                total += abs(luma[ys[i] + a + 1, xs[i] + b] - luma[ys[i] + a, xs[i] + b])
        out[i] = total / (side * (side - 1))
    return out


@dataclass(frozen=True)
class RowField:
    """Where each pixel of the left view's rows lies in the right view: a smooth field.

    ``offset(x, y) = a + b u + c v + e u v + f v^2`` rows, ``u = x / W - 0.5`` and
    ``v = y / H - 0.5`` for a right pixel ``(x, y)`` of a ``W x H`` view, ``u`` and ``v``
    held within the measured tiles' centres (no extrapolation past them): the right view's
    row ``y + offset`` shows what the left's row ``y`` shows.

    Attributes
    ----------
    coefficients : ndarray of float64, shape (5,)
        ``(a, b, c, e, f)``, rows.
    tiles : ndarray of float64, shape (T, 4)
        The tiles measured: the mean row of their patches (the left view's), the mean
        column of their matches in the right view, their offset and their number of
        patches.
    width, height : int
        The views' size.
    """

    coefficients: np.ndarray
    tiles: np.ndarray
    width: int
    height: int

    def offsets(self) -> np.ndarray:
        """Return the offset of every right pixel, rows: float64 ``(H, W)``."""
        u = np.arange(self.width, dtype=np.float64) / self.width - 0.5
        v = np.arange(self.height, dtype=np.float64) / self.height - 0.5
        tile_u, tile_v = self.tiles[:, 1] / self.width - 0.5, self.tiles[:, 0] / self.height - 0.5
        u = np.clip(u, tile_u.min(), tile_u.max())[np.newaxis, :]
        v = np.clip(v, tile_v.min(), tile_v.max())[:, np.newaxis]
        a, b, c, e, f = self.coefficients
        return a + b * u + c * v + e * u * v + f * v * v

    def largest(self) -> float:
        """Return the largest absolute offset over the view (rows)."""
        return float(np.abs(self.offsets()).max())

    def to_move(self) -> np.ndarray | None:
        """Return :meth:`offsets` where ``row_alignment`` moves the view by them, else None.

        It moves it where the field comes from at least :data:`MIN_TILES` tiles and its
        largest offset reaches :data:`MIN_OFFSET`.
        """
        if len(self.tiles) < MIN_TILES:
            return None
        offsets = self.offsets()
        return offsets if np.abs(offsets).max() >= MIN_OFFSET else None


def _terms(u, v, count):
    """Return the field's first ``count`` terms at ``u``, ``v``, as columns."""
    return np.stack([np.ones_like(u), u, v, u * v, v * v][:count], axis=1)


def _robust_fit(terms, offsets, weights):
    """Weighted least squares, twice: the second without the tiles far from the first fit.

    Far: more than ``max(0.25, 2.5 x the median distance)`` rows. Returns the coefficients
    and the tiles kept.
    """
    keep = np.ones(len(offsets), dtype=bool)
    for _ in range(2):
        coefficients = np.linalg.lstsq(
            terms[keep] * weights[keep, None], offsets[keep] * weights[keep], rcond=None
        )[0]
        residual = np.abs(terms @ coefficients - offsets)
        far = residual > max(0.25, 2.5 * float(np.median(residual)))
        if len(offsets) - far.sum() < terms.shape[1] + 2:
            break
        keep = ~far
    return coefficients, keep


def fit_field(tiles: np.ndarray, width: int, height: int) -> RowField:
    """Return the field through the ``tiles`` (rows ``(y, x, offset, patches)``).

    Of the fields of one, three (``a + b u + c v``) and five terms, each fitted by
    ``_robust_fit`` (each tile's squared distance weighing its number of patches) where there are
    at least two tiles more than its terms, the one of least Bayesian information criterion
    ``n log(E / n) + k log(n)`` over all ``n`` tiles, ``E`` the weighted sum of the squared
    distances of the tiles from the field, each at most :data:`OUTLIER` rows: a term must
    pay for itself, and a tile no field explains counts alike for all.
    """
    u = tiles[:, 1] / width - 0.5
    v = tiles[:, 0] / height - 0.5
    weights = np.sqrt(tiles[:, 3])
    offsets = tiles[:, 2]
    n = len(tiles)
    best, chosen = np.inf, None
    for count in (1, 3, 5):
        if count > 1 and n < count + 2:
            break
        terms = _terms(u, v, count)
        coefficients, _ = _robust_fit(terms, offsets, weights)
        distance = np.minimum(np.abs(terms @ coefficients - offsets), OUTLIER)
        error = max(float(np.sum(weights**2 * distance**2)), 1e-12)
        score = n * np.log(error / n) + count * np.log(n)
        if score < best:
            best, chosen = score, (count, coefficients)
    full = np.zeros(5)
    full[: chosen[0]] = chosen[1]
    return RowField(full, tiles, width, height)


def tile_of(ys, xr, width, height):
    """Return the tile (``row * GRID + column``) of right pixels ``(ys, xr)``."""
    column = np.clip(xr, 0, width - 1) * GRID // width
    return np.minimum(ys * GRID // height, GRID - 1) * GRID + column


def tile_minima(curves, tiles, offsets, refine):
    """Return each tile's least summed cost: ``{tile: (offset, patches)}``.

    ``tiles``: each curve's tile, a number below ``GRID**2`` (:func:`tile_of`).

    Each curve (a row of ``curves``, over ``offsets``) is divided by its median, so that
    every patch counts alike whatever its contrast; a tile's curves are summed. A tile with
    fewer than :data:`MIN_PATCHES` patches, or whose least lies at an end of ``offsets``,
    gives none. With ``refine``, the least is moved to the vertex of the parabola through
    it and its two neighbours.
    """
    scaled = curves / np.maximum(np.median(curves, axis=1, keepdims=True), 1e-9)
    step = offsets[1] - offsets[0]
    tiles = np.asarray(tiles, dtype=np.int64)
    size = GRID * GRID
    counts = np.bincount(tiles, minlength=size)
    totals = np.zeros((size, len(offsets)))
    np.add.at(totals, tiles, scaled)  # each tile's curves summed in their order
    out = {}
    for tile in np.flatnonzero(counts >= MIN_PATCHES):
        total = totals[tile]
        j = int(np.argmin(total))
        if j == 0 or j == len(offsets) - 1:
            continue
        shift = 0.0
        if refine:
            below, least, above = total[j - 1], total[j], total[j + 1]
            bend = below - 2.0 * least + above
            shift = 0.5 * (below - above) / bend if bend > 0 else 0.0
        out[int(tile)] = (offsets[j] + shift * step, int(counts[tile]))
    return out


def pick_patches(luma_l, coarse, factor):
    """Return the left pixels measured and the (rounded) coarse disparity there: ``(ys, xs, d)``.

    ``luma_l``: the left intensity, gray levels (float64); ``coarse``: the coarse pass's
    disparities (``factor`` times smaller each way, NaN: none). On a grid of
    :data:`SAMPLE_STEP` pixels, inside the view by a patch and a row, where the coarse pass
    kept an estimate and the patch's :func:`row_texture` reaches :data:`MIN_TEXTURE`; per
    tile of the right view the :data:`TILE_PATCHES` of most such texture, by tile
    (:func:`tile_of`) and within a tile the most textured first.
    """
    height, width = luma_l.shape
    r = PATCH_RADIUS
    ys, xs = np.mgrid[r + 1 : height - r - 1 : SAMPLE_STEP, r : width - r : SAMPLE_STEP]
    ys, xs = ys.ravel(), xs.ravel()
    cy = np.minimum(ys // factor, coarse.shape[0] - 1)
    cx = np.minimum(xs // factor, coarse.shape[1] - 1)
    d = coarse[cy, cx] * factor
    known = np.isfinite(d)
    ys, xs, d = ys[known], xs[known], np.rint(d[known]).astype(np.int64)
    texture = row_texture(luma_l, ys, xs, r)
    good = texture >= MIN_TEXTURE
    ys, xs, d, texture = ys[good], xs[good], d[good], texture[good]
    tile = tile_of(ys, xs - d, width, height)
    order = np.lexsort((-texture, tile))  # by tile, the most texture first
    rank = np.arange(order.size) - np.searchsorted(tile[order], tile[order])
    order = order[rank < TILE_PATCHES]
    return ys[order], xs[order], d[order]


def fine_curves(left, right, ys, xs, xr, centres, whole, threads=1):
    """Return the patches' :func:`patch_curves` at :data:`FINE_OFFSETS` around ``centres``.

    ``centres``: each patch's tile's best whole offset (one of :data:`WHOLE_OFFSETS`);
    ``whole``: the patches' curves at :data:`WHOLE_OFFSETS`. A fine offset that lands on a
    whole one (``centre - 1``, ``centre``, ``centre + 1``) is that curve's value, the same
    sums of the same rows (the offset is the same float, exact in binary); the others are
    measured: a third fewer offsets. :func:`estimate_from`, one thread, AVX2, the same
    field: teddy 42.3 -> 37.6 ms, tsukuba 39.4 -> 34.6, KITTI 000066 56.8 -> 50.8 (with
    :func:`tile_minima`'s sums in one pass).
    """
    fine = np.empty((ys.size, FINE_OFFSETS.size))
    kept = np.zeros(FINE_OFFSETS.size, dtype=np.bool_)
    for j, offset in enumerate(FINE_OFFSETS):
        place = np.rint(centres + offset - WHOLE_OFFSETS[0]).astype(np.int64)
        inside = (place >= 0) & (place < WHOLE_OFFSETS.size)
        if inside.all() and np.array_equal(WHOLE_OFFSETS[place], centres + offset):
            fine[:, j] = whole[np.arange(ys.size), place]
            kept[j] = True
    measured = np.empty((ys.size, int((~kept).sum())))
    patch_curves(
        left, right, ys, xs, xr, centres, FINE_OFFSETS[~kept], PATCH_RADIUS, X_REACH, measured,
        threads,
    )  # fmt: skip
    fine[:, ~kept] = measured
    return fine


def estimate_from(luma_l, luma_r, coarse, factor):
    """Return the :class:`RowField` of two intensities (gray levels) and a coarse disparity.

    ``coarse``: a left disparity map ``factor`` times smaller each way (NaN: none). Both
    intensities are smoothed (:data:`SMOOTHING`); the patches (:func:`pick_patches`, chosen
    on the left intensity as given) are matched at the whole offsets :data:`WHOLE_OFFSETS`
    first; each tile's least summed cost (:func:`tile_minima`) gives the centre of its
    :data:`FINE_OFFSETS`, whose least, refined by a parabola, is the
    tile's offset; :func:`fit_field` fits the field through the tiles. None where no tile
    could be measured.
    """
    luma_l = np.asarray(luma_l, dtype=np.float64)
    left = gaussian_smooth(luma_l, SMOOTHING)
    right = gaussian_smooth(luma_r, SMOOTHING)
    height, width = left.shape
    ys, xs, d = pick_patches(luma_l, coarse, factor)
    xr = xs - d
    tiles = tile_of(ys, xr, width, height)
    whole = np.empty((ys.size, WHOLE_OFFSETS.size))
    threads = nb.get_num_threads()
    patch_curves(
        left, right, ys, xs, xr, np.zeros(ys.size), WHOLE_OFFSETS, PATCH_RADIUS, X_REACH, whole,
        threads,
    )  # fmt: skip
    measured = np.all(np.isfinite(whole), axis=1)
    coarse_best = tile_minima(whole[measured], tiles[measured], WHOLE_OFFSETS, False)
    chosen = np.isin(tiles, list(coarse_best))
    ys, xs, xr, tiles = ys[chosen], xs[chosen], xr[chosen], tiles[chosen]
    centres = np.array([coarse_best[t][0] for t in tiles], dtype=np.float64)
    fine = fine_curves(left, right, ys, xs, xr, centres, whole[chosen], threads)
    measured = np.all(np.isfinite(fine), axis=1)
    rows = []
    for tile, (offset, count) in tile_minima(
        fine[measured], tiles[measured], FINE_OFFSETS, True
    ).items():
        here = measured & (tiles == tile)
        rows.append((ys[here].mean(), xr[here].mean(), coarse_best[tile][0] + offset, count))
    if not rows:
        return None
    return fit_field(np.array(rows, dtype=np.float64), width, height)


@nb.njit(cache=True)
def _move_rows(image, offsets, scale, rounded, out):
    """Write ``image`` (``(H, W, C)``) moved by ``offsets`` rows, times ``scale``, to ``out``.

    Pixel ``(y, x)`` takes the value at row ``y + offsets[y, x]`` of its column, linearly
    interpolated, rows beyond the image its first or last; rounded half up with
    ``rounded``.
    """
    height, width, channels = image.shape
    for y in range(height):
        for x in range(width):
            source = y + offsets[y, x]
            r0 = int(np.floor(source))
            frac = source - r0
            if r0 < 0:
                r0, frac = 0, 0.0
            elif r0 >= height - 1:
                r0, frac = height - 1, 0.0
            r1 = min(r0 + 1, height - 1)
            for c in range(channels):
                value = ((1.0 - frac) * image[r0, x, c] + frac * image[r1, x, c]) * scale
                out[y, x, c] = np.floor(value + 0.5) if rounded else value


def _moved(image, offsets, scale, dtype, rounded):
    """:func:`_move_rows` of a ``(H, W)`` or ``(H, W, C)`` array into a new one of ``dtype``.

    Floats other than float32 and float64 (float16, longdouble) are read as float64.
    """
    array = np.asarray(image)
    if array.dtype.kind == "f" and array.dtype not in (np.float32, np.float64):
        array = array.astype(np.float64)
    planes = array[:, :, np.newaxis] if array.ndim == 2 else array
    out = np.empty(planes.shape, dtype=np.float64 if dtype.kind == "f" else dtype)
    _move_rows(
        np.ascontiguousarray(planes), np.asarray(offsets, dtype=np.float64), scale, rounded, out
    )
    out = out.astype(dtype, copy=False)
    return out[:, :, 0] if array.ndim == 2 else out


def shift_rows(signal: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Return ``signal`` with each pixel taken ``offsets`` rows lower (linearly interpolated).

    ``signal``: ``(H, W)`` or ``(C, H, W)`` numbers (an intensity, colour channels);
    ``offsets``: ``(H, W)`` rows (:meth:`RowField.offsets`). Pixel ``(y, x)`` takes the
    value at row ``y + offsets[y, x]`` of its column, rounded half up for an integer dtype;
    rows beyond the view repeat its first or last row. The dtype is kept (a value between
    two of the dtype's lies within its range).
    """
    array = np.asarray(signal)
    if array.ndim == 2:
        return shift_image_rows(array, offsets)
    return np.moveaxis(shift_image_rows(np.moveaxis(array, 0, 2), offsets), 2, 0)


def shift_image_rows(image: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Return an image (``(H, W)`` or ``(H, W, C)``) moved as :func:`shift_rows` moves it.

    The dtype is kept, integers rounded half up: for a matcher that takes the image's own
    dtype (OpenCV's). ``row_alignment`` itself matches :func:`moved_view`, which keeps the
    fractions.
    """
    array = np.asarray(image)
    return _moved(array, offsets, 1.0, array.dtype, np.issubdtype(array.dtype, np.integer))


def moved_view(image: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Return the view ``row_alignment`` matches: the image moved, as float32 in [0, 1].

    :func:`shift_image_rows` of the image's values on the [0, 1] scale (uint8 over 255,
    uint16 over 65535, floats as they are), not rounded, so that the interpolated values
    keep their fractions: the intensity ``sgm`` computes from it is exact to its 1/16 of a
    gray level (the image moved as uint8 and rounded lost 0.37 points of bad-1.0 on
    Playtable). For any of dcstereo's methods: ``match(left, moved_view(right, offsets))``.
    """
    array = np.asarray(image)
    integer = np.issubdtype(array.dtype, np.integer)
    scale = 1.0 / np.iinfo(array.dtype).max if integer else 1.0
    return _moved(array, offsets, scale, np.dtype(np.float32), False)

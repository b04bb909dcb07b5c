"""A Gaussian smoothing of the intensity before the census transform (``census_smoothing``).

The census compares each pixel with its neighbours one by one, so the noise of single
pixels flips its bits where the image is nearly flat: a road, a wall in shadow, the sky.
Smoothing each view's intensity by a Gaussian of ``sigma`` pixels first keeps the bits of
the shading and of the coarser texture. It suits camera images whose finest detail is
mostly noise (KITTI's driving scenes: D1 5.71 -> 4.8 with the other stages) and costs
sharp images their finest texture (the Middlebury scenes lose), so it is off by default
(``docs/guide/methods.md``).

The weights are integers (:func:`gaussian_weights`, summing to ``2 ** WEIGHT_BITS`` each
way), so the smoothed value is exact and does not depend on the order of the sums.
"""

import numba as nb
import numpy as np

#: The 1-D weights sum to ``2 ** WEIGHT_BITS``; the 2-D sum is shifted back by twice that.
WEIGHT_BITS = 12

#: The weights reach ``round(TRUNCATE * sigma)`` pixels from the centre (as
#: ``scipy.ndimage.gaussian_filter``'s default).
TRUNCATE = 4.0


def gaussian_weights(sigma: float) -> np.ndarray:
    """Return the integer 1-D Gaussian weights of ``sigma`` pixels (int64, odd length).

    ``exp(-i**2 / (2 sigma**2))`` for ``|i| <= round(TRUNCATE * sigma)`` (at least 1),
    scaled to sum to ``2 ** WEIGHT_BITS`` and rounded; the centre weight takes what the
    rounding left over, so the sum is exact. ``sigma`` 0: the single weight
    ``2 ** WEIGHT_BITS`` (no smoothing).
    """
    total = 1 << WEIGHT_BITS
    if sigma == 0:
        return np.array([total], dtype=np.int64)
    radius = max(1, int(TRUNCATE * sigma + 0.5))
    offsets = np.arange(-radius, radius + 1, dtype=np.float64)
    g = np.exp(-(offsets**2) / (2.0 * sigma * sigma))
    weights = np.rint(g * (total / g.sum())).astype(np.int64)
    weights[radius] += total - int(weights.sum())
    return weights


def smooth_signal(signal: np.ndarray, sigma: float) -> np.ndarray:
    """Return ``signal`` (int32, ``(H, W)``) smoothed by a Gaussian of ``sigma`` pixels.

    Separable, the edges repeated, the weights of :func:`gaussian_weights` down the
    columns and then along the rows, rounded to the nearest integer (halves up). ``sigma``
    0 returns ``signal`` itself.
    """
    if sigma == 0:
        return signal
    out = np.empty(signal.shape, dtype=np.int32)
    _smooth(np.ascontiguousarray(signal, dtype=np.int32), gaussian_weights(sigma), out)
    return out


@nb.njit(cache=True, parallel=True)
def _smooth(signal, weights, out):
    """Write the separable integer smoothing of ``signal`` into ``out``, rows in parallel."""
    height, width = signal.shape
    radius = weights.size // 2
    shift = 2 * WEIGHT_BITS
    half = np.int64(1) << (shift - 1)
    for y in nb.prange(height):
        column = np.zeros(width + 2 * radius, dtype=np.int64)  # row y's vertical sums, padded
        for i in range(weights.size):
            yy = min(max(y + i - radius, 0), height - 1)
            w = weights[i]
            src = signal[yy]
            for x in range(width):
                column[radius + x] += w * src[x]
        for x in range(radius):  # the edges repeated
            column[x] = column[radius]
            column[radius + width + x] = column[radius + width - 1]
        acc = np.full(width, half, dtype=np.int64)
        for j in range(weights.size):
            w = weights[j]
            for x in range(width):
                acc[x] += w * column[x + j]
        for x in range(width):
            out[y, x] = acc[x] >> shift

"""Synthetic stereograms with known disparity, built from seeded random textures."""

import numpy as np


def texture(rng, height, width, smooth=1):
    """A random uint8 texture, box-smoothed along x ``smooth`` times (1 = raw noise)."""
    t = rng.integers(0, 256, size=(height, width)).astype(np.float64)
    for _ in range(smooth - 1):
        t = (t + np.roll(t, 1, axis=1) + np.roll(t, -1, axis=1)) / 3.0
    t = (t - t.min()) / max(np.ptp(t), 1e-9) * 255.0
    return np.rint(t).astype(np.uint8)


def constant_pair(rng, height, width, disparity):
    """Left/right with ``left[:, x] = right[:, x - disparity]`` (random left border)."""
    right = texture(rng, height, width)
    left = texture(rng, height, width)
    left[:, disparity:] = right[:, : width - disparity]
    return left, right


def object_pair(rng, height, width, background, foreground, columns):
    """A fronto-parallel object in front of a fronto-parallel background.

    The object covers left columns ``columns = (x0, x1)`` at disparity ``foreground``;
    everything else is background at disparity ``background``. Returns ``(left, right,
    truth)`` with ``truth`` the left disparity, NaN on the left pixels whose background
    partner is hidden behind the object in the right view (the occluded band
    ``[x0 - (foreground - background), x0)``) and on the left border.
    """
    x0, x1 = columns
    back = texture(rng, height, width + background)  # indexed by right column + background
    front = texture(rng, height, width)  # indexed by right column
    right = back[:, background : background + width].copy()
    right[:, x0 - foreground : x1 - foreground] = front[:, x0 - foreground : x1 - foreground]
    left = np.empty_like(right)
    truth = np.full((height, width), float(background), dtype=np.float32)
    for x in range(width):
        if x0 <= x < x1:
            left[:, x] = front[:, x - foreground]
            truth[:, x] = foreground
        else:
            left[:, x] = back[:, x]  # right column x - background
            j = x - background
            if j < 0 or x0 - foreground <= j < x1 - foreground:
                truth[:, x] = np.nan
    return left, right, truth


def slanted_pair(rng, height, width, d0, slope):
    """A slanted plane ``d(x) = d0 + slope * x`` (left geometry), linear resampling.

    The right image is a smooth-ish random texture; the left pixel ``x`` samples it at
    ``x - d(x)``. Returns ``(left, right, truth)``; truth is NaN where the sample would
    leave the right image.
    """
    right = texture(rng, height, width, smooth=2).astype(np.float64)
    xs = np.arange(width, dtype=np.float64)
    truth = d0 + slope * xs
    src = xs - truth
    inside = (src >= 0) & (src <= width - 1)
    left = np.empty((height, width))
    for y in range(height):
        left[y] = np.interp(src, np.arange(width), right[y])
    truth = np.where(inside, truth, np.nan)
    return (
        np.rint(left).astype(np.uint8),
        right.astype(np.uint8),
        np.broadcast_to(truth, (height, width)).astype(np.float32),
    )

"""The matching signal: the edge-padded integer intensity of an image, in one pass.

The numpy path (``signal.matching_signal`` then ``np.pad``) makes several full-image
temporaries and runs on one core: on a Middlebury colour pair it took 2 ms, an eighth of
the whole ``dsi5`` match, and all of it serial. Here every padded row is computed straight
from its source row, rows in parallel, with the same float64 expressions in the same order,
so the values are those of the numpy path, bit for bit.

A ``uint8`` colour row reads its three weighted channels from tables of the 256 products
``v * LUMA[i]`` (the float64 products the expression makes, so the same sums): the
interleaved three-byte pixels leave the arithmetic loop scalar, and the tables halve its
time (a 434 x 383 colour image: 0.32 -> 0.16 ms). Rows of RGB (three channels, C order, at
least 8 pixels: every Middlebury image) run vector code instead, 8 pixels at a time, with
the same products and sums (``simd._rgb_pixels``): 0.21 -> 0.155 ms on that image, 1 thread.
"""

import numba as nb
import numpy as np

from dcstereo._vector.simd import _LANES, _rgb_pixels

#: ``mode`` of ``padded_signal``: how a stored value becomes the 0..255 intensity scale.
MODE_UINT8 = 0  # as is
MODE_UINT16 = 1  # / 257
MODE_FLOAT = 2  # * 255 (floats in [0, 1])

#: BT.601 luma weights of R, G and B (the weights the Middlebury tools use).
LUMA = (0.299, 0.587, 0.114)


@nb.njit(cache=True, inline="always")
def _pad_ends(out, yp, radius, width):
    """Repeat padded row ``yp``'s first and last image pixels over its ``radius`` ends."""
    for x in range(radius):
        out[yp, x] = out[yp, radius]
        out[yp, radius + width + x] = out[yp, radius + width - 1]


@nb.njit(cache=True, inline="always")
def _row(image, y, mul, div, colour, steps, out, yp, radius):
    """Write padded row ``yp`` of ``out`` from row ``y`` (a value's intensity: ``v * mul / div``).

    The callers pass constants (1 or the scale), so the compiler folds the identities away
    and each call is its own loop; ``x * 1.0`` and ``x / 1.0`` are exact, so the values are
    those of ``signal.intensity``'s single multiplication or division.
    """
    width = image.shape[1]
    for x in range(width):
        if colour:
            lum = (
                (np.float64(image[y, x, 0]) * mul / div) * LUMA[0]
                + (np.float64(image[y, x, 1]) * mul / div) * LUMA[1]
            ) + (np.float64(image[y, x, 2]) * mul / div) * LUMA[2]
        else:
            lum = np.float64(image[y, x, 0]) * mul / div
        out[yp, radius + x] = np.int32(np.rint(lum * steps))
    _pad_ends(out, yp, radius, width)


@nb.njit(cache=True, inline="always")
def _row_tables(image, y, tables, steps, out, yp, radius):
    """``_row`` of a ``uint8`` colour image, the channel products read from ``tables``.

    (Compiled for every dtype, ``padded_signal``'s branches being chosen at run time; the
    ``np.intp`` casts type it, and only ``uint8`` images run it.)
    """
    width = image.shape[1]
    for x in range(width):
        v0, v1, v2 = np.intp(image[y, x, 0]), np.intp(image[y, x, 1]), np.intp(image[y, x, 2])
        lum = (tables[0, v0] + tables[1, v1]) + tables[2, v2]
        out[yp, radius + x] = np.int32(np.rint(lum * steps))
    _pad_ends(out, yp, radius, width)


@nb.njit(cache=True, inline="always")
def _row_rgb(image, y, steps, out, yp, radius):
    """``_row_tables`` of a three-channel image ``_LANES`` pixels at a time (at least that wide).

    A last block that would pass the row's end is taken ``_LANES`` pixels back from it: it
    writes some pixels twice, with the same values.
    """
    width = image.shape[1]
    for b in range((width + _LANES - 1) // _LANES):
        x0 = min(b * _LANES, width - _LANES)
        _rgb_pixels(image, y, x0, LUMA, steps, out, yp, radius + x0)
    _pad_ends(out, yp, radius, width)


@nb.njit(cache=True, parallel=True)
def padded_signal(image, mode, steps, radius, out):
    """Write the matching signal of ``image`` (H, W, C), edge-padded by ``radius``, to ``out``.

    ``out`` is int32 ``(H + 2 radius, W + 2 radius)``; ``C`` is 1 (gray) or 3 / 4 (colour:
    BT.601 luma of the first three channels, alpha ignored). A value is
    ``rint(intensity * steps)``, the intensity as ``signal.intensity`` computes it.
    """
    height = image.shape[0]
    colour = image.shape[2] >= 3
    tables = np.empty((3, 256), dtype=np.float64)
    for v in range(256):
        for i in range(3):
            tables[i, v] = np.float64(v) * LUMA[i]
    for yp in nb.prange(height + 2 * radius):
        y = min(max(yp - radius, 0), height - 1)
        if colour:
            if mode == MODE_UINT8 and image.shape[2] == 3 and image.shape[1] >= _LANES:
                _row_rgb(image, y, steps, out, yp, radius)
            elif mode == MODE_UINT8:
                _row_tables(image, y, tables, steps, out, yp, radius)
            elif mode == MODE_UINT16:
                _row(image, y, 1.0, 257.0, True, steps, out, yp, radius)
            else:
                _row(image, y, 255.0, 1.0, True, steps, out, yp, radius)
        elif mode == MODE_UINT8:
            _row(image, y, 1.0, 1.0, False, steps, out, yp, radius)
        elif mode == MODE_UINT16:
            _row(image, y, 1.0, 257.0, False, steps, out, yp, radius)
        else:
            _row(image, y, 255.0, 1.0, False, steps, out, yp, radius)


@nb.njit(cache=True)
def signal_levels(signal, steps, out):
    """Write ``clip(rint(signal / steps), 0, 255)`` of an int32 signal to ``out`` (int16).

    The gray views' 0..255 levels (``signal.colour_channels``), in one pass instead of
    numpy's four float64 temporaries (``colour_channels`` of KITTI's 1226 x 370 pair: 12-17
    -> 3.5 ms, this pass 0.2 ms of it); the same float64 division and round-half-to-even,
    so the same values.
    """
    flat, dest = signal.reshape(-1), out.reshape(-1)
    for i in range(flat.size):
        level = np.rint(flat[i] / steps)
        dest[i] = np.int16(min(max(level, 0.0), 255.0))

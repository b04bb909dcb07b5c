"""The matching signal: how an image of any supported dtype becomes integers for the cost.

Every image is brought to the 0..255 intensity scale first:

* ``uint8`` as is, ``uint16`` divided by 257 (so 65535 -> 255), floating point images are
  taken to be in ``[0, 1]`` and multiplied by 255;
* colour (H, W, 3) or (H, W, 4) images become luma, ``0.299 R + 0.587 G + 0.114 B``
  (ITU-R BT.601, the weights the Middlebury tools use); an alpha channel is ignored.

The result is quantized to 1/16 of a gray level and stored as ``int32``. With integer
signals, window sums and DP sums are exact, so results do not depend on the order of
evaluation (tiling, threads) and the same picture in ``uint8``, ``uint16`` or float gives
the same disparity map.
"""

import numpy as np

from dcstereo import _signal as signal_kernels
from dcstereo._signal import LUMA

#: Quantization steps per gray level of the matching signal.
SIGNAL_STEPS = 16


def check_image(image: np.ndarray, name: str) -> np.ndarray:
    """Validate one input image and return it as an array (no copy when possible).

    Non-native byte orders (big-endian ``uint16`` from 16-bit PGM or PNG data) are
    accepted and returned in the machine's order.

    Raises ``TypeError`` for unsupported dtypes and ``ValueError`` for wrong shapes,
    empty images, NaN pixels or float intensities outside ``[0, 1]``.
    """
    if isinstance(image, np.ma.MaskedArray) and np.ma.is_masked(image):
        # np.asarray would match the values under the mask as if they were pixels
        raise ValueError(
            f"{name} image is a masked array with masked pixels; give it with them filled "
            f"(image.filled(value))"
        )
    try:
        array = np.asarray(image)
    except ValueError as err:  # a ragged nested list
        raise ValueError(f"{name} image is not a rectangular array: {err}") from None
    dtype = array.dtype.newbyteorder("=")  # big-endian uint16 (16-bit PGM, PNG) is uint16
    if not (dtype in (np.uint8, np.uint16) or np.issubdtype(dtype, np.floating)):
        raise TypeError(
            f"{name} image has dtype {array.dtype}; expected uint8, uint16 or float in [0, 1]"
        )
    array = _native(array)
    if array.ndim == 3 and array.shape[2] in (1, 3, 4):
        if array.shape[2] == 1:
            array = array[:, :, 0]
    elif array.ndim != 2:
        raise ValueError(
            f"{name} image has shape {array.shape}; expected (H, W) gray or (H, W, 3|4) colour"
        )
    if array.shape[0] == 0 or array.shape[1] == 0:
        raise ValueError(f"{name} image is empty (shape {array.shape})")
    if np.issubdtype(array.dtype, np.floating):
        finite = np.isfinite(array)
        bad = np.count_nonzero(~(finite.all(axis=2) if finite.ndim == 3 else finite))
        if bad:
            raise ValueError(f"{name} image has {bad} NaN or infinite pixel(s)")
        lo, hi = float(array.min()), float(array.max())
        if lo < 0.0 or hi > 1.0:
            raise ValueError(
                f"{name} image is float with values in [{lo:g}, {hi:g}]; "
                "float images must lie in [0, 1] (or pass uint8/uint16)"
            )
    return array


def check_pair(
    left: np.ndarray, right: np.ndarray, matched: tuple[int, int] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Validate a stereo pair: each image as :func:`check_image`, both of the same H x W.

    ``matched``: the ``(H, W)`` of a disparity map the pair is said to have given (for
    the functions that take a result and its pair); the images must have that size.

    The two may differ in channel layout (gray, RGB, RGBA) and dtype: every method turns
    each image into its own intensity (:func:`intensity`, :func:`padded_signal`) before
    comparing them, so a gray left and a colour right match as the gray left and the
    colour right's luma.

    Returns
    -------
    left, right : ndarray
        As :func:`check_image` returns them.
    """
    left = check_image(left, "left")
    right = check_image(right, "right")
    if left.shape[:2] != right.shape[:2]:
        raise ValueError(f"left and right images differ in shape: {left.shape} vs {right.shape}")
    if matched is not None and left.shape[:2] != tuple(matched):
        raise ValueError(
            f"the pair's images are {left.shape[1]}x{left.shape[0]}, the result's map "
            f"{matched[1]}x{matched[0]}: not the pair matched"
        )
    return left, right


def _native(array: np.ndarray) -> np.ndarray:
    """Return ``array`` in the machine's byte order (a copy only when it is not)."""
    return array if array.dtype.isnative else array.astype(array.dtype.newbyteorder("="))


def intensity(image: np.ndarray) -> np.ndarray:
    """Return the float64 intensity (0..255 scale, luma for colour) of a checked image."""
    array = _native(np.asarray(image))
    if array.dtype == np.uint8:
        scaled = array.astype(np.float64)
    elif array.dtype == np.uint16:
        scaled = array.astype(np.float64) / 257.0
    else:
        scaled = array.astype(np.float64) * 255.0
    if scaled.ndim == 3:
        # summed in this order, as ``signal_kernels.padded_signal`` does (not a matmul,
        # whose BLAS may round differently)
        scaled = scaled[:, :, 0] * LUMA[0] + scaled[:, :, 1] * LUMA[1] + scaled[:, :, 2] * LUMA[2]
    return scaled


def matching_signal(image: np.ndarray) -> np.ndarray:
    """Return the int32 matching signal (intensity in 1/16 gray levels) of a checked image."""
    return np.rint(intensity(image) * SIGNAL_STEPS).astype(np.int32)


def padded_signal(image: np.ndarray, radius: int) -> np.ndarray:
    """Return ``matching_signal(image)`` edge-padded by ``radius`` on every side.

    The same values as ``np.pad(matching_signal(image), radius, mode="edge")``, computed in
    one compiled pass over the rows (in parallel) instead of several numpy passes.
    """
    array = _native(np.asarray(image))
    if array.dtype == np.uint8:
        mode = signal_kernels.MODE_UINT8
    elif array.dtype == np.uint16:
        mode = signal_kernels.MODE_UINT16
    else:
        mode = signal_kernels.MODE_FLOAT
    if mode == signal_kernels.MODE_FLOAT and array.dtype not in (np.float32, np.float64):
        array = array.astype(np.float64)  # float16, longdouble: as ``intensity`` takes them
    if array.ndim == 2:
        array = array[:, :, np.newaxis]
    height, width = array.shape[:2]
    out = np.empty((height + 2 * radius, width + 2 * radius), dtype=np.int32)
    signal_kernels.padded_signal(array, mode, SIGNAL_STEPS, radius, out)
    return out


def colour_channels(
    left: np.ndarray, right: np.ndarray, signals: tuple[np.ndarray, np.ndarray] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Return the two views' channels on the 0..255 scale as ``(C, H, W)`` int16, rounded.

    Colour views give their three channels (an alpha channel is ignored); where either is
    gray, both give their intensity (luma), so the two always have as many channels: from
    ``signals``, the views' ``padded_signal(view, 0)`` where the caller has them (``sgm``
    does: two passes over gray views fewer, 2 ms of a KITTI pair), else made here.
    """

    def scaled(image):
        image = np.asarray(image)
        if image.dtype == np.uint8:
            return image
        if image.dtype == np.uint16:
            return image.astype(np.float64) / 257.0
        return image.astype(np.float64) * 255.0

    colour = left.ndim == 3 and right.ndim == 3 and min(left.shape[2], right.shape[2]) >= 3
    out = []
    for side, image in enumerate((left, right)):
        if not colour:  # the intensity, in one compiled pass
            signal = padded_signal(image, 0) if signals is None else signals[side]
            levels = np.empty((1, *signal.shape), dtype=np.int16)
            signal_kernels.signal_levels(signal, float(SIGNAL_STEPS), levels)
            out.append(levels)
            continue
        channels = np.moveaxis(scaled(image[:, :, :3]), 2, 0)
        if channels.dtype != np.uint8:
            channels = np.clip(np.rint(channels), 0, 255)
        out.append(np.ascontiguousarray(channels, dtype=np.int16))
    return out[0], out[1]

"""Window statistics of the matching signal used by the divide-and-conquer matcher."""

import numpy as np

from dcstereo._checks import is_integer


def window_variance(intensity: np.ndarray, window: int) -> np.ndarray:
    """Variance of the intensity over the ``window x window`` window of every pixel.

    This is the feature strength of section 2 (``sigma^2`` in eq. 2 and 3). Pixels near
    the border use an edge-replicated window, like the matching cost.

    Parameters
    ----------
    intensity : ndarray, shape (H, W)
        Intensity on the 0..255 scale.
    window : int
        Odd window side ``W``.

    Returns
    -------
    ndarray of float64, shape (H, W)
        Population variance (gray levels squared), ``mean(I^2) - mean(I)^2``.

    Examples
    --------
    >>> import numpy as np
    >>> window_variance(np.array([[0.0, 2.0, 0.0]]), 1)
    array([[0., 0., 0.]])
    >>> float(window_variance(np.array([[0.0, 2.0, 0.0]]), 3)[0, 1])
    0.888...
    """
    if not is_integer(window):
        raise TypeError(f"window must be an integer, got {window!r}")
    if window < 1 or window % 2 == 0:
        raise ValueError(f"window must be a positive odd integer, got {window}")
    array = np.asarray(intensity)
    if array.dtype == bool or not (
        np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)
    ):
        raise TypeError(f"intensity must be an array of real numbers, got dtype {array.dtype}")
    if array.ndim != 2 or array.size == 0:
        raise ValueError(f"intensity must be a non-empty (H, W) array, got shape {array.shape}")
    array = array.astype(np.float64, copy=False)
    bad = np.count_nonzero(~np.isfinite(array))
    if bad:  # one would spread through the cumulative sums to every pixel
        raise ValueError(f"intensity has {bad} NaN or infinite value(s)")
    window = int(window)
    radius = window // 2
    padded = np.pad(array, radius, mode="edge")
    mean = _box_mean(padded, window)
    mean_sq = _box_mean(padded * padded, window)
    return np.maximum(mean_sq - mean * mean, 0.0)


def _box_mean(padded: np.ndarray, window: int) -> np.ndarray:
    """Mean over every ``window x window`` block of a padded array ("valid" positions)."""
    c = np.cumsum(np.cumsum(padded, axis=0), axis=1)
    c = np.pad(c, ((1, 0), (1, 0)))
    total = (
        c[window:, window:] - c[:-window, window:] - c[window:, :-window] + c[:-window, :-window]
    )
    return total / (window * window)

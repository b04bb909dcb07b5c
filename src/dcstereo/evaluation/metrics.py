"""Disparity error metrics: pure functions with explicit masks and a stated denominator.

Every metric scores the same set of pixels, the *scored* pixels::

    scored = mask & isfinite(truth)

``mask`` is a boolean array of the image shape (all True when omitted) and ``truth`` holds
NaN (or inf) where the ground truth is unknown. How a metric treats a scored pixel whose
estimate is not finite (NaN: the matcher gave no estimate) is stated in each function:

- :func:`bad_pixel_rate` counts it as bad (the Middlebury v3 rule, so a sparse map cannot
  score better than a dense one by leaving out its hard pixels);
- :func:`mean_abs_error` and :func:`rms_error` leave it out (their denominator is the scored
  pixels with a finite estimate);
- :func:`density` is the percentage of scored pixels that have a finite estimate.

All metrics raise ``ValueError`` when no pixel is scored, rather than return a number
computed over nothing.

References
----------
D. Scharstein and R. Szeliski, "A taxonomy and evaluation of dense two-frame stereo
correspondence algorithms", IJCV 47(1/2/3):7-42, 2002 (the bad-pixel percentage).
"""

from collections.abc import Mapping, Sequence

import numpy as np

from dcstereo._checks import is_number

#: Thresholds of the bad-pixel rates reported by :func:`evaluate`, in pixels.
DEFAULT_THRESHOLDS = (0.5, 1.0, 2.0, 4.0)

#: KITTI's bad-pixel thresholds (bad-2, bad-3, bad-4), in pixels.
KITTI_THRESHOLDS = (2.0, 3.0, 4.0)

#: KITTI's D1 outlier rule: an error over this many pixels and over this share of the truth.
D1_PIXELS = 3.0
D1_RELATIVE = 0.05


def _as_real(array, name: str) -> np.ndarray:
    array = np.asarray(array)
    if array.dtype == bool or not (
        np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)
    ):
        raise TypeError(f"{name} must be an array of real numbers, got dtype {array.dtype}")
    return array.astype(np.float64, copy=False)


def _scored(estimate, truth, mask) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate the inputs; return ``(estimate, truth, scored)`` as float64 / bool arrays."""
    estimate = _as_real(estimate, "estimate")
    truth = _as_real(truth, "truth")
    if estimate.shape != truth.shape:
        raise ValueError(
            f"estimate and truth differ in shape: estimate {estimate.shape} vs truth {truth.shape}"
        )
    scored = np.isfinite(truth)
    if mask is not None:
        mask = np.asarray(mask)
        if mask.dtype != bool:
            raise TypeError(
                f"mask must be a boolean array, got dtype {mask.dtype} "
                "(compare an 8-bit mask image with 255 first)"
            )
        if mask.shape != truth.shape:
            raise ValueError(
                f"mask and truth differ in shape: mask {mask.shape} vs truth {truth.shape}"
            )
        scored &= mask
    if not scored.any():
        raise ValueError("no pixel is scored: the mask selects no pixel with finite ground truth")
    return estimate, truth, scored


def _check_threshold(threshold) -> float:
    if not is_number(threshold):
        raise TypeError(f"threshold must be a number, got {threshold!r}")
    threshold = float(threshold)
    if not np.isfinite(threshold) or threshold < 0:
        raise ValueError(f"threshold must be a finite non-negative number, got {threshold}")
    return threshold


def _bad_rate(error: np.ndarray, threshold: float) -> float:
    # ``not (error <= t)`` is True for NaN errors: a missing estimate counts as bad.
    return 100.0 * float(np.count_nonzero(~(error <= threshold))) / error.size


def bad_pixel_rate(
    estimate: np.ndarray,
    truth: np.ndarray,
    *,
    mask: np.ndarray | None = None,
    threshold: float = 1.0,
) -> float:
    """Percentage of scored pixels whose disparity error exceeds ``threshold``.

    A scored pixel is bad when ``|estimate - truth| > threshold`` (strictly greater) or when
    its estimate is not finite. The denominator is the number of scored pixels,
    ``mask & isfinite(truth)``.

    Parameters
    ----------
    estimate : ndarray, shape (H, W)
        Estimated disparity in pixels; NaN where there is no estimate.
    truth : ndarray, shape (H, W)
        Ground-truth disparity in pixels; NaN or inf where unknown (not scored).
    mask : ndarray of bool, shape (H, W), optional
        Pixels to score (for example the Middlebury ``nonocc`` mask); all by default.
    threshold : float
        Error tolerance in pixels (Middlebury: 1.0).

    Returns
    -------
    float
        Percentage in ``[0, 100]``.

    Raises
    ------
    ValueError
        When the shapes differ, the threshold is negative or not finite, or no pixel is scored.

    Examples
    --------
    >>> import numpy as np
    >>> truth = np.array([[1.0, 2.0, np.nan, 4.0]])
    >>> estimate = np.array([[1.0, 3.5, 0.0, np.nan]])
    >>> bad_pixel_rate(estimate, truth)  # 2 bad of 3 scored
    66.66666666666667
    """
    threshold = _check_threshold(threshold)
    estimate, truth, scored = _scored(estimate, truth, mask)
    return _bad_rate(np.abs(estimate[scored] - truth[scored]), threshold)


def mean_abs_error(
    estimate: np.ndarray, truth: np.ndarray, *, mask: np.ndarray | None = None
) -> float:
    """Mean absolute disparity error over the scored pixels that have a finite estimate.

    Parameters
    ----------
    estimate, truth, mask
        As in :func:`bad_pixel_rate`.

    Returns
    -------
    float
        Mean of ``|estimate - truth|`` in pixels; NaN when no scored pixel has a finite
        estimate.

    Raises
    ------
    ValueError
        When the shapes differ or no pixel is scored.

    Examples
    --------
    >>> import numpy as np
    >>> mean_abs_error(np.array([1.0, 3.0, np.nan]), np.array([1.0, 2.0, 5.0]))
    0.5
    """
    estimate, truth, scored = _scored(estimate, truth, mask)
    error = np.abs(estimate[scored] - truth[scored])
    error = error[np.isfinite(error)]
    return float(error.mean()) if error.size else float("nan")


def rms_error(estimate: np.ndarray, truth: np.ndarray, *, mask: np.ndarray | None = None) -> float:
    """Root-mean-square disparity error over the scored pixels that have a finite estimate.

    Parameters
    ----------
    estimate, truth, mask
        As in :func:`bad_pixel_rate`.

    Returns
    -------
    float
        ``sqrt(mean((estimate - truth) ** 2))`` in pixels; NaN when no scored pixel has a
        finite estimate.

    Raises
    ------
    ValueError
        When the shapes differ or no pixel is scored.

    Examples
    --------
    >>> import numpy as np
    >>> rms_error(np.array([1.0, 4.0, np.nan]), np.array([1.0, 2.0, 5.0]))
    1.4142135623730951
    """
    estimate, truth, scored = _scored(estimate, truth, mask)
    error = estimate[scored] - truth[scored]
    error = error[np.isfinite(error)]
    return float(np.sqrt(np.mean(error * error))) if error.size else float("nan")


def density(estimate: np.ndarray, truth: np.ndarray, *, mask: np.ndarray | None = None) -> float:
    """Percentage of scored pixels that have a finite estimate.

    Parameters
    ----------
    estimate, truth, mask
        As in :func:`bad_pixel_rate`; ``truth`` only defines which pixels are scored.

    Returns
    -------
    float
        Percentage in ``[0, 100]``.

    Raises
    ------
    ValueError
        When the shapes differ or no pixel is scored.

    Examples
    --------
    >>> import numpy as np
    >>> density(np.array([1.0, np.nan, np.nan, 7.0]), np.array([1.0, 2.0, 3.0, np.nan]))
    33.333333333333336
    """
    estimate, _, scored = _scored(estimate, truth, mask)
    return 100.0 * float(np.count_nonzero(np.isfinite(estimate[scored]))) / float(scored.sum())


def _d1_rate(error: np.ndarray, truth: np.ndarray) -> float:
    # ``not (...)`` makes a NaN error (no estimate) an outlier, as in _bad_rate
    fine = (error <= D1_PIXELS) | (error <= D1_RELATIVE * np.abs(truth))
    return 100.0 * float(np.count_nonzero(~fine)) / error.size


def d1_rate(estimate: np.ndarray, truth: np.ndarray, *, mask: np.ndarray | None = None) -> float:
    """KITTI's D1: percentage of scored pixels whose error is over 3 px and over 5 % of truth.

    A scored pixel is an outlier when ``|estimate - truth| > 3`` **and**
    ``|estimate - truth| > 0.05 * |truth|``, or when its estimate is not finite (KITTI's
    devkit fills a sparse map before scoring; here a missing estimate counts as an
    outlier, as in :func:`bad_pixel_rate`). The denominator is the number of scored
    pixels, ``mask & isfinite(truth)``: for KITTI, the pixels with LiDAR ground truth in
    the region (``disp_occ`` for "all", ``disp_noc`` for "noc").

    Parameters
    ----------
    estimate, truth, mask
        As in :func:`bad_pixel_rate`.

    Returns
    -------
    float
        Percentage in ``[0, 100]``.

    Raises
    ------
    ValueError
        When the shapes differ or no pixel is scored.

    Examples
    --------
    >>> import numpy as np
    >>> truth = np.array([[10.0, 100.0, 100.0, 50.0]])
    >>> estimate = np.array([[13.5, 104.0, 106.0, np.nan]])  # out, in (4 < 5), out, none
    >>> d1_rate(estimate, truth)
    75.0

    References
    ----------
    M. Menze and A. Geiger, "Object scene flow for autonomous vehicles", CVPR 2015 (the
    KITTI 2015 stereo benchmark's D1).
    """
    estimate, truth, scored = _scored(estimate, truth, mask)
    return _d1_rate(np.abs(estimate[scored] - truth[scored]), truth[scored])


def bad_key(threshold: float) -> str:
    """Return the key of the bad-pixel rate at ``threshold`` in :func:`evaluate`'s scores.

    >>> bad_key(1), bad_key(0.5)
    ('bad-1.0', 'bad-0.5')
    """
    return f"bad-{float(threshold)}"


def evaluate(
    estimate: np.ndarray,
    truth: np.ndarray,
    masks: Mapping[str, np.ndarray],
    thresholds: Sequence[float] = DEFAULT_THRESHOLDS,
    *,
    d1: bool = False,
) -> dict[str, dict[str, float]]:
    """All metrics of one disparity map, for each evaluation mask.

    Parameters
    ----------
    estimate : ndarray, shape (H, W)
        Estimated disparity in pixels; NaN where there is no estimate.
    truth : ndarray, shape (H, W)
        Ground-truth disparity in pixels; NaN or inf where unknown.
    masks : mapping of str to ndarray of bool, shape (H, W)
        Named sets of pixels to score, for example ``StereoScene.masks``
        (``"nonocc"``, ``"all"``, ``"disc"``).
    thresholds : sequence of float
        Thresholds of the bad-pixel rates, in pixels.
    d1 : bool
        Also KITTI's D1 (:func:`d1_rate`), under ``"d1"`` (percent).

    Returns
    -------
    dict
        ``{mask_name: {"bad-0.5": ..., "bad-1.0": ..., ..., "mae": ..., "rms": ...,
        "density": ...}}``, with the keys of :func:`bad_pixel_rate` (``"bad-<threshold>"``,
        percent), :func:`mean_abs_error` (``"mae"``, pixels), :func:`rms_error` (``"rms"``,
        pixels) and :func:`density` (``"density"``, percent), and ``"d1"`` first when
        asked for.

    Raises
    ------
    ValueError
        When the shapes differ, a threshold is invalid, or a mask scores no pixel.

    Examples
    --------
    >>> import numpy as np
    >>> truth = np.array([[1.0, 2.0, 3.0]])
    >>> estimate = np.array([[1.0, 2.6, np.nan]])
    >>> scores = evaluate(estimate, truth, {"all": np.ones((1, 3), bool)}, thresholds=(0.5,))
    >>> sorted(scores["all"])
    ['bad-0.5', 'density', 'mae', 'rms']
    >>> round(scores["all"]["bad-0.5"], 2)
    66.67
    """
    if not isinstance(masks, Mapping):
        raise TypeError(
            f"masks must be a mapping of names to boolean arrays, got {type(masks).__name__}"
        )
    if isinstance(thresholds, (str, bytes)) or not hasattr(thresholds, "__iter__"):
        raise TypeError(f"thresholds must be a sequence of numbers, got {thresholds!r}")
    thresholds = [_check_threshold(t) for t in thresholds]
    scores = {}
    for name, mask in masks.items():
        try:
            est, tru, scored = _scored(estimate, truth, mask)
        except ValueError as err:
            raise ValueError(f"mask {name!r}: {err}") from None
        signed = est[scored] - tru[scored]
        error = np.abs(signed)
        finite = np.isfinite(error)
        row = {"d1": _d1_rate(error, tru[scored])} if d1 else {}
        row.update({bad_key(t): _bad_rate(error, t) for t in thresholds})
        if finite.any():
            row["mae"] = float(error[finite].mean())
            row["rms"] = float(np.sqrt(np.mean(signed[finite] ** 2)))
        else:
            row["mae"] = row["rms"] = float("nan")
        row["density"] = 100.0 * float(np.count_nonzero(finite)) / error.size
        scores[name] = row
    return scores

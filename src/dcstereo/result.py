"""The result of a matching run: disparity, why pixels have none, and the fill."""

from dataclasses import dataclass, replace

import numpy as np

from dcstereo.params import MatchParams
from dcstereo.signal import check_pair

#: The DP left this left pixel without a partner (a step of eq. 5).
FLAG_OCCLUDED = 1
#: The partner would fall outside the right image (left border, or right end of the path).
FLAG_BORDER = 2
#: The value was filled in by :func:`fill_occlusions` (the reason bit stays set).
FLAG_FILLED = 4
#: A reliable feature pair of the divide-and-conquer methods (an anchor of the path).
FLAG_FEATURE = 8
#: The left-right check of ``sgm`` removed the estimate, and the pixel is not occluded: the
#: right view's choice at its partner is a farther surface (a wrong match, not a hidden
#: pixel).
FLAG_MISMATCH = 16


@dataclass(frozen=True)
class DisparityResult:
    """Disparity map of the left image and what the matcher knows about each pixel.

    Attributes
    ----------
    disparity : ndarray of float32, shape (H, W)
        ``x_right = x_left - disparity``; NaN where there is no estimate. Half-pixel
        values come from the e steps of the five-step model.
    flags : ndarray of uint8, shape (H, W)
        Bit flags: :data:`FLAG_OCCLUDED`, :data:`FLAG_BORDER`, :data:`FLAG_FILLED`,
        :data:`FLAG_FEATURE`, :data:`FLAG_MISMATCH`.
    params : MatchParams
        The parameters of the run.
    path_cost : ndarray of float64, shape (H,)
        Cost of each row's optimal path (block: sum of the chosen costs), in units of the
        mean absolute difference per pixel.
    features : ndarray of float64, shape (M, 5), or None
        The reliable feature pairs the ``dc`` methods accepted, one per row:
        ``(row, x_left, x_right, SER, VS)``, sorted by row and column; None for the
        methods without features.
    """

    disparity: np.ndarray
    flags: np.ndarray
    params: MatchParams
    path_cost: np.ndarray
    features: np.ndarray | None = None

    def __post_init__(self):
        # the matchers build these right; a result built by hand gets one clear error here
        # instead of a confusing one in fill, pairs, the writers or the previews
        d = self.disparity
        if not isinstance(d, np.ndarray) or d.dtype != np.float32 or d.ndim != 2:
            raise TypeError(f"disparity must be a float32 (H, W) array, got {_describe(d)}")
        f = self.flags
        if not isinstance(f, np.ndarray) or f.dtype != np.uint8 or f.shape != d.shape:
            raise TypeError(f"flags must be a uint8 array of shape {d.shape}, got {_describe(f)}")
        c = self.path_cost
        if not isinstance(c, np.ndarray) or c.dtype.kind != "f" or c.shape != d.shape[:1]:
            raise TypeError(
                f"path_cost must be a float array of shape {d.shape[:1]}, got {_describe(c)}"
            )
        m = self.features
        if m is not None and (
            not isinstance(m, np.ndarray) or m.dtype.kind != "f" or m.ndim != 2 or m.shape[1] != 5
        ):
            raise TypeError(f"features must be None or a float (M, 5) array, got {_describe(m)}")
        if not hasattr(self.params, "method"):
            kind = type(self.params).__name__
            raise TypeError(f"params must be the run's parameters (MatchParams), got {kind}")

    @property
    def method(self) -> str:
        """Name of the method that produced this result."""
        return self.params.method

    @property
    def occluded(self) -> np.ndarray:
        """Left pixels without a partner: occluded in the DP, or beyond the image border."""
        return (self.flags & (FLAG_OCCLUDED | FLAG_BORDER)) != 0

    @property
    def mismatched(self) -> np.ndarray:
        """Pixels whose estimate the left-right check removed as a wrong match (``sgm``)."""
        return (self.flags & FLAG_MISMATCH) != 0

    @property
    def valid(self) -> np.ndarray:
        """Pixels with a finite disparity."""
        return np.isfinite(self.disparity)

    def pairs(self) -> np.ndarray:
        """Integer matches as an (M, 3) int64 array of ``(row, x_left, x_right)``.

        Pixels filled in or holding a half-pixel disparity are not pairs.
        """
        d = self.disparity
        keep = np.isfinite(d) & ((self.flags & FLAG_FILLED) == 0)
        keep &= np.floor(np.where(keep, d, 0)) == np.where(keep, d, 0)
        rows, cols = np.nonzero(keep)
        return np.stack([rows, cols, cols - d[rows, cols].astype(np.int64)], axis=1)

    def unfilled(self) -> "DisparityResult":
        """Return a copy without the filled values: NaN where :data:`FLAG_FILLED` is set.

        The estimates the method made itself (the reasons of the others stay in the flags,
        and :data:`FLAG_FILLED` goes).
        """
        filled = (self.flags & FLAG_FILLED) != 0
        if not filled.any():
            return self
        disparity = np.where(filled, np.float32(np.nan), self.disparity).astype(np.float32)
        flags = (self.flags & ~np.uint8(FLAG_FILLED)).astype(np.uint8)
        return replace(self, disparity=disparity, flags=flags)

    def filled(self) -> "DisparityResult":
        """Return a copy with every pixel that has no estimate filled (see fill_occlusions)."""
        if not np.isnan(self.disparity).any():
            return self
        disparity, was_filled = fill_occlusions(self.disparity)
        flags = self.flags | np.where(was_filled, FLAG_FILLED, 0).astype(np.uint8)
        return replace(self, disparity=disparity, flags=flags)


def check_result_pair(result, left, right):
    """Check that ``result`` is a :class:`DisparityResult` and ``left``/``right`` its pair.

    For the functions that take a result and the images it came from; returns the
    images as :func:`~dcstereo.signal.check_pair` does.
    """
    if not isinstance(result, DisparityResult):
        raise TypeError(f"result must be a DisparityResult, got {type(result).__name__}")
    return check_pair(left, right, result.disparity.shape)


def _describe(value) -> str:
    """``float64 array of shape (2, 3)``, or the type of anything that is not an array."""
    if isinstance(value, np.ndarray):
        return f"{value.dtype} array of shape {value.shape}"
    return type(value).__name__


def fill_occlusions(disparity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fill NaN pixels with the background disparity along each scanline.

    A pixel without an estimate takes the *smaller* of the nearest finite disparities to
    its left and right on the same row (occluded pixels belong to the background, which
    has the smaller disparity); with an estimate on one side only, it takes that one.
    Rows without any estimate stay NaN.

    Parameters
    ----------
    disparity : ndarray, shape (H, W)
        Disparity with NaN where there is no estimate.

    Returns
    -------
    filled : ndarray of float32, shape (H, W)
    was_filled : ndarray of bool, shape (H, W)
        The pixels that received a value.
    """
    d = np.asarray(disparity)
    if d.dtype == bool or not (
        np.issubdtype(d.dtype, np.integer) or np.issubdtype(d.dtype, np.floating)
    ):
        raise TypeError(f"disparity must be an array of real numbers, got dtype {d.dtype}")
    if d.ndim != 2:
        raise ValueError(f"disparity must be a 2-D (H, W) array, got shape {d.shape}")
    d = d.astype(np.float32, copy=False)
    height, width = d.shape
    valid = np.isfinite(d)
    cols = np.broadcast_to(np.arange(width), d.shape)
    left_idx = np.maximum.accumulate(np.where(valid, cols, -1), axis=1)
    right_idx = np.minimum.accumulate(np.where(valid, cols, width)[:, ::-1], axis=1)[:, ::-1]
    left_val = np.take_along_axis(d, np.clip(left_idx, 0, width - 1), axis=1)
    right_val = np.take_along_axis(d, np.clip(right_idx, 0, width - 1), axis=1)
    left_val = np.where(left_idx >= 0, left_val, np.inf)
    right_val = np.where(right_idx < width, right_val, np.inf)
    background = np.minimum(left_val, right_val)
    was_filled = ~valid & np.isfinite(background)
    out = np.where(was_filled, background, d).astype(np.float32)
    return out, was_filled

"""From disparity to depth and 3-D points, for a rectified pair with a known calibration.

A left pixel ``(x, y)`` with disparity ``d`` (the Middlebury convention: it matches the
right pixel ``(x - d, y)``) lies at depth

    Z = baseline * focal / (d + doffs)

where ``doffs`` is the x-difference of the two cameras' principal points
(``cx_right - cx_left``, 0 when they agree), and at

    X = (x - cx) * Z / focal,    Y = (y - cy) * Z / focal_y

in the left camera's frame: X to the right, Y down, Z forward (OpenCV's convention). Depth
and points come in the unit of the baseline (millimetres for the Middlebury scenes). This
is the formula of the Middlebury 2014 data set (Scharstein et al., GCPR 2014), whose
``calib.txt`` :meth:`Calibration.from_middlebury` reads.
"""

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dcstereo._checks import disparity_array, is_number


@dataclass(frozen=True)
class Calibration:
    """The geometry of a rectified pair: focal length, baseline, principal point.

    Attributes
    ----------
    focal : float
        Focal length in pixels, along x (``fx``).
    baseline : float
        Distance between the two camera centres; depth comes in its unit.
    cx, cy : float
        Principal point of the left camera, in pixels (column, row; 0 is the first pixel's
        centre).
    doffs : float
        ``cx_right - cx_left`` in pixels: 0 for a pair rectified with one principal
        point, Middlebury's ``doffs`` otherwise.
    focal_y : float or None
        Focal length along y (``fy``); None: the same as ``focal``.
    """

    focal: float
    baseline: float
    cx: float
    cy: float
    doffs: float = 0.0
    focal_y: float | None = None

    def __post_init__(self):
        for name in ("focal", "baseline", "cx", "cy", "doffs", "focal_y"):
            value = getattr(self, name)
            if name == "focal_y" and value is None:
                continue
            if not is_number(value):
                raise TypeError(f"{name} must be a number, got {type(value).__name__}")
            if not np.isfinite(value):
                raise ValueError(f"{name} must be finite, got {value}")
            object.__setattr__(self, name, float(value))
        for name in ("focal", "baseline", "focal_y"):
            value = getattr(self, name)
            if value is not None and value <= 0:
                raise ValueError(f"{name} must be positive, got {value:g}")

    @property
    def fy(self) -> float:
        """Focal length along y: ``focal_y``, or ``focal`` when it is None."""
        return self.focal if self.focal_y is None else self.focal_y

    def reprojection_matrix(self) -> np.ndarray:
        """Return OpenCV's 4 x 4 reprojection matrix ``Q`` of this pair.

        The matrix ``cv2.stereoRectify`` returns for a rectified pair (its ``Q``), for
        ``cv2.reprojectImageTo3D(disparity, Q)``: it maps ``(x, y, d, 1)`` to the
        homogeneous point of :func:`point_cloud`, so the two agree (``Z = baseline *
        focal / (d + doffs)``)::

            [[1, 0, 0, -cx], [0, s, 0, -cy * s], [0, 0, 0, focal], [0, 0, 1 / baseline,
            doffs / baseline]]

        with ``s = focal / focal_y`` (1 for square pixels, OpenCV's case).

        Returns
        -------
        ndarray of float64, shape (4, 4)

        Examples
        --------
        >>> q = Calibration(focal=500, baseline=100, cx=320, cy=240).reprojection_matrix()
        >>> q[2].tolist(), q[3].tolist()
        ([0.0, 0.0, 0.0, 500.0], [0.0, 0.0, 0.01, 0.0])
        """
        s = self.focal / self.fy
        return np.array(
            [
                [1.0, 0.0, 0.0, -self.cx],
                [0.0, s, 0.0, -self.cy * s],
                [0.0, 0.0, 0.0, self.focal],
                [0.0, 0.0, 1.0 / self.baseline, self.doffs / self.baseline],
            ]
        )

    @classmethod
    def from_middlebury(cls, path: str | os.PathLike) -> "Calibration":
        """Read a Middlebury ``calib.txt`` (the 2014 and 2021 data sets' format).

        ``cam0=[f 0 cx; 0 fy cy; 0 0 1]`` gives the left camera, ``baseline`` the
        baseline (mm), and ``doffs`` the principal points' offset; without ``doffs`` it is
        taken from ``cam1``'s ``cx`` when given, else 0.

        Parameters
        ----------
        path : path-like
            The file.

        Raises
        ------
        ValueError
            If the file is missing or unreadable, or lacks ``cam0`` or ``baseline``, or a
            value is not a number; the message names the file and the entry.
        """
        entries = read_calib(path)
        for key in ("cam0", "baseline"):
            if key not in entries:
                raise ValueError(f"calibration '{path}' lacks '{key}='")
        calibration = cls.from_entries(entries, path)
        assert calibration is not None  # cam0 and baseline are there
        return calibration

    @classmethod
    def from_entries(cls, entries: dict, source) -> "Calibration | None":
        """Make the calibration of :func:`read_calib`'s entries (None: no ``cam0`` or ``baseline``).

        ``source`` names the file in the messages.
        """
        if "cam0" not in entries or "baseline" not in entries:
            return None
        cam0 = _camera_matrix(entries["cam0"], source, "cam0")
        baseline = _number(entries["baseline"], source, "baseline")
        if "doffs" in entries:
            doffs = _number(entries["doffs"], source, "doffs")
        elif "cam1" in entries:
            doffs = _camera_matrix(entries["cam1"], source, "cam1")[0, 2] - cam0[0, 2]
        else:
            doffs = 0.0
        try:
            return cls(
                focal=cam0[0, 0],
                baseline=baseline,
                cx=cam0[0, 2],
                cy=cam0[1, 2],
                doffs=doffs,
                focal_y=cam0[1, 1],
            )
        except ValueError as exc:
            raise ValueError(f"calibration '{source}': {exc}") from None


def read_calib(path: str | os.PathLike) -> dict[str, str]:
    """Read a Middlebury ``calib.txt`` (``key=value`` lines) into a dict of strings.

    Parameters
    ----------
    path : path-like
        The file.

    Returns
    -------
    dict of str to str

    Raises
    ------
    ValueError
        If the file is missing, a folder or not UTF-8 text.
    """
    path = Path(path)
    if not path.is_file():
        what = "it is not a regular file" if path.exists() else "file does not exist"
        raise ValueError(f"cannot read {path}: {what}")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"cannot read {path}: it is not UTF-8 text") from None
    except OSError as exc:
        raise ValueError(f"cannot read {path}: {exc.strerror}") from None
    entries = {}
    for line in text.splitlines():
        key, sep, value = line.partition("=")
        if sep:
            entries[key.strip()] = value.strip()
    return entries


def _number(text: str, path, key: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"calibration '{path}': {key} is not a number: {text!r}") from None
    if not np.isfinite(value):
        raise ValueError(f"calibration '{path}': {key} must be finite, got {text!r}")
    return value


def _camera_matrix(text: str, path, key: str) -> np.ndarray:
    """Parse the 3 x 3 matrix ``[a b c; d e f; g h i]``."""
    body = text.strip()
    if not (body.startswith("[") and body.endswith("]")):
        raise ValueError(f"calibration '{path}': {key} must be a matrix [a b c; d e f; g h i]")
    rows = [row.split() for row in body[1:-1].split(";")]
    if len(rows) != 3 or any(len(row) != 3 for row in rows):
        raise ValueError(f"calibration '{path}': {key} must be a 3 x 3 matrix, got {text!r}")
    return np.array([[_number(v, path, key) for v in row] for row in rows])


@dataclass(frozen=True)
class PointCloud:
    """Points of the left camera's frame, one per pixel with a depth.

    Attributes
    ----------
    points : ndarray of float32, shape (N, 3)
        ``(X, Y, Z)``: X right, Y down, Z forward, in the unit of the baseline.
    colors : ndarray of uint8, shape (N, 3), or None
        The left image's colour of each point (gray repeated), when an image was given.
    pixels : ndarray of int64, shape (N, 2)
        The ``(row, column)`` of each point's left pixel; the points are in row-major
        order of their pixels.
    """

    points: np.ndarray
    colors: np.ndarray | None
    pixels: np.ndarray

    def __len__(self) -> int:
        return len(self.points)


def _check_calibration(calibration) -> None:
    if not isinstance(calibration, Calibration):
        raise TypeError(
            f"calibration must be a dcstereo.geometry.Calibration, got {type(calibration).__name__}"
        )


def depth(disparity, calibration: Calibration) -> np.ndarray:
    """Depth of every left pixel: ``baseline * focal / (d + doffs)``.

    Parameters
    ----------
    disparity : array_like, shape (H, W)
        Disparity in pixels, NaN where there is no estimate (a
        :attr:`DisparityResult.disparity`, filled or not).
    calibration : Calibration
        The pair's geometry.

    Returns
    -------
    ndarray of float32, shape (H, W)
        Depth in the unit of the baseline; NaN where the disparity is not finite or
        ``d + doffs <= 0`` (a point at or beyond infinity) or the depth is beyond
        float32's range.
    """
    with np.errstate(over="ignore"):
        z = _depth64(disparity, calibration).astype(np.float32)
    z[~np.isfinite(z)] = np.nan  # beyond float32's range: at infinity too
    return z


def _depth64(disparity, calibration: Calibration) -> np.ndarray:
    """:func:`depth` in float64, NaN where there is none."""
    _check_calibration(calibration)
    d = disparity_array(disparity) + calibration.doffs
    z = np.full(d.shape, np.nan)
    with np.errstate(over="ignore"):
        numerator = calibration.baseline * calibration.focal
        np.divide(numerator, d, out=z, where=np.isfinite(d) & (d > 0))
    z[~np.isfinite(z)] = np.nan
    return z


def _colors(image, shape) -> np.ndarray:
    """Return the image as uint8 RGB, ``(H, W, 3)``; 16-bit images keep their high byte."""
    image = np.asarray(image)
    if image.shape[:2] != shape or not (
        image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)
    ):
        raise ValueError(
            f"image must have shape {shape} or {(*shape, 3)} to colour the points, "
            f"got {image.shape}"
        )
    if image.dtype == np.uint16:
        image = (image >> 8).astype(np.uint8)
    elif image.dtype != np.uint8:
        raise TypeError(f"image must be uint8 or uint16 to colour the points, got {image.dtype}")
    if image.ndim == 2:
        image = np.repeat(image[:, :, None], 3, axis=2)
    return image


def point_cloud(
    disparity,
    calibration: Calibration,
    image=None,
    *,
    mask=None,
    max_depth: float | None = None,
) -> PointCloud:
    """Return the 3-D point of every left pixel with a depth (:func:`depth`).

    Parameters
    ----------
    disparity : array_like, shape (H, W)
        Disparity in pixels, NaN where there is no estimate.
    calibration : Calibration
        The pair's geometry.
    image : ndarray, shape (H, W) or (H, W, 3), optional
        The left image (uint8, or uint16 whose high byte is kept): the points' colours.
    mask : ndarray of bool, shape (H, W), optional
        Only these pixels (for example ``~result.occluded``).
    max_depth : float, optional
        Leave out points farther than this (in the unit of the baseline).

    Returns
    -------
    PointCloud
    """
    z = _depth64(disparity, calibration)
    keep = np.isfinite(z) & (z <= np.finfo(np.float32).max)
    if mask is not None:
        mask = np.asarray(mask)
        if mask.dtype != np.bool_ or mask.shape != z.shape:
            raise ValueError(
                f"mask must be a bool array of shape {z.shape}, got {mask.dtype} {mask.shape}"
            )
        keep &= mask
    if max_depth is not None:
        if not is_number(max_depth) or not max_depth > 0:
            raise ValueError(f"max_depth must be a positive number, got {max_depth!r}")
        keep &= z <= max_depth
    colors = None if image is None else _colors(image, z.shape)[keep]
    # written into the outputs with one float64 scratch column: on a 6-megapixel map the
    # peak is 288 MB (576 MB with a new column per step), 186 MB of it the result
    zk = z[keep]
    del z
    pixels = np.argwhere(keep).astype(np.int64, copy=False).reshape(-1, 2)
    points = np.empty((len(zk), 3), dtype=np.float32)
    scratch = np.empty(len(zk))
    for axis, centre, focal in (
        (1, calibration.cx, calibration.focal),
        (0, calibration.cy, calibration.fy),
    ):
        np.subtract(pixels[:, axis], centre, out=scratch)
        scratch *= zk
        scratch /= focal
        points[:, 1 - axis] = scratch
    points[:, 2] = zk
    return PointCloud(points=points, colors=colors, pixels=pixels)

"""From a two-camera calibration to a rectified pair that :func:`dcstereo.match` can use.

:func:`rectify` takes the two images as the cameras took them and the calibration that
``cv2.stereoCalibrate`` gives (:class:`StereoCalibration`: ``K1, D1, K2, D2, R, T``), and
returns the rectified pair, the rectified geometry (a :class:`dcstereo.geometry.Calibration`,
so depth and point clouds come out metric) and the pixels that hold image content.
OpenCV does the work (``cv2.stereoRectify``, ``cv2.initUndistortRectifyMap``,
``cv2.remap``): it is the ``opencv`` extra, ``pip install "dcstereo[opencv]"``.

Conventions, as :func:`read_calibration` reads a file and :func:`rectify` applies it:

- camera 1 (``K1``, ``D1``) took the LEFT image, camera 2 the RIGHT one;
- ``R`` and ``T`` take a point from camera 1's frame to camera 2's,
  ``X2 = R @ X1 + T`` (OpenCV's), so for a left-right rig camera 2 sits at
  ``-R.T @ T``, to the right of camera 1: ``T[0] < 0``. A calibration with ``T[0] > 0``
  has its cameras the other way round and is refused (swap the images and use
  :meth:`StereoCalibration.swapped`);
- the rig is horizontal: ``|T[0]| > |T[1]|``. A vertical rig (cameras one above the
  other) is refused: dcstereo matches along rows, so rotate both images by 90 degrees and
  calibrate them so, or rectify with OpenCV yourself;
- the rectified calibration's ``baseline`` is ``|T|`` in ``T``'s unit (the calibration
  target's: millimetres for a target measured in mm), positive; both rectified cameras
  share one principal point (OpenCV's ``CALIB_ZERO_DISPARITY``), so ``doffs = 0`` and a
  point at infinity has disparity 0;
- ``alpha`` is ``cv2.stereoRectify``'s: 0 crops the rectified images to pixels that all
  hold image content (the default: no black border to match), 1 keeps every source pixel
  (black corners), between scales between the two.

A Middlebury ``calib.txt`` describes a pair that is already rectified: :func:`rectify`
then returns the images as they are, with that calibration and every pixel valid (after
checking the image size against the file's ``width`` and ``height`` when it gives them).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dcstereo.geometry import Calibration, read_calib

#: The ``pip`` extra that brings OpenCV.
OPENCV_EXTRA = 'pip install "dcstereo[opencv]"'

#: Key spellings read from an OpenCV FileStorage file, for each part of the calibration.
#: ``M1``/``M2`` are what OpenCV's ``stereo_calib`` sample writes (intrinsics.yml).
KEY_SPELLINGS: dict[str, tuple[str, ...]] = {
    "K1": ("K1", "M1", "cameraMatrix1", "camera_matrix_1", "camera_matrix_left", "left_K"),
    "D1": ("D1", "distCoeffs1", "dist_coeffs_1", "distortion_coefficients_left", "left_D"),
    "K2": ("K2", "M2", "cameraMatrix2", "camera_matrix_2", "camera_matrix_right", "right_K"),
    "D2": ("D2", "distCoeffs2", "dist_coeffs_2", "distortion_coefficients_right", "right_D"),
    "R": ("R", "rotation", "R_stereo"),
    "T": ("T", "translation", "T_stereo"),
}

#: Key spellings of the image size: one entry ``[width, height]`` or two numbers.
SIZE_KEYS = ("image_size", "imageSize", "size", "img_size")
WIDTH_KEYS = ("image_width", "imageWidth", "width")
HEIGHT_KEYS = ("image_height", "imageHeight", "height")

#: Numbers of distortion coefficients OpenCV accepts.
DISTORTION_LENGTHS = (0, 4, 5, 8, 12, 14)


def import_cv2() -> Any:
    """Import OpenCV, or raise ImportError in one line naming the extra."""
    try:
        import cv2
    except ImportError:
        raise ImportError(
            f"rectification needs OpenCV, which is not installed: {OPENCV_EXTRA}"
        ) from None
    return cv2


@dataclass(frozen=True, eq=False)
class StereoCalibration:
    """Two cameras as ``cv2.stereoCalibrate`` describes them (not yet rectified).

    Attributes
    ----------
    K1, K2 : ndarray of float64, shape (3, 3)
        Camera matrices of the left (1) and right (2) camera, in pixels.
    D1, D2 : ndarray of float64, shape (N,)
        Distortion coefficients (OpenCV's order ``k1, k2, p1, p2[, k3, ...]``), N one of
        0, 4, 5, 8, 12, 14.
    R : ndarray of float64, shape (3, 3)
        Rotation from camera 1's frame to camera 2's.
    T : ndarray of float64, shape (3,)
        Translation from camera 1's frame to camera 2's (``X2 = R @ X1 + T``), in the
        unit depth should have.
    image_size : tuple of int or None
        ``(width, height)`` of the images the calibration was made with; None when the
        file does not say (the images' own size is then taken).
    source : str
        Where it was read from, for messages.

    Raises
    ------
    ValueError
        On a wrong shape, a non-finite value, a camera matrix that cannot be inverted, a
        ``R`` that is not a rotation, or a zero ``T``; the message names the entry.
    """

    K1: np.ndarray = field(repr=False)
    D1: np.ndarray = field(repr=False)
    K2: np.ndarray = field(repr=False)
    D2: np.ndarray = field(repr=False)
    R: np.ndarray = field(repr=False)
    T: np.ndarray
    image_size: tuple[int, int] | None = None
    source: str = "calibration"

    def __post_init__(self) -> None:
        where = self.source
        for name in ("K1", "K2"):
            matrix = _real(getattr(self, name), where, name)
            if matrix.shape != (3, 3):
                raise ValueError(f"{where}: {name} must be a 3x3 matrix, got shape {matrix.shape}")
            if abs(np.linalg.det(matrix)) < 1e-9 or matrix[0, 0] <= 0 or matrix[1, 1] <= 0:
                raise ValueError(
                    f"{where}: {name} cannot be inverted or has a focal length that is not "
                    f"positive ({matrix[0, 0]:g}, {matrix[1, 1]:g})"
                )
            object.__setattr__(self, name, matrix)
        for name in ("D1", "D2"):
            coefficients = _real(getattr(self, name), where, name).ravel()
            if coefficients.size not in DISTORTION_LENGTHS:
                raise ValueError(
                    f"{where}: {name} must hold 4, 5, 8, 12 or 14 distortion coefficients, got "
                    f"{coefficients.size}"
                )
            object.__setattr__(self, name, coefficients)
        rotation = _real(self.R, where, "R")
        if rotation.size == 3:  # a Rodrigues vector
            rotation = import_cv2().Rodrigues(rotation.reshape(3, 1))[0]
        if rotation.shape != (3, 3):
            raise ValueError(
                f"{where}: R must be a 3x3 rotation (or a 3-vector), got shape {rotation.shape}"
            )
        if (
            not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-4)
            or np.linalg.det(rotation) < 0
        ):
            raise ValueError(f"{where}: R is not a rotation matrix (R R^T != I or det(R) < 0)")
        object.__setattr__(self, "R", rotation)
        translation = _real(self.T, where, "T").ravel()
        if translation.size != 3:
            raise ValueError(f"{where}: T must hold 3 numbers, got {translation.size}")
        if not np.linalg.norm(translation) > 0:
            raise ValueError(f"{where}: T is zero: the two cameras are at one place")
        object.__setattr__(self, "T", translation)
        if self.image_size is not None:
            width, height = (int(v) for v in self.image_size)
            if width < 1 or height < 1:
                raise ValueError(f"{where}: image size must be positive, got {self.image_size}")
            object.__setattr__(self, "image_size", (width, height))

    @property
    def baseline(self) -> float:
        """Distance between the camera centres, ``|T|``, in ``T``'s unit."""
        return float(np.linalg.norm(self.T))

    def swapped(self) -> StereoCalibration:
        """Return the same rig with the cameras' roles exchanged (camera 2 becomes camera 1).

        For a calibration made with the right images passed first (``T[0] > 0``): rectify
        ``(right, left)`` with the swapped calibration.
        """
        return StereoCalibration(
            K1=self.K2,
            D1=self.D2,
            K2=self.K1,
            D2=self.D1,
            R=self.R.T,
            T=-self.R.T @ self.T,
            image_size=self.image_size,
            source=f"{self.source} (swapped)",
        )


def _real(value: Any, where: str, name: str) -> np.ndarray:
    try:
        array = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: {name} must hold numbers") from None
    if not np.isfinite(array).all():
        raise ValueError(f"{where}: {name} holds a value that is not finite")
    return array


@dataclass(frozen=True, eq=False)
class RectifiedPair:
    """A rectified pair and its geometry, from :func:`rectify`.

    Attributes
    ----------
    left, right : ndarray, shape (H, W) or (H, W, C)
        The rectified images, of the input's dtype; pixels without content are 0.
    calibration : Calibration
        Geometry of the rectified pair (focal length and principal point in pixels,
        baseline in ``T``'s unit, ``doffs`` 0): pass it to :func:`dcstereo.geometry.depth`
        and :func:`~dcstereo.geometry.point_cloud`.
    valid : ndarray of bool, shape (H, W)
        The left rectified pixels that come from inside the left image.
    right_valid : ndarray of bool, shape (H, W)
        The same for the right image.
    roi : tuple of int
        ``(x, y, width, height)``: the largest rectangle of the left image that holds
        content only (``cv2.stereoRectify``'s ``validPixROI1``; the whole image for an
        already rectified pair).
    R1, R2, P1, P2, Q : ndarray or None
        ``cv2.stereoRectify``'s outputs (None for an already rectified pair).
    """

    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)
    calibration: Calibration
    valid: np.ndarray = field(repr=False)
    right_valid: np.ndarray = field(repr=False)
    roi: tuple[int, int, int, int]
    R1: np.ndarray | None = field(default=None, repr=False)
    R2: np.ndarray | None = field(default=None, repr=False)
    P1: np.ndarray | None = field(default=None, repr=False)
    P2: np.ndarray | None = field(default=None, repr=False)
    Q: np.ndarray | None = field(default=None, repr=False)


# --- reading ----------------------------------------------------------------------------


def read_calibration(*paths: str | os.PathLike) -> StereoCalibration | Calibration:
    """Read a stereo calibration: OpenCV FileStorage (YAML/XML/JSON) or Middlebury calib.txt.

    Parameters
    ----------
    *paths : path-like
        One file, or several whose entries are merged (OpenCV's ``stereo_calib`` sample
        writes ``intrinsics.yml`` with ``M1 D1 M2 D2`` and ``extrinsics.yml`` with ``R T``).
        A ``.txt`` file is read as Middlebury's ``calib.txt`` (a pair already rectified).

    Returns
    -------
    StereoCalibration or Calibration
        A :class:`StereoCalibration` for OpenCV files (keys in :data:`KEY_SPELLINGS`; the
        image size from ``image_size`` = ``[width, height]`` or ``image_width`` and
        ``image_height``, when given), a :class:`~dcstereo.geometry.Calibration` for a
        ``calib.txt``.

    Raises
    ------
    ValueError
        A missing or unreadable file, a missing entry (the message names it and the
        spellings looked for), a wrong shape, a camera matrix that cannot be inverted.
    ImportError
        For a FileStorage file when OpenCV is not installed (the message names the extra).

    Examples
    --------
    A file as ``cv2.FileStorage`` writes it::

        %YAML:1.0
        ---
        image_size: [640, 480]
        K1: !!opencv-matrix
           rows: 3
           cols: 3
           dt: d
           data: [500., 0., 319.5, 0., 500., 239.5, 0., 0., 1.]
        D1: !!opencv-matrix {rows: 1, cols: 5, dt: d, data: [-0.1, 0.01, 0., 0., 0.]}
        K2: ...
        D2: ...
        R: ...
        T: !!opencv-matrix {rows: 3, cols: 1, dt: d, data: [-60., 0., 0.]}

    >>> calibration = read_calibration("stereo.yml")  # doctest: +SKIP
    >>> calibration.baseline  # doctest: +SKIP
    60.0
    """
    if not paths:
        raise ValueError("read_calibration needs at least one file")
    files = [Path(p) for p in paths]
    for path in files:
        if not path.is_file():
            what = "it is not a regular file" if path.exists() else "file does not exist"
            raise ValueError(f"cannot read calibration {path}: {what}")
    if any(path.suffix.lower() == ".txt" for path in files):
        if len(files) != 1:
            raise ValueError("a Middlebury calib.txt is read alone, not merged with other files")
        return _read_middlebury(files[0])
    entries: dict[str, Any] = {}
    for path in files:
        entries.update(_read_filestorage(path))
    return _from_entries(entries, ", ".join(str(p) for p in files))


def _read_middlebury(path: Path) -> Calibration:
    entries = read_calib(path)
    missing = [key for key in ("cam0", "baseline") if key not in entries]
    if missing:
        raise ValueError(f"calibration {path} lacks {', '.join(k + '=' for k in missing)}")
    calibration = Calibration.from_entries(entries, path)
    assert calibration is not None
    return calibration


def middlebury_size(path: str | os.PathLike) -> tuple[int, int] | None:
    """``(width, height)`` that a Middlebury ``calib.txt`` gives, or None when it gives none."""
    entries = read_calib(path)
    if "width" not in entries or "height" not in entries:
        return None
    try:
        return int(float(entries["width"])), int(float(entries["height"]))
    except ValueError:
        raise ValueError(f"calibration {path}: width and height must be numbers") from None


def _read_filestorage(path: Path) -> dict[str, Any]:
    """Every top-level entry of a FileStorage file: matrices as arrays, numbers, lists."""
    cv2 = import_cv2()
    try:
        storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError):  # OpenCV's parser errors come as either
        storage = None
    if storage is None or not storage.isOpened():
        raise ValueError(
            f"cannot read calibration {path}: not an OpenCV FileStorage file (YAML, XML or "
            "JSON as cv2.FileStorage writes it) or a Middlebury calib.txt"
        )
    try:
        root = storage.root()
        return {str(key): _node_value(root.getNode(key)) for key in root.keys()}
    finally:
        storage.release()


def _node_value(node: Any) -> Any:
    if node.isSeq():
        return [_node_value(node.at(i)) for i in range(node.size())]
    if node.isMap():
        matrix = node.mat()
        if matrix is not None:
            return np.asarray(matrix, dtype=np.float64)
        return {str(key): _node_value(node.getNode(key)) for key in node.keys()}
    if node.isInt() or node.isReal():
        return node.real()
    if node.isString():
        return node.string()
    return None


def _from_entries(entries: Mapping[str, Any], source: str) -> StereoCalibration:
    found: dict[str, Any] = {}
    for name, spellings in KEY_SPELLINGS.items():
        key = next((k for k in spellings if k in entries), None)
        if key is None:
            raise ValueError(
                f"calibration {source} lacks {name} (looked for {', '.join(spellings)})"
            )
        found[name] = entries[key]
    return StereoCalibration(**found, image_size=_image_size(entries, source), source=source)


def _image_size(entries: Mapping[str, Any], source: str) -> tuple[int, int] | None:
    size_key = next((k for k in SIZE_KEYS if k in entries), None)
    if size_key is not None:
        values = np.asarray(entries[size_key], dtype=np.float64).ravel()
        if values.size != 2:
            raise ValueError(
                f"calibration {source}: {size_key} must be [width, height], got "
                f"{values.size} numbers"
            )
        return int(values[0]), int(values[1])
    width = next((k for k in WIDTH_KEYS if k in entries), None)
    height = next((k for k in HEIGHT_KEYS if k in entries), None)
    if width is None or height is None:
        return None
    try:
        return int(float(entries[width])), int(float(entries[height]))
    except (TypeError, ValueError):
        raise ValueError(f"calibration {source}: {width} and {height} must be numbers") from None


# --- writing ----------------------------------------------------------------------------


def write_middlebury_calib(
    path: str | os.PathLike,
    calibration: Calibration,
    size: tuple[int, int],
    *,
    ndisp: int | None = None,
) -> None:
    """Write a rectified calibration as Middlebury's ``calib.txt``, atomically.

    The file that ``dcstereo run --calib`` and
    :meth:`dcstereo.geometry.Calibration.from_middlebury` read: ``cam0``, ``cam1``
    (``cx + doffs``), ``doffs``, ``baseline``, ``width``, ``height`` (and ``ndisp`` when
    given).

    Parameters
    ----------
    path : path-like
        Output file.
    calibration : Calibration
        The rectified geometry.
    size : tuple of int
        ``(width, height)`` of the rectified images.
    ndisp : int, optional
        Exclusive disparity bound to record.
    """
    from dcstereo.io import atomic_write

    c = calibration
    lines = [
        f"cam0=[{c.focal:.6f} 0 {c.cx:.6f}; 0 {c.fy:.6f} {c.cy:.6f}; 0 0 1]",
        f"cam1=[{c.focal:.6f} 0 {c.cx + c.doffs:.6f}; 0 {c.fy:.6f} {c.cy:.6f}; 0 0 1]",
        f"doffs={c.doffs:.6f}",
        f"baseline={c.baseline:.6f}",
        f"width={int(size[0])}",
        f"height={int(size[1])}",
    ]
    if ndisp is not None:
        lines.append(f"ndisp={int(ndisp)}")
    with atomic_write(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")


# --- rectifying -------------------------------------------------------------------------


def _check_images(left: np.ndarray, right: np.ndarray) -> tuple[int, int]:
    for name, image in (("left", left), ("right", right)):
        if image.ndim not in (2, 3) or image.size == 0:
            raise ValueError(
                f"{name} must be an image of shape (H, W) or (H, W, C), got {image.shape}"
            )
    if left.shape[:2] != right.shape[:2]:
        raise ValueError(
            f"left and right images differ in size: {left.shape[1]}x{left.shape[0]} and "
            f"{right.shape[1]}x{right.shape[0]}"
        )
    return left.shape[1], left.shape[0]


def rectify(
    left: np.ndarray,
    right: np.ndarray,
    calibration: StereoCalibration | Calibration | str | os.PathLike,
    *,
    alpha: float = 0.0,
    interpolation: str = "linear",
) -> RectifiedPair:
    """Rectify a pair so that a left pixel ``(x, y)`` matches the right pixel ``(x - d, y)``.

    Parameters
    ----------
    left, right : ndarray, shape (H, W) or (H, W, C)
        The images of camera 1 (left) and camera 2 (right), as taken; any dtype
        ``cv2.remap`` takes (uint8, uint16, float32).
    calibration : StereoCalibration, Calibration or path-like
        The rig (see the module's conventions), or a file for :func:`read_calibration`.
        A :class:`~dcstereo.geometry.Calibration` (or a Middlebury ``calib.txt``) means the
        pair is rectified already: the images come back unchanged.
    alpha : float
        ``cv2.stereoRectify``'s free scaling, 0 to 1: 0 keeps only pixels with content
        (default), 1 keeps every source pixel.
    interpolation : {"linear", "cubic", "nearest"}
        How ``cv2.remap`` resamples.

    Returns
    -------
    RectifiedPair

    Raises
    ------
    ValueError
        Images of different sizes, or of a size other than the calibration's; a vertical
        rig; cameras in the wrong order (``T[0] > 0``); ``alpha`` outside 0..1; an invalid
        calibration (see :class:`StereoCalibration`).
    ImportError
        When OpenCV is not installed (one line naming the extra).

    Examples
    --------
    >>> pair = rectify(left, right, "stereo.yml")  # doctest: +SKIP
    >>> result = dcstereo.match(pair.left, pair.right, max_disparity=64)  # doctest: +SKIP
    >>> z = dcstereo.geometry.depth(result.disparity, pair.calibration)  # doctest: +SKIP
    """
    left = np.asarray(left)
    right = np.asarray(right)
    size = _check_images(left, right)
    if isinstance(calibration, (str, os.PathLike)):
        path = calibration
        calibration = read_calibration(path)
        if isinstance(calibration, Calibration):
            expected = middlebury_size(path)
            if expected is not None and expected != size:
                raise ValueError(
                    f"calibration {path} is for {expected[0]}x{expected[1]} images but the "
                    f"pair is {size[0]}x{size[1]}"
                )
    if isinstance(calibration, Calibration):
        everywhere = np.ones((size[1], size[0]), dtype=bool)
        return RectifiedPair(
            left=left,
            right=right,
            calibration=calibration,
            valid=everywhere,
            right_valid=everywhere.copy(),
            roi=(0, 0, size[0], size[1]),
        )
    if not isinstance(calibration, StereoCalibration):
        raise TypeError(
            "calibration must be a StereoCalibration, a Calibration or a file path, got "
            f"{type(calibration).__name__}"
        )
    if not (isinstance(alpha, (int, float)) and 0.0 <= float(alpha) <= 1.0):
        raise ValueError(f"alpha must be a number from 0 to 1, got {alpha!r}")
    cv2 = import_cv2()
    modes = {"linear": cv2.INTER_LINEAR, "cubic": cv2.INTER_CUBIC, "nearest": cv2.INTER_NEAREST}
    if interpolation not in modes:
        raise ValueError(f"interpolation must be one of {', '.join(modes)}, got {interpolation!r}")
    check_rig(calibration, size)

    R1, R2, P1, P2, Q, roi1, _ = cv2.stereoRectify(
        calibration.K1,
        calibration.D1.reshape(1, -1),
        calibration.K2,
        calibration.D2.reshape(1, -1),
        size,
        calibration.R,
        calibration.T.reshape(3, 1),
        flags=cv2.CALIB_ZERO_DISPARITY,
        alpha=float(alpha),
    )
    if abs(P2[1, 3]) > abs(P2[0, 3]):  # stereoRectify chose a vertical layout
        raise ValueError(f"{calibration.source}: vertical rig (see dcstereo.rectify's notes)")
    out_left, valid = _remap(
        cv2, left, calibration.K1, calibration.D1, R1, P1, size, modes, interpolation
    )
    out_right, right_valid = _remap(
        cv2, right, calibration.K2, calibration.D2, R2, P2, size, modes, interpolation
    )
    rectified = Calibration(
        focal=P1[0, 0],
        baseline=-P2[0, 3] / P2[0, 0],
        cx=P1[0, 2],
        cy=P1[1, 2],
        doffs=P2[0, 2] - P1[0, 2],
        focal_y=P1[1, 1],
    )
    return RectifiedPair(
        left=out_left,
        right=out_right,
        calibration=rectified,
        valid=valid,
        right_valid=right_valid,
        roi=tuple(int(v) for v in roi1),  # type: ignore[arg-type]
        R1=R1,
        R2=R2,
        P1=P1,
        P2=P2,
        Q=Q,
    )


def check_rig(calibration: StereoCalibration, size: tuple[int, int]) -> None:
    """Refuse (ValueError) what :func:`rectify` cannot do with ``calibration`` and ``size``.

    The image size must be the calibration's (when it records one), the rig horizontal
    (``|T[0]| > |T[1]|``) and camera 1 the left one (``T[0] < 0``).
    """
    where = calibration.source
    if calibration.image_size is not None and tuple(calibration.image_size) != tuple(size):
        w, h = calibration.image_size
        raise ValueError(
            f"calibration {where} is for {w}x{h} images but the pair is {size[0]}x{size[1]}"
        )
    tx, ty = calibration.T[0], calibration.T[1]
    if abs(ty) >= abs(tx):
        raise ValueError(
            f"calibration {where} is of a vertical rig (|T[1]| = {abs(ty):g} >= |T[0]| = "
            f"{abs(tx):g}): dcstereo matches along rows; rotate both images by 90 degrees and "
            "calibrate them so"
        )
    if tx > 0:
        raise ValueError(
            f"calibration {where} has camera 1 to the right of camera 2 (T[0] = {tx:g} > 0): "
            "pass the images the other way round with StereoCalibration.swapped()"
        )


def _remap(
    cv2: Any,
    image: np.ndarray,
    K: np.ndarray,
    D: np.ndarray,
    R: np.ndarray,
    P: np.ndarray,
    size: tuple[int, int],
    modes: dict[str, int],
    interpolation: str,
) -> tuple[np.ndarray, np.ndarray]:
    map_x, map_y = cv2.initUndistortRectifyMap(K, D.reshape(1, -1), R, P, size, cv2.CV_32FC1)
    out = cv2.remap(
        image, map_x, map_y, modes[interpolation], borderMode=cv2.BORDER_CONSTANT, borderValue=0
    )
    # a pixel holds content when its source lies inside the image (pixel centres 0..W-1)
    width, height = size
    valid = (map_x >= 0) & (map_x <= width - 1) & (map_y >= 0) & (map_y <= height - 1)
    return out, valid

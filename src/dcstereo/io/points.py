"""Point clouds (binary PLY) and feature pairs (CSV): written atomically, read back."""

import os
import warnings
from pathlib import Path

import numpy as np

from dcstereo.io._atomic import atomic_write
from dcstereo.io._paths import _as_real_array, _check_readable

#: Bytes of the PLY property types :func:`write_ply` and :func:`is_complete` know.
_PLY_SIZES = {"char": 1, "uchar": 1, "short": 2, "ushort": 2, "int": 4, "uint": 4,
              "float": 4, "double": 8}  # fmt: skip


def _ply_complete(path: Path) -> bool:
    """Whether ``path`` is a binary PLY of one vertex element, exactly as long as it says."""
    with open(path, "rb") as f:
        head = f.read(4096)
    end = head.find(b"end_header\n")
    if not head.startswith(b"ply\n") or end < 0:
        return False
    lines = head[:end].decode("ascii").splitlines()
    if "format binary_little_endian 1.0" not in lines:
        return False
    elements = [line.split() for line in lines if line.startswith("element ")]
    if len(elements) != 1 or elements[0][1] != "vertex":
        return False
    count = int(elements[0][2])
    sizes = [_PLY_SIZES[line.split()[1]] for line in lines if line.startswith("property ")]
    return path.stat().st_size == end + len(b"end_header\n") + count * sum(sizes)


def write_ply(path: str | os.PathLike, points: np.ndarray, colors: np.ndarray | None = None):
    """Write a point cloud as a binary little-endian PLY file, atomically.

    The vertices have ``float x, y, z`` and, with ``colors``, ``uchar red, green, blue``:
    the layout MeshLab, CloudCompare, Open3D and PCL read.

    Parameters
    ----------
    path : str or os.PathLike
        Output file (``.ply``).
    points : ndarray, shape (N, 3)
        Finite real coordinates, written as float32 (N may be 0).
    colors : ndarray of uint8, shape (N, 3), optional
        One RGB colour per point.
    """
    points = _as_real_array(points, "points")
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {points.shape}")
    with np.errstate(over="ignore", invalid="ignore"):
        values = points.astype("<f4")
    if not np.isfinite(values).all():
        raise ValueError("points must be finite (as float32) to be written to a PLY file")
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if colors is not None:
        colors = np.asarray(colors)
        if colors.dtype != np.uint8:
            raise TypeError(f"colors must be uint8, got dtype {colors.dtype}")
        if colors.shape != points.shape:
            raise ValueError(f"colors must have shape {points.shape}, got {colors.shape}")
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    vertices = np.empty(len(values), dtype=fields)
    for axis, name in enumerate("xyz"):
        vertices[name] = values[:, axis]
    if colors is not None:
        for channel, name in enumerate(("red", "green", "blue")):
            vertices[name] = colors[:, channel]
    types = {"<f4": "float", "u1": "uchar"}
    header = (
        ["ply", "format binary_little_endian 1.0", "comment written by dcstereo"]
        + [f"element vertex {len(vertices)}"]
        + [f"property {types[kind]} {name}" for name, kind in fields]
        + ["end_header"]
    )
    with atomic_write(path) as tmp:
        tmp.write_bytes(("\n".join(header) + "\n").encode("ascii") + vertices.tobytes())


def write_features_csv(path: str | os.PathLike, features: np.ndarray) -> None:
    """Write feature pairs as CSV with the header ``row,x_left,x_right,ser,vs``, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Output file.
    features : ndarray, shape (M, 5)
        ``(row, x_left, x_right, SER, VS)`` as in :attr:`DisparityResult.features`;
        an infinite SER (a perfect match) is written as ``inf``.
    """
    try:
        table = np.asarray(features, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError("features must hold numbers") from None
    if table.ndim != 2 or table.shape[1] != 5:
        raise ValueError(f"features must have shape (M, 5), got {table.shape}")
    pixels = table[:, :3]
    bad = ~(np.isfinite(pixels) & (pixels == np.rint(pixels))).all(axis=1)
    if bad.any():
        index = int(np.argmax(bad))
        raise ValueError(
            f"feature {index}: row, x_left and x_right must be finite integers, got "
            f"{', '.join(f'{v:g}' for v in pixels[index])}"
        )
    lines = ["row,x_left,x_right,ser,vs"]
    for row, x_left, x_right, ser, vs in table:
        lines.append(f"{int(row)},{int(x_left)},{int(x_right)},{ser:.6g},{vs:.6g}")
    with atomic_write(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n", encoding="ascii")


def read_features_csv(path: str | os.PathLike) -> np.ndarray:
    """Read a file written by :func:`write_features_csv` back as an (M, 5) float64 array."""
    _check_readable(path, "features")
    try:
        with warnings.catch_warnings():
            # a header alone is what write_features_csv writes for no features
            warnings.filterwarnings("ignore", "loadtxt: input contained no data", UserWarning)
            table = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, dtype=np.float64)
    except ValueError as exc:
        raise ValueError(f"cannot read features '{path}': {exc}") from None
    if table.size == 0:
        return np.empty((0, 5))
    if table.shape[1] != 5:
        raise ValueError(f"cannot read features '{path}': expected 5 columns")
    return table

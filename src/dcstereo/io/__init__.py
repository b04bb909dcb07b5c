"""Read and write images and disparity maps; every write is atomic.

Disparity files follow two conventions:

- PFM (Middlebury): float32 disparities in pixels, ``+inf`` where there is no estimate.
- 16-bit PNG (KITTI style): ``round(d * scale)`` with ``scale=256`` by default, ``0`` where
  there is no estimate.

In memory a disparity map is float32 (H, W) with NaN where there is no estimate.

Depth maps (:mod:`dcstereo.geometry`) are written the same two ways: PFM (float32, in the
baseline's unit, ``+inf`` where there is no depth) or 16-bit PNG (``round(z * scale)``,
``scale=1`` by default: millimetres for a baseline in millimetres, the RGB-D convention;
``0`` where there is no depth).

The readers refuse an image of more than :data:`MAX_PIXELS` pixels (100 million) with a
one-line ``ValueError`` that says how to raise the limit: the readers' ``max_pixels``
argument, or the environment variable ``DCSTEREO_MAX_PIXELS`` (every command reads it).
Pillow's own warnings (its decompression-bomb warning, ``Corrupt EXIF data``...) and its
decompression-bomb error are set aside while dcstereo decodes: a damaged file is one error
line, the pixel limit replaces Pillow's, and no warning text reaches the terminal.
"""

import os
import re
import struct
import threading
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError

from dcstereo._checks import disparity_array, is_integer, is_number
from dcstereo.io._atomic import (  # noqa: F401  (re-exported: the writers' public helpers)
    TEMPORARY_NAME_EXTRA,
    _reason,
    atomic_write,
    atomic_writes,
    check_writable,
    remove_stale_temporaries,
    stale_temporaries,
)
from dcstereo.io._paths import _as_real_array, _check_readable
from dcstereo.io.points import (  # noqa: F401  (re-exported: dcstereo.io's writers)
    _ply_complete,
    read_features_csv,
    write_features_csv,
    write_ply,
)

_PNG16_MAX = 65535
#: The most pixels (width x height) an image or map may have for the readers, unless
#: their ``max_pixels`` or the environment variable :data:`MAX_PIXELS_VARIABLE` says
#: otherwise. 100 million: twice a 50-megapixel photograph; Pillow's own
#: decompression-bomb limit (89.5 million, an error at twice that) is of the same size.
MAX_PIXELS = 100_000_000
#: The environment variable that sets the readers' pixel limit (a whole number).
MAX_PIXELS_VARIABLE = "DCSTEREO_MAX_PIXELS"
_PFM_HEADER = re.compile(rb"(P[Ff])\s+(\S+)\s+(\S+)\s+(\S+)(?:\r\n|\s)")
#: Bytes read for a PFM header (the header of any real file is far shorter).
_PFM_HEADER_BYTES = 4096
_DISPARITY_SUFFIXES = (".pfm", ".png")


def read_image(path: str | os.PathLike, *, max_pixels: int | None = None) -> np.ndarray:
    """Read an image file into a numpy array.

    PNG, JPEG, TIFF, PGM/PPM and the other formats Pillow knows are read with Pillow, PFM
    with :func:`read_pfm`. Palette images become RGB, an alpha channel is dropped, 1-bit
    images become 0/255 and 16-bit gray images (PNG, PGM, TIFF) stay 16-bit; 16-bit
    colour PNGs come back as 8 bits (Pillow keeps only the high byte).

    Parameters
    ----------
    path : str or os.PathLike
        The image file.
    max_pixels : int, optional
        The most pixels the image may have (default: :func:`pixel_limit`, 100 million or
        ``DCSTEREO_MAX_PIXELS``); checked on the header, before anything is decoded.

    Returns
    -------
    ndarray, shape (H, W) or (H, W, 3)
        ``uint8`` or ``uint16``; ``float32`` for PFM and float TIFF files.

    Raises
    ------
    ValueError
        If the file is missing, not an image, truncated or over ``max_pixels``; the
        message names the path.
    """
    limit = pixel_limit(max_pixels)
    _check_readable(path, "image")
    if _is_pfm(path):
        return read_pfm(path, max_pixels=limit)
    image = open_image(path, max_pixels=limit)
    mode = image.mode
    array = _mode_to_array(image)
    if array is None:
        raise ValueError(f"cannot read image '{path}': unsupported pixel mode '{mode}'")
    return _normalise_dtype(array, path)


def open_image(path: str | os.PathLike, *, max_pixels: int | None = None) -> Image.Image:
    """Open and decode an image file with Pillow; return the decoded image.

    A damaged or unknown file is a one-line ``ValueError`` naming the path (Pillow's
    decoders raise ``OSError``, ``SyntaxError``, ``EOFError``, ``ValueError``,
    ``struct.error``... on damaged files; none of them should reach the user as a
    traceback), and so is an image of more than ``max_pixels`` pixels (default:
    :func:`pixel_limit`), found from its header before it is decoded. Pillow's warnings
    and its decompression-bomb check are set aside meanwhile (this limit replaces the
    check): none is printed, nor turned into an exception by ``-W error``.
    """
    limit = pixel_limit(max_pixels)
    with _pillow_quietly():
        try:
            image = Image.open(path)
        except UnidentifiedImageError:
            raise ValueError(f"cannot read image '{path}': not a recognised image format") from None
        except Exception as exc:
            raise _corrupt(path, exc) from None
        with image:
            _check_pixels(path, "image", *image.size, limit)
            try:
                image.load()
                return image.copy()
            except MemoryError:
                width, height = image.size
                raise MemoryError(
                    f"out of memory reading image '{path}' ({width} x {height} pixels)"
                ) from None
            except Exception as exc:
                raise _corrupt(path, exc) from None


def _corrupt(path: str | os.PathLike, exc: Exception) -> ValueError:
    return ValueError(f"cannot read image '{path}': truncated or corrupt image data ({exc})")


def pixel_limit(max_pixels: int | None = None) -> int:
    """Return the pixel limit of the readers: ``max_pixels`` if given, else the default.

    The default is the environment variable ``DCSTEREO_MAX_PIXELS`` where it is set (a
    whole number, ``_`` allowed between digits), else :data:`MAX_PIXELS`.

    Raises
    ------
    TypeError, ValueError
        If ``max_pixels`` or the variable is not a whole number of 1 or more.
    """
    if max_pixels is not None:
        if not is_integer(max_pixels):
            raise TypeError(f"max_pixels must be an integer, got {max_pixels!r}")
        if max_pixels < 1:
            raise ValueError(f"max_pixels must be 1 or more, got {max_pixels}")
        return int(max_pixels)
    text = os.environ.get(MAX_PIXELS_VARIABLE, "").strip()
    if not text:
        return MAX_PIXELS
    try:
        limit = int(text)
    except ValueError:
        limit = 0
    if limit < 1:
        raise ValueError(
            f"{MAX_PIXELS_VARIABLE} must be a whole number of pixels, 1 or more, got {text!r}"
        )
    return limit


def _check_pixels(path, what: str, width: int, height: int, limit: int) -> None:
    """Refuse a ``width x height`` image over ``limit`` pixels, saying how to raise it."""
    if width * height > limit:
        raise ValueError(
            f"cannot read {what} '{path}': {width} x {height} is {width * height:,} pixels, "
            f"more than the limit of {limit:,} per image; raise it with the environment "
            f"variable {MAX_PIXELS_VARIABLE}=<pixels> (in Python: max_pixels=)"
        )


#: Held while Pillow decodes for dcstereo: the settings :func:`_pillow_quietly` changes
#: are the process's, so one image decodes at a time (a reader called inside another's
#: block, on the same thread, is fine).
_PILLOW_LOCK = threading.RLock()


@contextmanager
def _pillow_quietly() -> Iterator[None]:
    """Decode with Pillow without its warnings and without its decompression-bomb check.

    Pillow warns on damaged files (``Corrupt EXIF data``...) and past 89.5 million pixels
    (``DecompressionBombWarning``), each printed with its own source line, and raises past
    twice that: dcstereo reports a damaged file as one error line and applies its own
    pixel limit instead (:func:`pixel_limit`). Python's warning filters and Pillow's
    ``Image.MAX_IMAGE_PIXELS`` belong to the whole process, so they are changed under a
    lock and put back when the block ends; under ``-W error`` too, no warning of Pillow's
    becomes an exception meanwhile. Pillow used by another thread at that moment runs
    with the same settings.
    """
    with _PILLOW_LOCK, warnings.catch_warnings():
        warnings.filterwarnings("ignore", module=r"PIL(\.|$)")
        warnings.filterwarnings("ignore", category=Image.DecompressionBombWarning)
        limit = Image.MAX_IMAGE_PIXELS
        Image.MAX_IMAGE_PIXELS = None
        try:
            yield
        finally:
            Image.MAX_IMAGE_PIXELS = limit


def _is_pfm(path: str | os.PathLike) -> bool:
    try:
        with open(path, "rb") as f:
            head = f.read(3)
    except OSError as exc:
        raise ValueError(f"cannot read image '{path}': {_reason(exc)}") from None
    return head[:2] in (b"PF", b"Pf") and head[2:3].isspace()


def _mode_to_array(im: Image.Image) -> np.ndarray | None:
    mode = im.mode
    if mode == "1":
        return np.asarray(im.convert("L"))
    if mode == "P":
        # A palette with a transparent entry must go through RGBA (Pillow warns otherwise).
        has_alpha = "transparency" in im.info
        return np.asarray(im.convert("RGBA" if has_alpha else "RGB"))[..., :3]
    if mode in ("LA", "La"):
        return np.asarray(im)[..., 0]
    if mode in ("L", "RGB", "F", "I") or mode.startswith("I;16"):
        return np.asarray(im)
    try:
        return np.asarray(im.convert("RGB"))
    except ValueError:  # Pillow has no conversion from this mode
        return None


def _normalise_dtype(array: np.ndarray, path: str | os.PathLike) -> np.ndarray:
    if array.dtype == np.uint8:
        return np.ascontiguousarray(array)
    if array.dtype.kind == "f":
        return np.ascontiguousarray(array, dtype=np.float32)
    # Pillow gives "I;16B" as big-endian uint16 and 16-bit PGM as int32 mode "I".
    if array.size and (array.min() < 0 or array.max() > _PNG16_MAX):
        raise ValueError(
            f"cannot read image '{path}': integer values outside 0..{_PNG16_MAX} are not supported"
        )
    return np.ascontiguousarray(array, dtype=np.uint16)


def _pfm_header(data: bytes, path: str | os.PathLike) -> tuple[int, int, int, float, int]:
    """Parse the header at the start of ``data``: width, height, channels, scale, data offset.

    Raises ``ValueError`` naming ``path`` when it is malformed.
    """
    # Four whitespace-separated fields, then exactly one whitespace byte (or CR LF).
    header = _PFM_HEADER.match(data)
    if header is None:
        raise ValueError(f"cannot read PFM file '{path}': header does not start with PF or Pf")
    magic, fields = header[1], header.group(2, 3, 4)
    try:
        if not (fields[0].isdigit() and fields[1].isdigit()):  # int() also takes "+1", "1_0"
            raise ValueError
        width, height, scale = int(fields[0]), int(fields[1]), float(fields[2])
    except ValueError:
        raise ValueError(
            f"cannot read PFM file '{path}': malformed width, height or scale in the header"
        ) from None
    if width <= 0 or height <= 0 or scale == 0 or not np.isfinite(scale):
        raise ValueError(
            f"cannot read PFM file '{path}': invalid header (width {width}, height {height}, "
            f"scale {scale})"
        )
    return width, height, 3 if magic == b"PF" else 1, scale, header.end()


def is_complete(path: str | os.PathLike) -> bool:
    """Return True when ``path`` is a whole PFM or image file, cheaply, without decoding it.

    Files are written atomically, but one can still be cut short later (a full disk, an
    interrupted copy). A PFM is complete when its header parses and the file is exactly
    the header plus its ``width * height * channels`` float32 values; a binary PLY (as
    :func:`~dcstereo.io.points.write_ply` writes) when it is exactly its header plus its
    vertices; any other file when Pillow's ``verify`` passes (a PNG: every chunk's CRC, up
    to the end chunk). A missing or unreadable file is not complete.
    """
    path = Path(path)
    if not path.is_file():  # a FIFO or a device would block the read below
        return False
    try:
        if path.suffix.lower() == ".pfm":
            with open(path, "rb") as f:
                width, height, channels, _, pos = _pfm_header(f.read(256), path)
            return path.stat().st_size == pos + 4 * width * height * channels
        if path.suffix.lower() == ".ply":
            return _ply_complete(path)
        with _pillow_quietly(), Image.open(path) as image:
            image.verify()
        return True
    except (OSError, ValueError, SyntaxError, EOFError, struct.error, KeyError, IndexError):
        return False


def read_pfm(path: str | os.PathLike, *, max_pixels: int | None = None) -> np.ndarray:
    """Read a Portable Float Map.

    The header is ``Pf`` (gray) or ``PF`` (colour), the width and height, and a scale
    whose sign gives the byte order (negative: little endian). Rows are stored bottom to
    top; the array returned is top to bottom. Values are returned as stored (``inf``
    stays ``inf``).

    Parameters
    ----------
    path : str or os.PathLike
        The PFM file.
    max_pixels : int, optional
        The most pixels the map may have (default: :func:`pixel_limit`); checked on the
        header, before the data is read.

    Returns
    -------
    ndarray of float32, shape (H, W) or (H, W, 3)

    Raises
    ------
    ValueError
        If the file is missing, its header is malformed, its data is short or it has more
        than ``max_pixels`` pixels.
    """
    limit = pixel_limit(max_pixels)
    _check_readable(path, "PFM file")
    try:
        with open(path, "rb") as f:
            width, height, channels, scale, pos = _pfm_header(f.read(_PFM_HEADER_BYTES), path)
            _check_pixels(path, "PFM file", width, height, limit)
            count = width * height * channels
            f.seek(pos)
            data = f.read(4 * count)
    except OSError as exc:
        raise ValueError(f"cannot read PFM file '{path}': {_reason(exc)}") from None
    if len(data) < 4 * count:
        raise ValueError(
            f"cannot read PFM file '{path}': data is short ({len(data)} bytes, "
            f"{4 * count} expected for {width}x{height}x{channels})"
        )
    dtype = "<f4" if scale < 0 else ">f4"
    values = np.frombuffer(data, dtype=dtype, count=count)
    shape = (height, width, 3) if channels == 3 else (height, width)
    return np.ascontiguousarray(values.reshape(shape)[::-1], dtype=np.float32)


def write_pfm(path: str | os.PathLike, array: np.ndarray) -> None:
    """Write a float32 Portable Float Map, little endian, atomically.

    Every non-finite value (NaN, ``-inf``, ``+inf``) is written as ``+inf``, the
    Middlebury convention for "no estimate".

    Parameters
    ----------
    path : str or os.PathLike
        Output file (usually ``.pfm``).
    array : ndarray, shape (H, W) or (H, W, 3)
        Real values; written as gray ``Pf`` or colour ``PF``.
    """
    values = _as_real_array(array, "array")
    if not (values.ndim == 2 or (values.ndim == 3 and values.shape[2] == 3)):
        raise ValueError(f"array must have shape (H, W) or (H, W, 3) for PFM, got {values.shape}")
    _check_not_empty(values, "array")
    with np.errstate(over="ignore", invalid="ignore"):
        values = values.astype(np.float32)
    values = np.where(np.isfinite(values), values, np.float32(np.inf))
    height, width = values.shape[:2]
    magic = "PF" if values.ndim == 3 else "Pf"
    header = f"{magic}\n{width} {height}\n-1.0\n".encode("ascii")
    body = np.ascontiguousarray(values[::-1], dtype="<f4").tobytes()
    with atomic_write(path) as tmp:
        tmp.write_bytes(header + body)


def read_disparity(
    path: str | os.PathLike, *, scale: float | None = None, max_pixels: int | None = None
) -> np.ndarray:
    """Read a disparity map stored as PFM or as a gray PNG (or other gray image).

    Parameters
    ----------
    path : str or os.PathLike
        PFM file (disparity in pixels, ``inf`` = no estimate), 16-bit gray image (value /
        ``scale``, ``0`` = no estimate) or 8-bit gray image (value / ``scale``, ``0`` = no
        estimate; ``scale`` is required because 8-bit conventions differ, e.g. Middlebury
        2001 uses 8, quarter-size 2003 scenes use 4).
    scale : float, optional
        Stored value per pixel of disparity. Default 256 for 16-bit images; for PFM files
        the values are divided by it when given.
    max_pixels : int, optional
        The most pixels the map may have (default: :func:`pixel_limit`).

    Returns
    -------
    ndarray of float32, shape (H, W)
        Disparity in pixels, NaN where there is no estimate.
    """
    scale = None if scale is None else _check_scale(scale)
    return _read_map(path, scale, "disparity", max_pixels)


def read_depth(
    path: str | os.PathLike, *, scale: float = 1.0, max_pixels: int | None = None
) -> np.ndarray:
    """Read a depth map written by :func:`write_depth` (PFM, or 16-bit PNG).

    Parameters
    ----------
    path : str or os.PathLike
        PFM file (depth, ``inf`` = none) or 16-bit gray PNG (``value / scale``, ``0`` =
        none).
    scale : float
        Stored value per unit of depth for a PNG (1: the PNG holds the depth in the
        baseline's unit, millimetres for Middlebury; TUM RGB-D uses 5000 per metre).
        A PFM's values are divided by it too.
    max_pixels : int, optional
        The most pixels the map may have (default: :func:`pixel_limit`).

    Returns
    -------
    ndarray of float32, shape (H, W)
        Depth, NaN where there is none.
    """
    return _read_map(path, _check_scale(scale), "depth", max_pixels)


def _read_map(path, scale: float | None, what: str, max_pixels: int | None) -> np.ndarray:
    """Read a one-channel map: PFM (``inf`` = none) or integer image (``0`` = none).

    ``scale`` is checked by the caller; None: 256 for a 16-bit image, required for 8 bits.
    """
    stored = read_image(path, max_pixels=max_pixels)
    if stored.ndim != 2:
        raise ValueError(
            f"cannot read {what} '{path}': it is a colour image, a {what} map must "
            "have a single channel"
        )
    if stored.dtype == np.float32:
        values = np.where(np.isfinite(stored), stored, np.float32(np.nan))
        return (values / np.float32(scale or 1.0)).astype(np.float32)
    if stored.dtype == np.uint8 and scale is None:
        raise ValueError(
            f"cannot read {what} '{path}': an 8-bit {what} image needs a scale "
            f"(stored value per pixel of {what}: scale=, or dcstereo eval --scale)"
        )
    if scale is None:
        scale = 256.0
    values = stored.astype(np.float32) / np.float32(scale)
    values[stored == 0] = np.nan
    return values


def write_disparity_png16(
    path: str | os.PathLike, disparity: np.ndarray, *, scale: float = 256
) -> None:
    """Write a disparity map as a 16-bit PNG (KITTI style), atomically.

    The stored value is ``round(disparity * scale)``; ``0`` means "no estimate" and is
    written for every non-finite pixel. A finite disparity that would round to 0
    (``0 <= d <= 0.5 / scale``) is stored as ``1`` so that it stays distinguishable
    from "no estimate"; it reads back as ``1 / scale``.

    Parameters
    ----------
    path : str or os.PathLike
        Output file (usually ``.png``).
    disparity : ndarray, shape (H, W)
        Disparity in pixels, ``>= 0``, NaN where there is no estimate.
    scale : float
        Stored value per pixel of disparity; the largest disparity that fits is
        ``65535 / scale`` (255.99 for the default 256).

    Raises
    ------
    ValueError
        If a disparity is negative or too large for 16 bits; nothing is written.
    """
    scale = _check_scale(scale)
    d, rounded, finite = _png16_values(path, disparity, scale, "disparity")
    if finite.any() and rounded[finite].max() > _PNG16_MAX:
        raise ValueError(
            f"cannot write '{path}': largest disparity {float(d[finite].max()):g} exceeds "
            f"the 16-bit limit {_PNG16_MAX / scale:g} at scale {scale:g}"
        )
    _save_png16(path, rounded, finite)


def _png16_values(path, values, scale: float, what: str):
    """Check a map for a 16-bit PNG: ``(values as float64, round(values * scale), finite)``.

    Refuses a negative value (a PNG stores 0 or more); ``scale`` is already checked.
    """
    v = _check_map(values, what)
    finite = np.isfinite(v)
    if finite.any() and v[finite].min() < 0:
        raise ValueError(
            f"cannot write '{path}': smallest {what} {float(v[finite].min()):g} is negative "
            "and a 16-bit PNG stores 0 or more"
        )
    return v, np.rint(np.where(finite, v, 0.0) * scale), finite


def _save_png16(path, rounded: np.ndarray, keep: np.ndarray) -> None:
    """Write ``rounded`` where ``keep`` (0 becomes 1: 0 means none) and 0 elsewhere, atomically."""
    stored = np.where(keep, np.maximum(rounded, 1), 0).astype(np.uint16)
    with atomic_write(path) as tmp:
        Image.fromarray(stored).save(tmp, format="PNG")


def write_depth_png16(path: str | os.PathLike, depth: np.ndarray, *, scale: float = 1.0) -> int:
    """Write a depth map as a 16-bit PNG, the RGB-D convention, atomically.

    The stored value is ``round(depth * scale)``; ``0`` means "no depth" and is written
    for every non-finite pixel. With the default scale 1 the PNG holds the depth in the
    baseline's unit: millimetres for a baseline in millimetres (Middlebury, depth
    cameras, Open3D's default ``depth_scale`` of 1000 per metre); TUM RGB-D stores 5000
    per metre. A depth that would round to 0 is stored as ``1``. A depth beyond the
    16 bits (``65535 / scale``: 65.5 m at 1 per millimetre) cannot be stored: it is
    written as ``0``, "no depth", and counted in the return value.

    Parameters
    ----------
    path : str or os.PathLike
        Output file (usually ``.png``).
    depth : ndarray, shape (H, W)
        Depth, ``>= 0``, NaN where there is none (:func:`dcstereo.geometry.depth`).
    scale : float
        Stored value per unit of depth.

    Returns
    -------
    int
        The pixels with a depth too far for 16 bits, written as "no depth".

    Raises
    ------
    ValueError
        If a depth is negative; nothing is written.
    """
    _, rounded, finite = _png16_values(path, depth, _check_scale(scale), "depth")
    far = finite & (rounded > _PNG16_MAX)
    _save_png16(path, rounded, finite & ~far)
    return int(far.sum())


def write_depth(path: str | os.PathLike, depth: np.ndarray, *, scale: float | None = None) -> int:
    """Write a depth map in the format given by the file suffix, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        ``.pfm`` (:func:`write_pfm`: float32 depth, ``inf`` = none) or ``.png``
        (:func:`write_depth_png16`: 16-bit, ``round(depth * scale)``, ``0`` = none).
    depth : ndarray, shape (H, W)
        Depth, NaN where there is none.
    scale : float, optional
        For ``.png`` only: stored value per unit of depth (default 1).

    Returns
    -------
    int
        Pixels with a depth the file could not hold, written as "no depth" (a PNG's
        beyond ``65535 / scale``; always 0 for PFM).
    """
    check_suffix(path, _DISPARITY_SUFFIXES, "depth")
    if Path(path).suffix.lower() == ".png":
        return write_depth_png16(path, depth, scale=1.0 if scale is None else scale)
    if scale is not None:
        raise TypeError("write_depth takes a scale for a .png file only, not for .pfm")
    write_pfm(path, depth)
    return 0


def check_disparity_suffix(path: str | os.PathLike) -> None:
    """Raise ``ValueError`` unless ``path`` has a suffix :func:`write_disparity` knows."""
    check_suffix(path, _DISPARITY_SUFFIXES, "disparity")


def check_png_suffix(path: str | os.PathLike, what: str = "picture") -> None:
    """Raise ``ValueError`` unless ``path`` ends in ``.png``.

    The PNG writers write PNG under any name; a command checks its pictures' names with
    this before any work. ``what`` names the file in the message (a CLI option).
    """
    check_suffix(path, ".png", what)


def check_suffix(path: str | os.PathLike, suffix: str | tuple[str, ...], what: str) -> None:
    """Raise ``ValueError`` unless ``path`` ends in ``suffix`` (any case), or one of them.

    ``what`` names the file in the message (a CLI option).
    """
    allowed = (suffix,) if isinstance(suffix, str) else suffix
    found = Path(path).suffix.lower()
    if found not in allowed:
        use = allowed[0] if len(allowed) == 1 else "one of " + ", ".join(allowed)
        raise ValueError(f"cannot write {what} '{path}': unsupported suffix '{found}', use {use}")


def write_disparity(path: str | os.PathLike, disparity: np.ndarray, **options) -> None:
    """Write a disparity map in the format given by the file suffix, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        ``.pfm`` (:func:`write_pfm`, ``inf`` = no estimate) or ``.png``
        (:func:`write_disparity_png16`, ``0`` = no estimate).
    disparity : ndarray, shape (H, W)
        Disparity in pixels, NaN where there is no estimate.
    **options
        Passed to the writer: ``scale`` for ``.png``; none for ``.pfm``.
    """
    check_disparity_suffix(path)
    suffix = Path(path).suffix.lower()
    d = _check_map(disparity)
    if suffix == ".png":
        write_disparity_png16(path, d, **options)
        return
    if options:
        raise TypeError(
            f"write_disparity got options {sorted(options)} that a .pfm file does not take"
        )
    write_pfm(path, d)


def write_mask_png(path: str | os.PathLike, mask: np.ndarray) -> None:
    """Write a boolean mask as an 8-bit PNG (True = 255, False = 0), atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Output file.
    mask : ndarray of bool, shape (H, W)
        The mask; anything but bool is refused (write ``mask != 0`` for 0/1 arrays).
    """
    mask = np.asarray(mask)
    if mask.dtype != np.bool_:
        raise TypeError(f"mask must be a bool array, got dtype {mask.dtype}")
    if mask.ndim != 2:
        raise ValueError(f"mask must be 2-D (H, W), got shape {mask.shape}")
    _check_not_empty(mask, "mask")
    with atomic_write(path) as tmp:
        Image.fromarray(np.where(mask, 255, 0).astype(np.uint8)).save(tmp, format="PNG")


def write_rgb_png(path: str | os.PathLike, image: np.ndarray) -> None:
    """Write an 8-bit gray or RGB image as a PNG, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Output file.
    image : ndarray of uint8, shape (H, W) or (H, W, 3)
        Gray or RGB pixels (e.g. from :mod:`dcstereo.viz`).
    """
    image = np.asarray(image)
    if image.dtype != np.uint8:
        raise TypeError(f"image must be uint8, got dtype {image.dtype}")
    if not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)):
        raise ValueError(f"image must have shape (H, W) or (H, W, 3), got {image.shape}")
    _check_not_empty(image, "image")
    with atomic_write(path) as tmp:
        Image.fromarray(np.ascontiguousarray(image)).save(tmp, format="PNG")


def _check_not_empty(array: np.ndarray, name: str) -> None:
    if array.size == 0:
        raise ValueError(f"{name} is empty (shape {array.shape})")


def _check_map(values: np.ndarray, name: str = "disparity") -> np.ndarray:
    """Return a real, non-empty (H, W) map as float64 (``name`` in the messages)."""
    v = disparity_array(values, name)
    _check_not_empty(v, name)
    return v


def _check_scale(scale: float) -> float:
    if not is_number(scale):
        raise TypeError(f"scale must be a number, got {type(scale).__name__}")
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"scale must be a positive finite number, got {scale}")
    return float(scale)

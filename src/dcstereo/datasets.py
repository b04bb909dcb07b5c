"""Stereo pairs with ground truth: the Middlebury development scenes and the skimage motorcycle.

The Middlebury scenes are read from ``<data dir>/middlebury/<scene>/`` (see
:func:`default_data_dir`), one folder per scene::

    left.png, right.png       rectified colour pair, left = reference view
    disp_gt.png               8-bit gray, disparity = gray / scale, gray 0 = unknown
    nonocc.png, all.png       255 = scored in the "nonocc" / "all" column of Middlebury v2
    disc.png                  255 = near a depth discontinuity (128 = scored elsewhere only)
    meta.json                 at least ``scale`` and ``ndisp`` (exclusive disparity bound)

Convention: left pixel ``(x, y)`` matches right pixel ``(x - d, y)``, ``d >= 0``.
"""

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image

#: Environment variable that overrides :func:`default_data_dir`.
DATA_ENV_VAR = "DCSTEREO_DATA"

#: Mask files of a Middlebury scene folder and the mask names they become.
MIDDLEBURY_MASKS = {"nonocc": "nonocc.png", "all": "all.png", "disc": "disc.png"}


@dataclass(frozen=True, eq=False)
class StereoScene:
    """A rectified stereo pair with ground-truth disparity and evaluation masks.

    Compared by identity (``eq=False``): element-wise array comparison has no single truth
    value. The repr leaves out the arrays and ``meta``.

    Attributes
    ----------
    name : str
        Scene name, for example ``"tsukuba"``.
    left, right : ndarray of uint8, shape (H, W, 3) or (H, W)
        The pair as read from disk.
    disparity : ndarray of float32, shape (H, W)
        Ground-truth disparity of the left view in pixels (``x_right = x_left - d``); NaN
        where unknown.
    masks : dict of str to ndarray of bool, shape (H, W)
        Evaluation masks: Middlebury scenes have ``"nonocc"``, ``"all"`` and ``"disc"``.
    max_disparity : int
        Largest disparity to search (inclusive), for :func:`dcstereo.match`; sub-pixel
        ground truth may exceed it by less than one pixel.
    min_disparity : int
        Smallest disparity to search.
    meta : dict
        Provenance and encoding details (the scene's ``meta.json`` for Middlebury).
    """

    name: str
    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)
    disparity: np.ndarray = field(repr=False)
    masks: dict[str, np.ndarray] = field(repr=False)
    max_disparity: int
    min_disparity: int = 0
    meta: dict = field(default_factory=dict, repr=False)

    def __post_init__(self):
        if self.left.shape != self.right.shape:
            raise ValueError(
                f"scene {self.name!r}: left and right images differ in shape: "
                f"{self.left.shape} vs {self.right.shape}"
            )
        shape = self.left.shape[:2]
        if self.disparity.shape != shape:
            raise ValueError(
                f"scene {self.name!r}: disparity has shape {self.disparity.shape}, "
                f"the images {shape}"
            )
        for key, mask in self.masks.items():
            if mask.shape != shape or mask.dtype != bool:
                raise ValueError(
                    f"scene {self.name!r}: mask {key!r} must be a boolean array of shape "
                    f"{shape}, got {mask.dtype} {mask.shape}"
                )
        if self.min_disparity > self.max_disparity:
            raise ValueError(
                f"scene {self.name!r}: min_disparity={self.min_disparity} is larger than "
                f"max_disparity={self.max_disparity}"
            )

    @property
    def shape(self) -> tuple[int, int]:
        """Image size ``(H, W)``."""
        return self.disparity.shape


def default_data_dir() -> Path:
    """Folder holding the data sets (``middlebury/`` ...).

    The environment variable ``DCSTEREO_DATA`` when it is set; otherwise ``shared/data``
    beside the checkout (``<repo>/../shared/data``), where the development data lives.

    Returns
    -------
    Path
        The folder; it may not exist.
    """
    override = os.environ.get(DATA_ENV_VAR)
    if override:
        return Path(override).expanduser()
    return Path(__file__).resolve().parents[3] / "shared" / "data"


def middlebury_dir(root: str | os.PathLike | None = None) -> Path:
    """Folder of the Middlebury scenes: ``root / "middlebury"``.

    Parameters
    ----------
    root : path-like, optional
        Data folder; :func:`default_data_dir` by default.

    Returns
    -------
    Path
    """
    return Path(root if root is not None else default_data_dir()) / "middlebury"


def list_middlebury(root: str | os.PathLike | None = None) -> list[str]:
    """Names of the Middlebury scenes present (folders holding a ``left.png``), sorted.

    Parameters
    ----------
    root : path-like, optional
        Data folder; :func:`default_data_dir` by default.

    Returns
    -------
    list of str
        Empty when the folder does not exist.
    """
    folder = middlebury_dir(root)
    if not folder.is_dir():
        return []
    return sorted(p.name for p in folder.iterdir() if (p / "left.png").is_file())


def _read_image(path: Path) -> np.ndarray:
    """Read an 8-bit image: gray stays (H, W), anything else becomes RGB (H, W, 3)."""
    with Image.open(path) as image:
        if image.mode not in ("L", "RGB"):
            if image.mode not in ("P", "PA", "LA", "RGBA", "RGBX", "CMYK", "YCbCr"):
                raise ValueError(f"{path} is not an 8-bit image (Pillow mode {image.mode!r})")
            image = image.convert("RGB")
        return np.asarray(image, dtype=np.uint8).copy()


def _read_gray(path: Path) -> np.ndarray:
    """Read an 8-bit single-channel image (palette images through their gray palette)."""
    with Image.open(path) as image:
        if image.mode == "P":
            image = image.convert("L")
        if image.mode != "L":
            raise ValueError(f"{path} must be an 8-bit gray image, got Pillow mode {image.mode!r}")
        return np.asarray(image, dtype=np.uint8).copy()


def _scene_folder(name_or_path, root) -> Path:
    as_text = os.fspath(name_or_path)
    is_path = isinstance(name_or_path, os.PathLike) or "/" in as_text or os.sep in as_text
    if is_path:
        folder = Path(as_text).expanduser()
        if not (folder / "left.png").is_file():
            raise ValueError(f"no Middlebury scene at {folder}: left.png is missing")
        return folder
    folder = middlebury_dir(root) / as_text
    if not (folder / "left.png").is_file():
        available = list_middlebury(root)
        listing = ", ".join(available) if available else f"none (set {DATA_ENV_VAR})"
        raise ValueError(
            f"unknown Middlebury scene {as_text!r} in {middlebury_dir(root)}; available: {listing}"
        )
    return folder


def load_middlebury(
    name_or_path: str | os.PathLike, root: str | os.PathLike | None = None
) -> StereoScene:
    """Load a Middlebury scene with its ground truth and v2 evaluation masks.

    Parameters
    ----------
    name_or_path : str or path-like
        Scene name (``"tsukuba"``, ``"venus"``, ``"teddy"``, ``"cones"``), looked up in
        :func:`middlebury_dir`, or the path of a scene folder (a ``Path``, or a string
        containing a path separator).
    root : path-like, optional
        Data folder for scene names; :func:`default_data_dir` by default.

    Returns
    -------
    StereoScene
        ``disparity = gray / scale`` with gray 0 as NaN; masks ``"nonocc"``, ``"all"`` and
        ``"disc"`` are the pixels equal to 255 in the mask images (so ``"disc"`` leaves out the
        value 128); ``max_disparity = ndisp - 1``.

    Raises
    ------
    ValueError
        When the scene does not exist (the message lists the available ones), a file is
        missing, ``meta.json`` lacks ``scale`` or ``ndisp``, or the files differ in size.

    Examples
    --------
    >>> scene = load_middlebury("tsukuba")  # doctest: +SKIP
    >>> scene.left.shape, scene.max_disparity  # doctest: +SKIP
    ((288, 384, 3), 15)
    """
    folder = _scene_folder(name_or_path, root)
    needed = ["right.png", "disp_gt.png", "meta.json", *MIDDLEBURY_MASKS.values()]
    missing = [f for f in needed if not (folder / f).is_file()]
    if missing:
        raise ValueError(f"Middlebury scene folder {folder} lacks {', '.join(missing)}")
    meta = json.loads((folder / "meta.json").read_text(encoding="utf-8"))
    try:
        scale = float(meta["scale"])
        ndisp = int(meta["ndisp"])
    except (KeyError, TypeError, ValueError):
        raise ValueError(
            f"{folder / 'meta.json'} must give a numeric 'scale' and an integer 'ndisp'"
        ) from None
    if not scale > 0 or ndisp < 1:
        raise ValueError(
            f"{folder / 'meta.json'}: scale must be positive and ndisp at least 1, "
            f"got scale={scale} and ndisp={ndisp}"
        )

    left = _read_image(folder / "left.png")
    right = _read_image(folder / "right.png")
    gray = _read_gray(folder / "disp_gt.png")
    disparity = np.where(gray == 0, np.nan, gray / scale).astype(np.float32)
    masks = {key: _read_gray(folder / file) == 255 for key, file in MIDDLEBURY_MASKS.items()}
    for file, array in [("right.png", right), ("disp_gt.png", gray)] + [
        (MIDDLEBURY_MASKS[key], mask) for key, mask in masks.items()
    ]:
        if array.shape[:2] != left.shape[:2]:
            raise ValueError(
                f"{folder / file} is {array.shape[1]}x{array.shape[0]} pixels but left.png is "
                f"{left.shape[1]}x{left.shape[0]}"
            )
    return StereoScene(
        name=str(meta.get("name", folder.name)),
        left=left,
        right=right,
        disparity=disparity,
        masks=masks,
        max_disparity=ndisp - 1,
        min_disparity=0,
        meta=meta,
    )


def load_motorcycle() -> StereoScene:
    """Load the Middlebury 2014 motorcycle pair shipped with scikit-image.

    Uses :func:`skimage.data.stereo_motorcycle` (scikit-image is an optional dependency:
    ``pip install "dcstereo[demo]"``).

    Returns
    -------
    StereoScene
        Images (500, 741, 3) uint8; disparity with the unknown (inf) pixels as NaN;
        ``masks["all"]`` and ``masks["nonocc"]`` are both the pixels with finite ground truth,
        because scikit-image ships no occlusion mask (so ``"nonocc"`` includes half-occluded
        pixels here); ``max_disparity = 64`` (the ground truth spans about 7 to 60).

    Raises
    ------
    ImportError
        When scikit-image is not installed.

    References
    ----------
    D. Scharstein, H. Hirschmueller, Y. Kitajima, G. Krathwohl, N. Nesic, X. Wang and
    P. Westling, "High-resolution stereo datasets with subpixel-accurate ground truth",
    GCPR 2014.
    """
    try:
        from skimage import data
    except ImportError as err:
        raise ImportError(
            "load_motorcycle needs scikit-image; install the demo extra: "
            'pip install "dcstereo[demo]"'
        ) from err
    left, right, disparity = data.stereo_motorcycle()
    disparity = np.asarray(disparity, dtype=np.float32)
    known = np.isfinite(disparity)
    disparity = np.where(known, disparity, np.float32(np.nan)).astype(np.float32)
    return StereoScene(
        name="motorcycle",
        left=np.asarray(left, dtype=np.uint8),
        right=np.asarray(right, dtype=np.uint8),
        disparity=disparity,
        masks={"all": known, "nonocc": known.copy()},
        max_disparity=64,
        min_disparity=0,
        meta={
            "name": "motorcycle",
            "source": "skimage.data.stereo_motorcycle (Middlebury 2014, Motorcycle, reduced)",
            "masks": "'all' and 'nonocc' are both the pixels with finite ground truth; "
            "no occlusion mask is available",
            "citation": (
                "D. Scharstein et al. High-resolution stereo datasets with subpixel-accurate "
                "ground truth. GCPR 2014."
            ),
        },
    )

"""Stereo pairs with ground truth: the Middlebury development scenes and the skimage motorcycle.

The Middlebury scenes are read from ``<data dir>/middlebury/<scene>/`` (see
:func:`default_data_dir`), one folder per scene::

    left.png, right.png       rectified colour pair, left = reference view
    disp_gt.png               8-bit gray, disparity = gray / scale, gray 0 = unknown
    nonocc.png, all.png       255 = scored in the "nonocc" / "all" column of Middlebury v2
    disc.png                  255 = near a depth discontinuity (128 = scored elsewhere only)
    meta.json                 at least ``scale`` and ``ndisp`` (exclusive disparity bound)

Convention: left pixel ``(x, y)`` matches right pixel ``(x - d, y)``, ``d >= 0``.

:func:`load_scene` reads a scene folder of any of the layouts below, detected from the
files present (see :data:`LAYOUTS`):

``"v2"``
    the layout above (the project's copy of the Middlebury 2001/2003 v2 scenes);
``"2005/2006"``
    ``view1.png`` / ``view5.png`` and ``disp1.png`` (8-bit, 0 = unknown, disparity =
    gray / scale with scale 1, 2 or 3 for the full, half and third size, inferred from the
    image height 1110 / 555 / 370); ``disp5.png`` (the right view's map), when present,
    gives the occlusions by a left-right cross-check;
``"2014"``
    ``im0.png`` / ``im1.png``, ``disp0GT.pfm`` (MiddEval3) or ``disp0.pfm`` (scenes2014) with
    ``inf`` = unknown, ``calib.txt`` with ``ndisp``, and optionally ``mask0nocc.png`` (255 =
    non-occluded, 128 = occluded, 0 = unknown) or ``disp1.pfm`` (cross-check).

:data:`~dcstereo.evaluation.downloads.REGISTRY` lists public Middlebury scenes that
:func:`~dcstereo.evaluation.downloads.fetch` downloads into a cache
with pooch (``dcstereo datasets list`` / ``dcstereo datasets fetch NAME``).
"""

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dcstereo._checks import is_number
from dcstereo.geometry import Calibration, read_calib
from dcstereo.io import open_image, read_pfm

#: Environment variable that overrides :func:`default_data_dir`.
DATA_ENV_VAR = "DCSTEREO_DATA"

#: Mask files of a Middlebury scene folder and the mask names they become.
MIDDLEBURY_MASKS = {"nonocc": "nonocc.png", "all": "all.png", "disc": "disc.png"}

#: Keys of a loaded scene's ``meta``: where each of its masks comes from (a file, or how it
#: was derived), and why each Middlebury mask it lacks is missing (mask name: reason).
MASK_SOURCES = "mask_sources"
MISSING_MASKS = "missing_masks"

#: How the masks derived from the ground truth alone are described.
KNOWN_TRUTH = "every pixel with ground truth"


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
        The pair as read from disk, of one height and width (each gray or colour).
    disparity : ndarray of float32, shape (H, W)
        Ground-truth disparity of the left view in pixels (``x_right = x_left - d``); NaN
        where unknown.
    masks : dict of str to ndarray of bool, shape (H, W)
        Evaluation masks: ``"nonocc"``, ``"all"`` and ``"disc"`` for the Middlebury v2
        scenes with all three mask files, the ones a scene has otherwise (see
        :func:`load_scene`).
    max_disparity : int
        Largest disparity to search (inclusive), for :func:`dcstereo.match`; sub-pixel
        ground truth may exceed it by less than one pixel.
    min_disparity : int
        Smallest disparity to search.
    meta : dict
        Provenance and encoding details (the scene's ``meta.json`` for Middlebury).
    calibration : Calibration or None
        Focal length, baseline and principal point, for depth and point clouds
        (:mod:`dcstereo.geometry`): the 2014 scenes' ``calib.txt`` and the Motorcycle pair;
        None for the older scenes, which publish none.
    """

    name: str
    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)
    disparity: np.ndarray = field(repr=False)
    masks: dict[str, np.ndarray] = field(repr=False)
    max_disparity: int
    min_disparity: int = 0
    meta: dict = field(default_factory=dict, repr=False)
    calibration: Calibration | None = field(default=None, repr=False)

    def __post_init__(self):
        # a gray and a colour view may pair: every method reduces each to its own intensity
        if self.left.shape[:2] != self.right.shape[:2]:
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
        if self.calibration is not None and not isinstance(self.calibration, Calibration):
            raise TypeError(
                f"scene {self.name!r}: calibration must be a Calibration or None, got "
                f"{type(self.calibration).__name__}"
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
    return Path(__file__).resolve().parents[4] / "shared" / "data"  # src/dcstereo/evaluation/


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
    image = open_image(path)
    if image.mode not in ("L", "RGB"):
        if image.mode not in ("P", "PA", "LA", "RGBA", "RGBX", "CMYK", "YCbCr"):
            raise ValueError(f"{path} is not an 8-bit image (Pillow mode {image.mode!r})")
        image = image.convert("RGB")
    return np.asarray(image, dtype=np.uint8).copy()


def _read_gray(path: Path) -> np.ndarray:
    """Read an 8-bit single-channel image (palette images through their gray palette)."""
    image = open_image(path)
    if image.mode == "P":
        image = image.convert("L")
    if image.mode != "L":
        raise ValueError(f"{path} must be an 8-bit gray image, got Pillow mode {image.mode!r}")
    return np.asarray(image, dtype=np.uint8).copy()


def _integer(value) -> int:
    """Return ``value`` as an int when it is a whole number (or its text); else ValueError."""
    if isinstance(value, int):
        return int(value)
    number = float(value)  # TypeError or ValueError for anything else
    if not number.is_integer():  # also NaN and infinities
        raise ValueError(f"{value!r} is not a whole number")
    return int(number)


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


def _read_meta(path: Path):
    """Parse a scene's ``meta.json``; a broken file is a one-line error naming it."""
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as err:
        raise ValueError(
            f"cannot read {path}: invalid JSON (line {err.lineno} column {err.colno})"
        ) from None
    except UnicodeDecodeError:
        raise ValueError(f"cannot read {path}: it is not UTF-8 text") from None


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
        value 128), those of the three the folder has; a folder with none has one mask,
        ``"all"``, every pixel with ground truth. ``meta["mask_sources"]`` says where each
        mask comes from and ``meta["missing_masks"]`` why the others are missing;
        ``max_disparity = ndisp - 1``.

    Raises
    ------
    ValueError
        When the scene does not exist (the message lists the available ones), the right
        image, the ground truth or ``meta.json`` is missing, ``meta.json`` is not valid
        JSON or lacks ``scale`` or ``ndisp``, or the files differ in size.

    Examples
    --------
    >>> scene = load_middlebury("tsukuba")  # doctest: +SKIP
    >>> scene.left.shape, scene.max_disparity  # doctest: +SKIP
    ((288, 384, 3), 15)
    """
    folder = _scene_folder(name_or_path, root)
    needed = ["right.png", "disp_gt.png", "meta.json"]
    missing = [f for f in needed if not (folder / f).is_file()]
    if missing:
        raise ValueError(f"Middlebury scene folder {folder} lacks {', '.join(missing)}")
    meta = _read_meta(folder / "meta.json")
    try:
        scale = float(meta["scale"])
        ndisp = _integer(meta["ndisp"])
    except (KeyError, TypeError, ValueError, OverflowError):
        raise ValueError(
            f"{folder / 'meta.json'} must give a numeric 'scale' and an integer 'ndisp'"
        ) from None
    if not (math.isfinite(scale) and scale > 0) or ndisp < 1:
        raise ValueError(
            f"{folder / 'meta.json'}: scale must be positive and finite and ndisp at least 1, "
            f"got scale={scale} and ndisp={ndisp}"
        )

    left = _read_image(folder / "left.png")
    right = _read_image(folder / "right.png")
    gray = _read_gray(folder / "disp_gt.png")
    disparity = np.where(gray == 0, np.nan, gray / scale).astype(np.float32)
    present = {key: file for key, file in MIDDLEBURY_MASKS.items() if (folder / file).is_file()}
    masks = {key: _read_gray(folder / file) == 255 for key, file in present.items()}
    for file, array in [("right.png", right), ("disp_gt.png", gray)] + [
        (MIDDLEBURY_MASKS[key], mask) for key, mask in masks.items()
    ]:
        if array.shape[:2] != left.shape[:2]:
            raise ValueError(
                f"{folder / file} is {array.shape[1]}x{array.shape[0]} pixels but left.png is "
                f"{left.shape[1]}x{left.shape[0]}"
            )
    # a folder with some of the masks is scored on those; with none, on every pixel with
    # ground truth (as the layouts without mask files are)
    sources = dict(present)
    if not masks:
        masks = {"all": np.isfinite(disparity)}
        sources["all"] = KNOWN_TRUTH + " (the folder has no mask file)"
    meta[MASK_SOURCES] = sources
    meta[MISSING_MASKS] = {
        key: f"no {file} in the folder"
        for key, file in MIDDLEBURY_MASKS.items()
        if key not in masks
    }
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


#: The calibration of scikit-image's Motorcycle pair, as its ``stereo_motorcycle``
#: documents it for the images it ships (the 2014 calibration divided by 4).
MOTORCYCLE_CALIBRATION = Calibration(
    focal=994.978, baseline=193.001, cx=311.193, cy=254.877, doffs=31.086
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
        pixels here); ``max_disparity = 64`` (the ground truth spans about 7 to 60);
        ``calibration`` :data:`MOTORCYCLE_CALIBRATION` (baseline in mm).

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
        calibration=MOTORCYCLE_CALIBRATION,
        meta={
            "name": "motorcycle",
            "source": "skimage.data.stereo_motorcycle (Middlebury 2014, Motorcycle, reduced)",
            "masks": "'all' and 'nonocc' are both the pixels with finite ground truth; "
            "no occlusion mask is available",
            MASK_SOURCES: {
                "nonocc": KNOWN_TRUTH + " (no occlusion mask is available)",
                "all": KNOWN_TRUTH,
            },
            MISSING_MASKS: {"disc": "scikit-image ships no disc mask"},
            "citation": (
                "D. Scharstein et al. High-resolution stereo datasets with subpixel-accurate "
                "ground truth. GCPR 2014."
            ),
        },
    )


# --- any layout -----------------------------------------------------------------------

#: Scene layouts understood by :func:`load_scene`, and the files that identify each.
LAYOUTS = {
    "v2": ("left.png", "right.png", "disp_gt.png", "meta.json"),
    "2005/2006": ("view1.png", "view5.png", "disp1.png"),
    "2014": ("im0.png", "im1.png", "calib.txt"),
}
# and the KITTI layouts of dcstereo.evaluation.kitti.KITTI_LAYOUTS (kitti2012, kitti2015,
# kitti-pair).
# ETH3D's two-view folders (im0.png, im1.png, disp0GT.pfm, mask0nocc.png, calib.txt) are
# of the "2014" layout; their calib.txt may lack ndisp.

#: Image height of the full, half and third size 2005/2006 scenes, and the disparity
#: scale (stored gray value per pixel of disparity) of each.
SCALE_BY_HEIGHT_2005 = {1110: 1, 555: 2, 370: 3}

#: Largest disagreement, in pixels, between the left and the right ground truth of a
#: pixel that the cross-check still calls non-occluded.
CROSS_CHECK_TOLERANCE = 1.0


def scene_layout(folder: str | os.PathLike) -> str | None:
    """Layout of a scene folder (a key of :data:`LAYOUTS`), or None when it is not one.

    Parameters
    ----------
    folder : path-like
        A folder.

    Returns
    -------
    str or None
    """
    from dcstereo.evaluation.kitti import kitti_layout

    folder = Path(folder)
    kitti = kitti_layout(folder)  # first: a one-pair KITTI folder has the v2 file names
    if kitti is not None:
        return kitti
    for layout, files in LAYOUTS.items():
        if all((folder / name).is_file() for name in files):
            return layout
    return None


def find_scenes(root: str | os.PathLike) -> list[Path]:
    """Scene folders (of any layout) at or below ``root``, sorted by path.

    A scene folder is not searched further.

    Parameters
    ----------
    root : path-like
        A scene folder or a folder holding scene folders at any depth.

    Returns
    -------
    list of Path
        Empty when there is none or ``root`` does not exist.
    """
    root = Path(root)
    if scene_layout(root) is not None:
        return [root]
    found = []
    for current, dirs, _ in os.walk(root):
        dirs.sort()
        for name in list(dirs):
            if scene_layout(Path(current) / name) is not None:
                found.append(Path(current) / name)
                dirs.remove(name)
    return sorted(found)


def load_scene(
    folder: str | os.PathLike, *, scale: float | None = None, frame: str | int | None = None
) -> StereoScene:
    """Load a scene folder of any layout (:data:`LAYOUTS`, :data:`.kitti.KITTI_LAYOUTS`).

    Parameters
    ----------
    folder : path-like
        The scene folder.
    scale : float, optional
        2005/2006 layout only (other layouts refuse it: their files give the scale): stored
        gray value per pixel of disparity; default inferred from the image height
        (:data:`SCALE_BY_HEIGHT_2005`).
    frame : str or int, optional
        The frame of a KITTI training folder (``"000046_10"``), required there and refused
        elsewhere.

    Returns
    -------
    StereoScene
        Masks ``"all"`` (pixels with known ground truth) and ``"nonocc"`` always, ``"disc"``
        when the layout has one (v2 only). Without an occlusion mask or a right-view map,
        ``"nonocc"`` equals ``"all"`` and ``meta["nonocc"]`` says so.

    Raises
    ------
    ValueError
        When the folder matches no layout (the message names the files looked for), its
        files are inconsistent, or ``scale`` is given for a layout other than 2005/2006.

    Examples
    --------
    >>> scene = load_scene("shared/data/middlebury/tsukuba")  # doctest: +SKIP
    >>> scene.meta["layout"]  # doctest: +SKIP
    'v2'
    """
    folder = Path(folder).expanduser()
    layout = scene_layout(folder)
    if layout is None:
        expected = "; ".join(f"{key}: {', '.join(files)}" for key, files in LAYOUTS.items())
        raise ValueError(f"{folder} is not a scene folder of a known layout ({expected})")
    if scale is not None and layout != "2005/2006":
        raise ValueError(
            f"a ground-truth scale applies to 2005/2006 scenes only; {folder} is a "
            f"{layout} scene, whose files give the scale"
        )
    if layout.startswith("kitti"):
        from dcstereo.evaluation import kitti

        if scale is not None:
            raise ValueError(f"a ground-truth scale applies to 2005/2006 scenes only, not {folder}")
        if layout == "kitti-pair":
            if frame is not None:
                raise ValueError(f"{folder} holds one pair: it takes no frame")
            return kitti.load_pair(folder)
        if frame is None:
            found = kitti.frames(folder)
            raise ValueError(
                f"{folder} is a {layout} training folder of {len(found)} frames: give a frame "
                f"(--frame {found[0] if found else '000000_10'})"
            )
        return kitti.load_kitti(folder, frame)
    if frame is not None:
        raise ValueError(f"a frame applies to KITTI training folders only; {folder} is {layout}")
    if layout == "v2":
        scene = load_middlebury(folder)
        scene.meta.setdefault("layout", "v2")
        return scene
    if layout == "2005/2006":
        return _load_2005(folder, scale)
    return _load_2014(folder)


def _describe_masks(meta: dict, layout: str) -> None:
    """Record the sources of a derived scene's ``nonocc`` and ``all``, and its missing disc."""
    meta[MASK_SOURCES] = {"nonocc": meta["nonocc"], "all": KNOWN_TRUTH}
    meta[MISSING_MASKS] = {"disc": f"the {layout} layout has no disc mask"}


def _check_same_size(folder: Path, reference: np.ndarray, arrays: dict) -> None:
    for name, array in arrays.items():
        if array.shape[:2] != reference.shape[:2]:
            raise ValueError(
                f"{folder / name} is {array.shape[1]}x{array.shape[0]} pixels but the left "
                f"image is {reference.shape[1]}x{reference.shape[0]}"
            )


def cross_check(left_truth: np.ndarray, right_truth: np.ndarray, tolerance: float) -> np.ndarray:
    """Left pixels whose ground truth the right view's ground truth confirms.

    The left pixel ``x`` with disparity ``d`` lands on the right pixel ``round(x - d)``;
    it is visible in both views when that pixel is inside the image and its disparity
    differs from ``d`` by at most ``tolerance`` (how Middlebury derived its occlusion
    masks).

    Parameters
    ----------
    left_truth, right_truth : ndarray of float, shape (H, W)
        Ground truth of the left and of the right view, NaN where unknown.
    tolerance : float
        Largest disagreement in pixels.

    Returns
    -------
    ndarray of bool, shape (H, W)
    """
    if np.shape(left_truth) != np.shape(right_truth) or np.ndim(left_truth) != 2:
        raise ValueError(
            f"left_truth and right_truth must be 2-D maps of one shape, got "
            f"{np.shape(left_truth)} and {np.shape(right_truth)}"
        )
    height, width = left_truth.shape
    known = np.isfinite(left_truth)
    cols = np.arange(width)[None, :] - np.where(known, left_truth, 0.0)
    target = np.rint(cols).astype(np.int64)
    inside = known & (target >= 0) & (target < width)
    rows = np.broadcast_to(np.arange(height)[:, None], target.shape)
    partner = np.full(left_truth.shape, np.nan)
    partner[inside] = right_truth[rows[inside], target[inside]]
    with np.errstate(invalid="ignore"):
        return inside & (np.abs(partner - left_truth) <= tolerance)


def _load_2005(folder: Path, scale: float | None) -> StereoScene:
    left = _read_image(folder / "view1.png")
    right = _read_image(folder / "view5.png")
    gray = _read_gray(folder / "disp1.png")
    height = left.shape[0]
    if scale is None:
        scale = SCALE_BY_HEIGHT_2005.get(height)
        if scale is None:
            sizes = ", ".join(f"{h} (scale {s})" for h, s in SCALE_BY_HEIGHT_2005.items())
            raise ValueError(
                f"cannot infer the disparity scale of {folder}: its images are {height} "
                f"pixels high, not one of the Middlebury 2005/2006 sizes {sizes}; give the scale "
                "(load_scene(..., scale=S); dcstereo eval or bench --gt-scale S)"
            )
    elif not is_number(scale):
        raise TypeError(f"scale must be a number, got {type(scale).__name__}")
    elif not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"scale must be a positive number, got {scale}")
    arrays = {"view5.png": right, "disp1.png": gray}
    truth = np.where(gray == 0, np.nan, gray / float(scale)).astype(np.float32)
    known = np.isfinite(truth)
    meta = {"name": folder.name, "layout": "2005/2006", "scale": float(scale)}
    if (folder / "disp5.png").is_file():
        gray5 = _read_gray(folder / "disp5.png")
        arrays["disp5.png"] = gray5
        _check_same_size(folder, left, arrays)
        right_truth = np.where(gray5 == 0, np.nan, gray5 / float(scale))
        nonocc = cross_check(truth, right_truth, CROSS_CHECK_TOLERANCE)
        meta["nonocc"] = f"left-right cross-check with disp5.png, tolerance {CROSS_CHECK_TOLERANCE}"
    else:
        _check_same_size(folder, left, arrays)
        nonocc = known.copy()
        meta["nonocc"] = "no disp5.png: equals 'all' (occluded pixels included)"
    if not known.any():
        raise ValueError(f"{folder / 'disp1.png'} holds no known disparity (all 0)")
    max_disparity = int(math.ceil(float(np.nanmax(truth))))
    meta["max_disparity"] = "ceil of the largest ground-truth disparity (no ndisp in this layout)"
    _describe_masks(meta, "2005/2006")
    return StereoScene(
        name=folder.name,
        left=left,
        right=right,
        disparity=truth,
        masks={"nonocc": nonocc, "all": known},
        max_disparity=max_disparity,
        meta=meta,
    )


def _load_2014(folder: Path) -> StereoScene:
    truth_file = next(
        (name for name in ("disp0GT.pfm", "disp0.pfm") if (folder / name).is_file()), None
    )
    if truth_file is None:
        raise ValueError(f"2014 scene folder {folder} lacks disp0GT.pfm (or disp0.pfm)")
    calib = read_calib(folder / "calib.txt")
    try:  # ETH3D's calib.txt may have no ndisp: the ground truth's ceiling + 1 then
        ndisp = _integer(calib["ndisp"]) if "ndisp" in calib else None
    except ValueError:
        raise ValueError(f"{folder / 'calib.txt'} must give an integer ndisp") from None
    if ndisp is not None and ndisp < 1:
        raise ValueError(f"{folder / 'calib.txt'}: ndisp must be at least 1, got {ndisp}")
    left = _read_image(folder / "im0.png")
    right = _read_image(folder / "im1.png")
    stored = read_pfm(folder / truth_file)
    if stored.ndim != 2:
        raise ValueError(f"{folder / truth_file} must be a gray (Pf) PFM file")
    truth = np.where(np.isfinite(stored), stored, np.nan).astype(np.float32)
    if ndisp is None:
        if not np.isfinite(truth).any():
            raise ValueError(f"{folder / truth_file} holds no known disparity")
        ndisp = int(math.ceil(float(np.nanmax(truth)))) + 1
    arrays = {"im1.png": right, truth_file: truth}
    known = np.isfinite(truth)
    meta = {"name": folder.name, "layout": "2014", "ndisp": ndisp, "truth": truth_file}
    if (folder / "mask0nocc.png").is_file():
        mask = _read_gray(folder / "mask0nocc.png")
        arrays["mask0nocc.png"] = mask
        _check_same_size(folder, left, arrays)
        nonocc = (mask == 255) & known
        known &= mask != 0
        meta["nonocc"] = "mask0nocc.png == 255"
    elif (folder / "disp1.pfm").is_file():
        right_truth = read_pfm(folder / "disp1.pfm")
        if right_truth.ndim != 2:
            raise ValueError(f"{folder / 'disp1.pfm'} must be a gray (Pf) PFM file")
        arrays["disp1.pfm"] = right_truth
        _check_same_size(folder, left, arrays)
        right_truth = np.where(np.isfinite(right_truth), right_truth, np.nan)
        nonocc = cross_check(truth, right_truth, CROSS_CHECK_TOLERANCE)
        meta["nonocc"] = f"left-right cross-check with disp1.pfm, tolerance {CROSS_CHECK_TOLERANCE}"
    else:
        _check_same_size(folder, left, arrays)
        nonocc = known.copy()
        meta["nonocc"] = "no mask0nocc.png or disp1.pfm: equals 'all' (occluded pixels included)"
    _describe_masks(meta, "2014")
    return StereoScene(
        name=folder.name,
        left=left,
        right=right,
        disparity=truth,
        masks={"nonocc": nonocc, "all": known},
        max_disparity=ndisp - 1,
        meta=meta,
        calibration=Calibration.from_entries(calib, folder / "calib.txt"),
    )

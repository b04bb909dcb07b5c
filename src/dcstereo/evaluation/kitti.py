"""The robotics data sets' folders: KITTI 2012 and 2015 training folders, one-pair folders.

:func:`dcstereo.evaluation.datasets.load_scene` and
:func:`~dcstereo.evaluation.datasets.find_scenes` read these through the hooks here (the
Middlebury layouts are in :mod:`dcstereo.evaluation.datasets`; ETH3D's two-view folders
have the MiddEval3 files and are read there, see
:data:`dcstereo.evaluation.datasets.LAYOUTS`). Layouts (:data:`KITTI_LAYOUTS`):

``"kitti2012"``
    a KITTI 2012 training folder: ``colored_0/`` and ``colored_1/`` (or the gray
    ``image_0/`` and ``image_1/``), ``disp_occ/`` and optionally ``disp_noc/``, one
    ``<frame>.png`` in each per frame (``000046_10.png``);
``"kitti2015"``
    a KITTI 2015 training folder: ``image_2/``, ``image_3/``, ``disp_occ_0/`` and optionally
    ``disp_noc_0/``;
``"kitti-pair"``
    one KITTI pair in a folder, as ``shared/data/outdoor/`` holds them: ``left.png``,
    ``right.png``, ``disp_gt.png`` (16-bit) and ``meta.json`` with ``scale`` (256),
    ``ndisp`` and ``gt_type`` (``disp_occ`` or ``disp_noc``).

KITTI's ground truth is a 16-bit PNG, disparity = value / 256, 0 = none (LiDAR: sparse).
Its two regions are the masks ``"all"`` (``disp_occ``: every pixel with ground truth,
occluded ones included) and ``"nonocc"`` (``disp_noc``: the pixels visible in both views,
KITTI's "noc"; the project's name for it, as for Middlebury). A training folder holds many
frames: load one with ``load_scene(folder, frame="000046_10")``; :func:`frames` lists them.
KITTI gives no disparity range: ``max_disparity`` is the ceiling of the frame's largest
ground-truth disparity (``meta["max_disparity"]`` says so).

References
----------
A. Geiger, P. Lenz and R. Urtasun, "Are we ready for autonomous driving? The KITTI vision
benchmark suite", CVPR 2012. M. Menze and A. Geiger, "Object scene flow for autonomous
vehicles", CVPR 2015.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

#: KITTI's folders by layout: (left images, right images, ``disp_occ``, ``disp_noc``); the
#: 2012 layout's images are ``colored_*`` when present, else ``image_*``.
KITTI_FOLDERS: dict[str, tuple[tuple[str, ...], tuple[str, ...], str, str]] = {
    "kitti2012": (("colored_0", "image_0"), ("colored_1", "image_1"), "disp_occ", "disp_noc"),
    "kitti2015": (("image_2",), ("image_3",), "disp_occ_0", "disp_noc_0"),
}

#: Layouts read here, and what identifies each.
KITTI_LAYOUTS: dict[str, str] = {
    "kitti2012": "colored_0/ and colored_1/ (or image_0/ and image_1/), disp_occ/",
    "kitti2015": "image_2/, image_3/, disp_occ_0/",
    "kitti-pair": "left.png, right.png, 16-bit disp_gt.png, meta.json",
}

#: KITTI's ground truth: stored value per pixel of disparity.
KITTI_SCALE = 256.0


def kitti_layout(folder: str | os.PathLike) -> str | None:
    """Return the KITTI layout of ``folder`` (a key of :data:`KITTI_LAYOUTS`), or None."""
    folder = Path(folder)
    for layout, (lefts, rights, occ, _) in KITTI_FOLDERS.items():
        if (
            any((folder / name).is_dir() for name in lefts)
            and any((folder / name).is_dir() for name in rights)
            and (folder / occ).is_dir()
        ):
            return layout
    files = ("left.png", "right.png", "disp_gt.png", "meta.json")
    if all((folder / name).is_file() for name in files) and _is_16_bit(folder / "disp_gt.png"):
        return "kitti-pair"
    return None


def _is_16_bit(path: Path) -> bool:
    """Whether an image file holds 16-bit (or 32-bit integer) gray, from its header only."""
    from PIL import Image

    try:
        with Image.open(path) as image:
            return image.mode in ("I;16", "I;16B", "I;16L", "I")
    except Exception:  # a broken file: not this layout (load_scene then says why)
        return False


def frames(folder: str | os.PathLike) -> list[str]:
    """Frames of a KITTI training folder that have ground truth (``disp_occ``), sorted.

    Returns
    -------
    list of str
        Names such as ``"000046_10"``; empty when ``folder`` is not a KITTI training folder.
    """
    folder = Path(folder)
    layout = kitti_layout(folder)
    if layout not in KITTI_FOLDERS:
        return []
    occ = folder / KITTI_FOLDERS[layout][2]
    return sorted(p.stem for p in occ.glob("*.png"))


def frame_name(frame: str | int) -> str:
    """KITTI's file stem of a frame: ``46`` or ``"000046"`` -> ``"000046_10"``."""
    text = str(frame).strip()
    if text.endswith(".png"):
        text = text[:-4]
    number, sep, index = text.partition("_")
    if not number.isdigit() or (sep and not index.isdigit()):
        raise ValueError(f"a KITTI frame is a name such as 000046_10, got {frame!r}")
    return f"{int(number):06d}_{index if sep else '10'}"


def _folder_of(folder: Path, names: Sequence[str]) -> Path:
    return next((folder / name for name in names if (folder / name).is_dir()), folder / names[0])


def load_kitti(folder: str | os.PathLike, frame: str | int) -> Any:
    """Load one frame of a KITTI 2012 or 2015 training folder.

    Parameters
    ----------
    folder : path-like
        The training folder (the one holding ``colored_0/`` ... or ``image_2/`` ...).
    frame : str or int
        The frame, ``"000046_10"`` (or ``46``).

    Returns
    -------
    StereoScene
        Masks ``"all"`` (``disp_occ`` > 0) and ``"nonocc"`` (``disp_noc`` > 0, when the
        folder has ``disp_noc``); ``disparity`` from ``disp_occ``.

    Raises
    ------
    ValueError
        The folder is not a KITTI training folder, the frame has no ground truth (the
        message names a few that have), or one of its files is missing or of another size.
    """
    from dcstereo.evaluation.datasets import MASK_SOURCES, MISSING_MASKS, StereoScene, _read_image

    folder = Path(folder).expanduser()
    layout = kitti_layout(folder)
    if layout not in KITTI_FOLDERS:
        raise ValueError(f"{folder} is not a KITTI 2012 or 2015 training folder")
    name = frame_name(frame)
    lefts, rights, occ, noc = KITTI_FOLDERS[layout]
    occ_file = folder / occ / f"{name}.png"
    if not occ_file.is_file():
        have = frames(folder)
        shown = ", ".join(have[:5]) + (", ..." if len(have) > 5 else "")
        raise ValueError(
            f"{folder} has no frame {name} ({occ}/{name}.png is missing); it has "
            f"{len(have)} frames with ground truth: {shown or 'none'}"
        )
    files = {
        "left": _folder_of(folder, lefts) / f"{name}.png",
        "right": _folder_of(folder, rights) / f"{name}.png",
    }
    missing = [str(path.relative_to(folder)) for path in files.values() if not path.is_file()]
    if missing:
        raise ValueError(f"KITTI frame {name} in {folder} lacks {', '.join(missing)}")
    left = _read_image(files["left"])
    right = _read_image(files["right"])
    truth = _read_truth(occ_file, KITTI_SCALE)
    masks = {"all": np.isfinite(truth)}
    sources = {"all": f"{occ}/{name}.png > 0"}
    missing_masks = {"disc": "KITTI has no disc mask"}
    noc_file = folder / noc / f"{name}.png"
    if noc_file.is_file():
        noc_truth = _read_truth(noc_file, KITTI_SCALE)
        _same_size(noc_file, noc_truth, left)
        masks["nonocc"] = np.isfinite(noc_truth) & masks["all"]
        sources["nonocc"] = f"{noc}/{name}.png > 0 (KITTI's noc)"
    else:
        missing_masks["nonocc"] = f"no {noc}/{name}.png in the folder"
    for path, array in ((files["right"], right), (occ_file, truth)):
        _same_size(path, array, left)
    meta = {
        "name": name,
        "layout": layout,
        "frame": name,
        "kitti": True,
        "files": {key: str(path) for key, path in files.items()},
        MASK_SOURCES: sources,
        MISSING_MASKS: missing_masks,
        "max_disparity": "ceil of the largest ground-truth disparity (KITTI gives no range)",
    }
    return StereoScene(
        name=f"{folder.name}/{name}" if folder.name else name,
        left=left,
        right=right,
        disparity=truth,
        masks=masks,
        max_disparity=_ceil_max(truth, occ_file),
        meta=meta,
    )


def load_pair(folder: str | os.PathLike) -> Any:
    """Load a one-pair KITTI folder (``kitti-pair``: the ``shared/data/outdoor`` pairs).

    ``meta.json`` gives ``scale`` (default 256), ``ndisp`` (exclusive bound; default: the
    ceiling of the largest ground truth plus one) and ``gt_type``: ``disp_occ`` makes the
    ground truth's pixels the mask ``"all"``, ``disp_noc`` the mask ``"nonocc"``; the other
    is missing (KITTI publishes both, these folders keep one).

    Returns
    -------
    StereoScene
    """
    from dcstereo.evaluation.datasets import (
        MASK_SOURCES,
        MISSING_MASKS,
        StereoScene,
        _read_image,
        _read_meta,
    )

    folder = Path(folder).expanduser()
    meta = _read_meta(folder / "meta.json")
    if not isinstance(meta, dict):
        raise ValueError(f"{folder / 'meta.json'} must hold a JSON object")
    scale = float(meta.get("scale", KITTI_SCALE))
    if not (math.isfinite(scale) and scale > 0):
        raise ValueError(f"{folder / 'meta.json'}: scale must be positive, got {scale}")
    left = _read_image(folder / "left.png")
    right = _read_image(folder / "right.png")
    truth = _read_truth(folder / "disp_gt.png", scale)
    for path, array in ((folder / "right.png", right), (folder / "disp_gt.png", truth)):
        _same_size(path, array, left)
    gt_type = str(meta.get("gt_type", "disp_occ"))
    if gt_type not in ("disp_occ", "disp_noc"):
        raise ValueError(
            f"{folder / 'meta.json'}: gt_type must be disp_occ or disp_noc, got {gt_type!r}"
        )
    region, other = ("all", "nonocc") if gt_type == "disp_occ" else ("nonocc", "all")
    masks = {region: np.isfinite(truth)}
    meta = dict(meta)
    meta.update(layout="kitti-pair", kitti=True)
    meta[MASK_SOURCES] = {region: f"disp_gt.png > 0 ({gt_type})"}
    meta[MISSING_MASKS] = {
        other: f"the folder keeps KITTI's {gt_type} only",
        "disc": "KITTI has no disc mask",
    }
    if "ndisp" in meta:
        try:
            max_disparity = int(meta["ndisp"]) - 1
        except (TypeError, ValueError):
            raise ValueError(f"{folder / 'meta.json'}: ndisp must be an integer") from None
    else:
        max_disparity = _ceil_max(truth, folder / "disp_gt.png")
    return StereoScene(
        name=str(meta.get("name", folder.name)),
        left=left,
        right=right,
        disparity=truth,
        masks=masks,
        max_disparity=max_disparity,
        meta=meta,
    )


def _read_truth(path: Path, scale: float) -> np.ndarray:
    from dcstereo.io import read_disparity

    truth = read_disparity(path, scale=scale)
    if not np.isfinite(truth).any():
        raise ValueError(f"{path} holds no ground truth (every pixel is 0)")
    return truth


def _same_size(path: Path, array: np.ndarray, left: np.ndarray) -> None:
    if array.shape[:2] != left.shape[:2]:
        raise ValueError(
            f"{path} is {array.shape[1]}x{array.shape[0]} pixels but the left image is "
            f"{left.shape[1]}x{left.shape[0]}"
        )


def _ceil_max(truth: np.ndarray, path: Path) -> int:
    return max(1, int(math.ceil(float(np.nanmax(truth)))))


def expand_frames(folders: Iterable[Path]) -> list[Path | tuple[Path, str]]:
    """Replace each KITTI training folder in ``folders`` by its frames, ``(folder, frame)``."""
    items: list[Path | tuple[Path, str]] = []
    for folder in folders:
        if kitti_layout(folder) in KITTI_FOLDERS:
            names = frames(folder)
            if not names:
                raise ValueError(f"KITTI training folder {folder} has no frame with ground truth")
            items.extend((folder, name) for name in names)
        else:
            items.append(folder)
    return items


def is_kitti(scene: Any) -> bool:
    """Whether a scene is scored with KITTI's measures (a KITTI layout)."""
    return bool(getattr(scene, "meta", {}).get("kitti", False))


def kitti_table(rows: Sequence[dict], *, title: str | None = None) -> Any:
    """Build a rich table of KITTI's measures of :func:`dcstereo.evaluation.bench` rows.

    Columns: scene, method, then D1, bad-2 and bad-3 (%, dense maps) over ``noc`` (the
    mask ``nonocc``) and ``all``; ``-`` where a scene lacks the region or the row was not
    scored with KITTI's measures.
    """
    from rich.table import Table

    from dcstereo.evaluation.scoring import _cell

    table = Table(title=title)
    table.add_column("scene", no_wrap=True)
    table.add_column("method", no_wrap=True)
    for region in ("noc", "all"):  # KITTI's names of the regions
        for key in ("D1", "bad-2", "bad-3"):
            table.add_column(f"{key} {region} %", justify="right")
    for row in rows:
        cells = [
            _cell(row["dense"], region, key)
            for region in ("nonocc", "all")
            for key in ("d1", "bad-2.0", "bad-3.0")
        ]
        table.add_row(row["scene"], row["method"], *cells)
    return table

"""The scores the accuracy pins hold, taken as ``scripts/eval_stages.py`` takes them.

Dense maps (filled); Middlebury: bad-1.0 over ``nonocc``; KITTI: D1 over every pixel with
ground truth. One place for the measurement, so that every pin measures alike.
"""

import pytest

from dcstereo.evaluation.datasets import default_data_dir, load_scene
from dcstereo.evaluation.metrics import bad_pixel_rate, d1_rate
from dcstereo.evaluation.scoring import run_scene


def middlebury_bad1(root, name: str, method: str = "sgm", **options) -> float:
    """bad-1.0 (percent, ``nonocc``) of ``method`` with ``options`` on the scene ``root / name``."""
    scene = load_scene(root / name)
    result = run_scene(method, scene, **options).filled()
    mask = scene.masks["nonocc"]
    return bad_pixel_rate(result.disparity, scene.disparity, threshold=1.0, mask=mask)


def kitti_d1(name: str, method: str = "sgm", **options) -> float:
    """D1 (percent) of ``method`` with ``options`` on the outdoor pair ``name`` (skips without)."""
    folder = default_data_dir() / "outdoor" / name
    if not folder.is_dir():
        pytest.skip(f"outdoor data not found at {folder}")
    scene = load_scene(folder)  # the one-pair KITTI layout: truth NaN where it has none
    result = run_scene(method, scene, **options).filled()
    return d1_rate(result.disparity, scene.disparity)  # every pixel with truth

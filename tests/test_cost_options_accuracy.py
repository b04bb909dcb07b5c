"""Pins of the cost-side options of ``sgm`` (off by default) on development scenes.

Measured with ``scripts/eval_stages.py`` (dense maps, filled): a change that makes one
worse by more than a hundredth of a point fails here.
"""

import pytest

from dcstereo.evaluation.datasets import default_data_dir, load_scene
from dcstereo.evaluation.metrics import bad_pixel_rate, d1_rate
from dcstereo.evaluation.scoring import run_scene

#: The options that won outdoors: a sparse 5 x 7 census (step 2), census alone, larger
#: penalties kept across weaker edges.
OUTDOOR = {
    "census_window": (5, 7),
    "census_step": 2,
    "cost": "census",
    "p1": 80,
    "p2": 500,
    "p2_gradient": 10,
}


@pytest.mark.slow
@pytest.mark.dataset
@pytest.mark.parametrize(("options", "pinned"), [({}, 9.584), (OUTDOOR, 2.962)])
def test_outdoor_census_keeps_its_measured_d1(options, pinned):
    folder = default_data_dir() / "outdoor" / "kitti2012_000090_10"
    if not folder.is_dir():
        pytest.skip(f"outdoor data not found at {folder}")
    scene = load_scene(folder)  # the one-pair KITTI layout: truth NaN where it has none
    result = run_scene("sgm", scene, **options).filled()
    d1 = d1_rate(result.disparity, scene.disparity)  # every pixel with truth
    assert d1 <= pinned + 0.01, f"D1 {d1:.3f} % > {pinned}"


@pytest.mark.slow
@pytest.mark.dataset
def test_cross_support_keeps_its_measured_accuracy_on_midd1(middlebury_root):
    scene = load_scene(middlebury_root / "Midd1")
    options = {"aggregation": "cross", "cross_iterations": 1, "cross_limit": 7, "cross_tau": 15}
    result = run_scene("sgm", scene, **options).filled()
    bad = bad_pixel_rate(
        result.disparity, scene.disparity, threshold=1.0, mask=scene.masks["nonocc"]
    )
    assert bad <= 14.547 + 0.01, f"Midd1: bad-1.0 {bad:.3f} % > 14.547"


@pytest.mark.slow
@pytest.mark.dataset
@pytest.mark.parametrize(("name", "pinned"), [("Midd1", 14.562), ("teddy", 5.661)])
def test_cross_both_keeps_its_measured_accuracy(middlebury_root, name, pinned):
    # aggregation="cross-both" with its defaults (limit 5, tau 10, one round)
    scene = load_scene(middlebury_root / name)
    result = run_scene("sgm", scene, aggregation="cross-both").filled()
    mask = scene.masks["nonocc"]
    bad = bad_pixel_rate(result.disparity, scene.disparity, threshold=1.0, mask=mask)
    assert bad <= pinned + 0.01, f"{name}: bad-1.0 {bad:.3f} % > {pinned}"

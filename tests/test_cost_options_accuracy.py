"""Pins of the cost-side options of ``sgm`` (off by default) on development scenes.

Measured with ``scripts/eval_stages.py`` (dense maps, filled): a change that makes one
worse by more than a hundredth of a point fails here.
"""

import pytest

from pins import kitti_d1, middlebury_bad1

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
    d1 = kitti_d1("kitti2012_000090_10", **options)
    assert d1 <= pinned + 0.01, f"D1 {d1:.3f} % > {pinned}"


@pytest.mark.slow
@pytest.mark.dataset
def test_cross_support_keeps_its_measured_accuracy_on_midd1(middlebury_root):
    options = {"aggregation": "cross", "cross_iterations": 1, "cross_limit": 7, "cross_tau": 15}
    bad = middlebury_bad1(middlebury_root, "Midd1", **options)
    assert bad <= 14.547 + 0.01, f"Midd1: bad-1.0 {bad:.3f} % > 14.547"


@pytest.mark.slow
@pytest.mark.dataset
@pytest.mark.parametrize(("name", "pinned"), [("Midd1", 14.562), ("teddy", 5.661)])
def test_cross_both_keeps_its_measured_accuracy(middlebury_root, name, pinned):
    # aggregation="cross-both" with its defaults (limit 5, tau 10, one round)
    bad = middlebury_bad1(middlebury_root, name, aggregation="cross-both")
    assert bad <= pinned + 0.01, f"{name}: bad-1.0 {bad:.3f} % > {pinned}"

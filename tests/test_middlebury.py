"""Accuracy on the Middlebury development scenes (skipped when the data is absent)."""

import pytest

import dcstereo
from dcstereo.evaluation.datasets import load_middlebury
from dcstereo.evaluation.metrics import bad_pixel_rate

pytestmark = [pytest.mark.dataset, pytest.mark.slow]


@pytest.mark.parametrize(("scene", "limit"), [("tsukuba", 8.0), ("venus", 12.0)])
def test_dsi5_filled_bad1_nonocc(middlebury_root, scene, limit):
    data = load_middlebury(scene, root=middlebury_root.parent)
    result = dcstereo.match(
        data.left, data.right, max_disparity=data.max_disparity, method="dsi5", fill=True
    )
    bad = bad_pixel_rate(result.disparity, data.disparity, mask=data.masks["nonocc"])
    assert bad <= limit

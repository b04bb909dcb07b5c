"""A method is a named list of stages; the docs' defaults are the parameter records'."""

import numpy as np
import pytest

import dcstereo
from dcstereo import params as P
from dcstereo.methods import FILL, MEDIAN, REGISTRY, SUBPIXEL, Method, core
from dcstereo.methods._pipeline import Stage


def test_every_method_has_an_entry_and_starts_with_its_own_stage():
    assert tuple(REGISTRY) == P.METHODS
    for name, method in REGISTRY.items():
        assert method.name == name
        assert method.stages[0].name == name
        assert method.stages[-1] is FILL


def test_sgm_lists_its_stages_and_fits_its_own_subpixel():
    stages = REGISTRY["sgm"].stage_names()
    assert stages == ("sgm", "median", "fill")
    assert "semi-global paths" in REGISTRY["sgm"].stages[0].steps
    assert REGISTRY["dsi5"].stage_names() == ("dsi5", "subpixel", "median", "fill")


def test_stages_whose_option_is_off_are_skipped():
    calls = []

    def stage(name):
        def run(left, right, params, result):
            calls.append(name)
            return result

        return run

    method = Method(
        "toy",
        (
            Stage("first", stage("first")),
            Stage("off", stage("off"), when=lambda params: False),
            Stage("last", stage("last")),
        ),
    )
    params = P.MatchParams(max_disparity=2, method="dsi5")
    assert method.run(np.zeros((3, 3)), np.zeros((3, 3)), params) is None
    assert calls == ["first", "last"]
    assert str(method) == "toy: first -> off -> last"


def test_a_new_method_of_existing_stages_is_a_few_lines():
    """dsi5 without its median: the same map as dsi5 with median=0."""
    from dcstereo.methods.dsi import _match_dsi

    rng = np.random.default_rng(3)
    right = rng.integers(0, 256, (24, 40), dtype=np.uint8)
    left = np.roll(right, 2, axis=1)
    params = P.MatchParams(max_disparity=5, method="dsi5", median=3, fill=True)
    mine = Method("mine", (core("dsi5", _match_dsi, "costs + DP"), FILL))
    ours = mine.run(left, right, params)
    theirs = dcstereo.match(left, right, max_disparity=5, method="dsi5", median=0, fill=True)
    np.testing.assert_array_equal(ours.disparity, theirs.disparity)
    with_median = dcstereo.match(left, right, max_disparity=5, method="dsi5", median=3, fill=True)
    mine_median = Method("mine", (core("dsi5", _match_dsi, ""), SUBPIXEL, MEDIAN, FILL))
    np.testing.assert_array_equal(
        mine_median.run(left, right, params).disparity, with_median.disparity
    )


@pytest.mark.parametrize("method", ["sgm", None])
def test_match_docstring_states_the_records_defaults(method):
    doc = " ".join(dcstereo.match.__doc__.split())
    defaults = P.METHOD_DEFAULTS[method]
    label = "for ``sgm``" if method else "for the paper's methods"
    part = doc[doc.index(label) :]
    assert f"``window`` {defaults['window']}" in part
    assert f'``cost`` ``"{defaults["cost"]}"``' in part
    assert f"``fill`` {defaults['fill']}" in part
    assert f"``median`` {defaults['median']}" in part
    subpixel = defaults["subpixel"]
    assert (f'``subpixel`` ``"{subpixel}"``' if subpixel else "``subpixel`` None") in part
    if method == "sgm":
        for name, value in (
            ("census_window", P.DEFAULT_CENSUS_WINDOW),
            ("ad_truncation", P.DEFAULT_AD_TRUNCATION),
            ("p1", P.DEFAULT_P1),
            ("p2", P.DEFAULT_P2),
            ("p2_gradient", P.DEFAULT_P2_GRADIENT),
            ("paths", P.DEFAULT_PATHS),
            ("lr_tolerance", P.DEFAULT_LR_TOLERANCE),
        ):
            assert f"``{name}`` {value}" in doc, name
    else:
        assert f"``occlusion_cost`` {P.DEFAULT_OCCLUSION_COST}" in doc
    assert f'``"{P.DEFAULT_METHOD}"`` (default' in doc

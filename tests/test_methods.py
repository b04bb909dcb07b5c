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
    assert stages == ("sgm", "median", "edges", "fill")
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


def test_the_stages_of_a_run_share_a_store_that_ends_with_it():
    from dcstereo.methods._pipeline import run_shared

    seen = []

    def put(left, right, params, result):
        run_shared()["value"] = 7
        return result

    def take(left, right, params, result):
        seen.append(run_shared().pop("value", None))
        return result

    method = Method("toy", (Stage("put", put), Stage("take", take)))
    params = P.MatchParams(max_disparity=2, method="dsi5")
    assert run_shared() is None
    method.run(np.zeros((3, 3)), np.zeros((3, 3)), params)
    method.run(np.zeros((3, 3)), np.zeros((3, 3)), params)
    assert seen == [7, 7] and run_shared() is None
    # a failing run leaves nothing behind either
    method = Method("toy", (Stage("put", put), Stage("fail", lambda *args: 1 / 0)))
    with pytest.raises(ZeroDivisionError):
        method.run(np.zeros((3, 3)), np.zeros((3, 3)), params)
    assert run_shared() is None


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


COMMON = {"max_disparity", "min_disparity", "window", "cost", "fill", "subpixel", "median"}


@pytest.mark.parametrize("name", P.METHODS)
def test_each_method_has_a_record_of_the_options_it_reads(name):
    from dataclasses import fields

    record = REGISTRY[name].params
    assert record.METHOD == name
    own = {f.name for f in fields(record)} - COMMON
    reads = {option for option, readers in P.METHOD_OPTIONS.items() if name in readers}
    assert own == reads
    made = record(max_disparity=12)
    flat = P.MatchParams(max_disparity=12, method=name)
    for f in fields(record):  # the defaults are MatchParams', resolved for the method
        assert getattr(made, f.name) == getattr(flat, f.name), f.name
    assert made.match_params() == flat


def test_a_record_refuses_another_methods_option_and_checks_values_as_match_does():
    from dcstereo.methods.dc import DCParams
    from dcstereo.methods.sgm import SGMParams

    with pytest.raises(TypeError, match="p1"):
        DCParams(max_disparity=8, p1=10)
    with pytest.raises(ValueError, match=r"p2 \(10\) must be at least p1 \(60\)"):
        SGMParams(max_disparity=8, p2=10)
    with pytest.raises(ValueError, match=r"p2 \(10\) must be at least p1 \(60\)"):
        dcstereo.match(np.zeros((4, 9)), np.zeros((4, 9)), max_disparity=8, p2=10)
    record = SGMParams(max_disparity=8, p1=40, median=0)
    assert record.p1 == 40 and record.window == 3  # sgm's window, resolved
    with pytest.raises(AttributeError):
        record.p1 = 50  # frozen


def test_a_record_runs_as_its_options():
    from dataclasses import asdict

    from dcstereo.methods.dsi import DSI5Params

    rng = np.random.default_rng(5)
    right = rng.integers(0, 256, (20, 36), dtype=np.uint8)
    left = np.roll(right, 3, axis=1)
    record = DSI5Params(max_disparity=6, occlusion_cost=12.0, fill=True)
    ours = REGISTRY["dsi5"].run(left, right, record.match_params())
    theirs = dcstereo.match(left, right, method=record.METHOD, **asdict(record))
    np.testing.assert_array_equal(ours.disparity, theirs.disparity)

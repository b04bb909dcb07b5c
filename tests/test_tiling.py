"""Row-band tiling gives exactly the untiled result, serially and on Dask."""

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dcstereo import io, match
from dcstereo.batch.tiling import match_tiled, row_bands
from dcstereo.cli import main
from dcstereo.evaluation.synthetic import synthetic_sequence


@pytest.fixture(scope="module")
def dask_client():
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(
            n_workers=2, processes=True, threads_per_worker=1, dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        yield client


def assert_same_result(tiled, whole):
    np.testing.assert_array_equal(tiled.disparity, whole.disparity)
    np.testing.assert_array_equal(tiled.flags, whole.flags)
    np.testing.assert_array_equal(tiled.path_cost, whole.path_cost)
    if whole.features is None:
        assert tiled.features is None
    else:
        np.testing.assert_array_equal(tiled.features, whole.features)
    assert tiled.params == whole.params


def _pair(seed, height, width):
    frame = synthetic_sequence(
        1,
        height=height,
        width=width,
        background_disparity=(1, 4),
        foreground_disparity=8,
        seed=seed,
    )[0]
    return frame.left, frame.right


@pytest.mark.parametrize("method", ["dc", "dsi5", "dsi3", "block"])
@settings(
    max_examples=12,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    height=st.integers(5, 40),
    width=st.integers(24, 48),
    tile_rows=st.integers(1, 45),
    window=st.sampled_from([1, 3, 5]),
    seed=st.integers(0, 3),
)
def test_tiled_equals_untiled(method, height, width, tile_rows, window, seed):
    left, right = _pair(seed, height, width)
    kwargs = {"max_disparity": 10, "method": method, "window": window}
    whole = match(left, right, **kwargs)
    tiled = match_tiled(left, right, tile_rows=tile_rows, **kwargs)
    assert_same_result(tiled, whole)


def test_features_rows_are_offset_by_the_band_start():
    left, right = _pair(7, 48, 64)
    whole = match(left, right, max_disparity=14, method="dc")
    assert len(whole.features) > 0
    assert whole.features[:, 0].max() > 20  # rows of later bands are present
    tiled = match_tiled(left, right, tile_rows=7, max_disparity=14, method="dc")
    assert_same_result(tiled, whole)


def test_fill_is_tiled_too():
    left, right = _pair(2, 30, 48)
    whole = match(left, right, max_disparity=12, method="dsi5", fill=True)
    tiled = match_tiled(left, right, tile_rows=4, max_disparity=12, method="dsi5", fill=True)
    assert_same_result(tiled, whole)


def test_row_bands_cover_every_row_once_with_the_window_context():
    for height in range(1, 30):
        for tile_rows in (1, 2, 5, 40):
            bands = row_bands(height, tile_rows, 5)
            rows = np.concatenate([np.arange(b.start, b.stop) for b in bands])
            np.testing.assert_array_equal(rows, np.arange(height))
            for b in bands:
                assert b.read_start <= max(0, b.start - 2)
                assert b.read_stop >= min(height, b.stop + 2)
                assert b.read_stop - b.read_start >= min(5, height)


@pytest.mark.parametrize("bad", [0, -3])
def test_bad_tile_rows_is_refused(bad):
    left, right = _pair(0, 10, 30)
    with pytest.raises(ValueError, match="tile_rows"):
        match_tiled(left, right, tile_rows=bad, max_disparity=4)


def test_bad_match_options_fail_before_any_band():
    left, right = _pair(0, 10, 30)
    with pytest.raises(ValueError, match="window"):
        match_tiled(left, right, tile_rows=3, max_disparity=4, window=4)
    with pytest.raises(ValueError, match="differ in shape"):
        match_tiled(left, right[:, :-1], tile_rows=3, max_disparity=4)


def test_tiled_on_dask_equals_untiled(dask_client):
    left, right = _pair(5, 40, 56)
    whole = match(left, right, max_disparity=12, method="dc")
    tiled = match_tiled(left, right, tile_rows=9, client=dask_client, max_disparity=12, method="dc")
    assert_same_result(tiled, whole)


def test_cli_run_tile_rows_writes_the_untiled_disparity(tmp_path):
    left, right = _pair(3, 36, 50)
    io.write_rgb_png(tmp_path / "l.png", left)
    io.write_rgb_png(tmp_path / "r.png", right)
    runner = CliRunner()
    paths = [str(tmp_path / "l.png"), str(tmp_path / "r.png"), "--max-disparity", "12", "-q"]
    assert runner.invoke(main, ["run", *paths, "-o", str(tmp_path / "a.pfm")]).exit_code == 0
    tiled = runner.invoke(main, ["run", *paths, "-o", str(tmp_path / "b.pfm"), "--tile-rows", "5"])
    assert tiled.exit_code == 0, tiled.output
    assert (tmp_path / "a.pfm").read_bytes() == (tmp_path / "b.pfm").read_bytes()
    bad = runner.invoke(main, ["run", *paths, "-o", str(tmp_path / "c.pfm"), "--tile-rows", "0"])
    assert bad.exit_code != 0
    assert "tile_rows" in bad.output or "tile-rows" in bad.output


@pytest.mark.parametrize("fill", [False, True])
def test_subpixel_is_tiled_too(fill):
    left, right = _pair(5, 33, 48)
    kwargs = {"max_disparity": 12, "subpixel": "equiangular", "fill": fill}
    whole = match(left, right, **kwargs)
    assert (whole.disparity % 1 != 0).sum() > 50  # the refinement ran
    tiled = match_tiled(left, right, tile_rows=5, **kwargs)
    assert_same_result(tiled, whole)

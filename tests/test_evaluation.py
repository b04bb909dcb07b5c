import sys

import numpy as np
import pytest

import synthetic
from dcstereo.evaluation.datasets import StereoScene
from dcstereo.evaluation.scoring import (
    available_methods,
    bench,
    bench_table,
    json_rows,
    mean_rows,
    parse_methods,
    render,
    run_method,
    score,
)
from dcstereo.params import METHODS


def toy_scene(seed=7, name="toy", foreground=8):
    rng = np.random.default_rng(seed)
    left, right, truth = synthetic.object_pair(rng, 24, 64, 2, foreground, (24, 44))
    known = np.isfinite(truth)
    disc = np.zeros_like(known)
    disc[:, 20:28] = True
    disc &= known
    return StereoScene(
        name=name,
        left=left,
        right=right,
        disparity=truth,
        masks={"all": known, "nonocc": known.copy(), "disc": disc},
        max_disparity=10,
    )


def test_score_truth_against_itself_is_perfect():
    scene = toy_scene()
    scores = score(scene.disparity, scene)
    assert list(scores) == ["nonocc", "all", "disc"]
    for row in scores.values():
        assert row["bad-0.5"] == row["bad-1.0"] == row["bad-2.0"] == row["bad-4.0"] == 0.0
        assert row["mae"] == row["rms"] == 0.0 and row["density"] == 100.0


def test_score_counts_missing_as_bad_by_hand():
    scene = toy_scene()
    estimate = scene.disparity.copy()
    known = scene.masks["all"]
    rows, cols = np.nonzero(known)
    estimate[rows[:10], cols[:10]] = np.nan  # 10 holes
    estimate[rows[10:15], cols[10:15]] += 3.0  # 5 wrong by 3
    scores = score(estimate, scene)["all"]
    total = known.sum()
    assert scores["bad-1.0"] == pytest.approx(100 * 15 / total)
    assert scores["bad-4.0"] == pytest.approx(100 * 10 / total)
    assert scores["density"] == pytest.approx(100 * (total - 10) / total)
    assert scores["mae"] == pytest.approx(15 / (total - 10))


def test_score_rejects_other_sizes():
    with pytest.raises(ValueError, match="prediction is 5x4 pixels but scene toy is 64x24"):
        score(np.zeros((4, 5)), toy_scene())


def test_every_method_is_available_and_parsed():
    names = available_methods(include_opencv=False)
    assert names == list(METHODS)
    assert available_methods(include_opencv=True)[-3:] == ["opencv-sgbm", "opencv-hh", "opencv-bm"]
    assert parse_methods("dsi5, dc") == ["dsi5", "dc"]
    assert parse_methods(None) == available_methods()
    with pytest.raises(ValueError, match="unknown method 'nope'"):
        parse_methods("dc,nope")
    with pytest.raises(ValueError, match="repeated"):
        parse_methods("dc,dc")


def test_bench_rows_and_means():
    scenes = [toy_scene(7, "a"), toy_scene(8, "b", foreground=7)]
    seen = []
    rows = bench(scenes, ["block", "dsi5"], progress=lambda *args: seen.append(args[:2]))
    assert [(r["scene"], r["method"]) for r in rows] == [
        ("a", "block"),
        ("a", "dsi5"),
        ("b", "block"),
        ("b", "dsi5"),
    ]
    assert seen == [(r["scene"], r["method"]) for r in rows]
    for row in rows:
        assert row["seconds"] > 0
        assert row["dense"]["all"]["density"] == 100.0  # filled
        assert row["sparse"]["all"]["density"] <= 100.0
        assert row["dense"]["nonocc"]["bad-1.0"] < 20.0  # an easy textured scene
    means = mean_rows(rows)
    assert [m["method"] for m in means] == ["block", "dsi5"]
    expected = (rows[1]["dense"]["disc"]["bad-1.0"] + rows[3]["dense"]["disc"]["bad-1.0"]) / 2
    assert means[1]["dense"]["disc"]["bad-1.0"] == pytest.approx(expected)
    assert means[0]["scenes"] == 2
    text = render(bench_table(rows))
    assert text.count("mean") == 2 and "dsi5" in text
    assert all(
        "result" not in row for row in json_rows(bench(scenes[:1], ["block"], keep_results=True))
    )


def test_run_method_matches_match():
    import dcstereo

    scene = toy_scene()
    a = run_method("dsi3", scene.left, scene.right, max_disparity=10)
    b = dcstereo.match(scene.left, scene.right, max_disparity=10, method="dsi3")
    np.testing.assert_array_equal(a.disparity, b.disparity)


def test_bench_table_shows_the_chosen_threshold_and_the_mae():
    rows = bench([toy_scene()], ["dsi5"], thresholds=(1.0, 3.0))
    text = render(bench_table(rows, threshold=3))
    assert "bad-3.0 nonocc" in text and "bad-1.0" not in text and "mae nonocc" in text
    assert f"{rows[0]['dense']['nonocc']['mae']:.3f}" in text
    with pytest.raises(ValueError, match=r"not scored at the threshold 0.5 \(bad-0.5\)"):
        bench_table(rows, threshold=0.5)


def test_bench_match_options_reach_dcstereos_methods_only():
    import dcstereo

    pytest.importorskip("cv2")
    scene = toy_scene()
    options = {"subpixel": "parabola", "occlusion_cost": 12.0}
    rows = bench([scene], ["dc", "opencv-sgbm"], match_options=options, keep_results=True)
    ours = dcstereo.match(scene.left, scene.right, max_disparity=10, method="dc", **options)
    np.testing.assert_array_equal(rows[0]["result"].disparity, ours.disparity)
    assert rows[0]["result"].params.subpixel == "parabola"
    d = rows[0]["result"].disparity
    assert np.any(np.isfinite(d) & (d != np.floor(d)))  # refined
    plain = run_method("opencv-sgbm", scene.left, scene.right, max_disparity=10)
    np.testing.assert_array_equal(rows[1]["result"].disparity, plain.disparity)


# --- OpenCV --------------------------------------------------------------------------


def test_opencv_result_is_float_with_nan():
    pytest.importorskip("cv2")
    from dcstereo.compat.opencv import match_opencv

    rng = np.random.default_rng(11)
    right = rng.integers(0, 256, (40, 96), dtype=np.uint8)
    left = np.roll(right, 3, axis=1)
    for method in ("sgbm", "bm"):
        result = match_opencv(left, right, max_disparity=20, method=method)
        assert result.disparity.dtype == np.float32 and result.disparity.shape == (40, 96)
        assert result.params.num_disparities == 32  # 21 rounded up to a multiple of 16
        assert result.method == f"opencv-{method}"
        assert np.isnan(result.disparity).any()  # left border: no estimate
        np.testing.assert_array_equal(result.occluded, np.isnan(result.disparity))
        inner = result.disparity[8:-8, 40:-8]
        assert np.nanmedian(inner) == 3.0
        assert np.nanmax(result.disparity) <= 20
        dense = result.filled().disparity
        has_any = np.isfinite(result.disparity).any(axis=1)
        assert has_any.sum() > 20  # BM leaves whole border rows empty; fill is per row
        assert np.isfinite(dense[has_any]).all()


def test_opencv_validates_and_names_the_extra(monkeypatch):
    from dcstereo.compat.opencv import match_opencv

    image = np.zeros((10, 40), np.uint8)
    with pytest.raises(ValueError, match="window >= 5"):
        match_opencv(image, image, max_disparity=8, method="bm", window=3)
    with pytest.raises(ValueError, match="method must be 'sgbm' or 'bm'"):
        match_opencv(image, image, max_disparity=8, method="xx")
    monkeypatch.setitem(sys.modules, "cv2", None)
    with pytest.raises(ImportError, match=r"pip install \"dcstereo\[opencv\]\""):
        match_opencv(image, image, max_disparity=8)


def test_to_json_writes_null_for_non_finite_values():
    import json

    from dcstereo.evaluation.scoring import to_json

    payload = {"a": [1.5, float("nan"), np.float64("inf")], "b": {"c": -np.inf, "d": "x"}}
    assert json.loads(to_json(payload)) == {"a": [1.5, None, None], "b": {"c": None, "d": "x"}}
    scene = toy_scene()
    rows = bench([scene], ["block"])
    rows[0]["sparse"] = score(np.full(scene.shape, np.nan, np.float32), scene)
    text = to_json(json_rows(rows + mean_rows(rows)))
    assert "NaN" not in text and json.loads(text)[0]["sparse"]["all"]["mae"] is None


def test_bench_warms_each_method_up_on_the_rows_its_stages_need(monkeypatch):
    # the untimed first run: as many rows as the coarse pass of sgm's stages needs (64), so
    # that their kernels do not compile inside the first timed call; a shorter scene whole
    from dcstereo.evaluation import scoring

    rng = np.random.default_rng(3)
    left, right, truth = synthetic.object_pair(rng, 100, 80, 2, 6, (30, 50))
    known = np.isfinite(truth)
    tall = StereoScene("tall", left, right, truth, {"all": known, "nonocc": known}, 8)
    seen = []

    def run_method(method, left, right, **options):
        seen.append(left.shape)

    monkeypatch.setattr(scoring, "run_method", run_method)
    done = set()
    scoring._warm_up("sgm-accurate", tall, {}, done)
    scoring._warm_up("sgm-accurate", tall, {}, done)  # once a method
    scoring._warm_up("dc", toy_scene(), {}, done)
    assert scoring.WARM_UP_ROWS == 64
    assert seen == [(64, 80), (24, 64)]

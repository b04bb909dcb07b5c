"""eval, bench, compare, scanline and datasets through click's test runner."""

import json

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import synthetic
from dcstereo import io
from dcstereo.cli import main
from dcstereo.evaluation import downloads
from test_datasets import http_server, zipped_scene  # noqa: F401  (fixture)

HEIGHT, WIDTH = 24, 64


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def write_v2_scene(folder, seed=5, foreground=8):
    """A tiny scene in the v2 layout: object pair, gray = 4 * d."""
    rng = np.random.default_rng(seed)
    left, right, truth = synthetic.object_pair(rng, HEIGHT, WIDTH, 2, foreground, (24, 44))
    folder.mkdir(parents=True)
    known = np.isfinite(truth)
    gray = np.where(known, np.rint(4 * np.nan_to_num(truth)), 0).astype(np.uint8)
    mask = np.where(known, 255, 0).astype(np.uint8)
    disc = np.where(known, 128, 0).astype(np.uint8)
    disc[:, 20:28][known[:, 20:28]] = 255
    for name, array in [
        ("left.png", left),
        ("right.png", right),
        ("disp_gt.png", gray),
        ("nonocc.png", mask),
        ("all.png", mask),
        ("disc.png", disc),
    ]:
        Image.fromarray(array).save(folder / name)
    (folder / "meta.json").write_text(json.dumps({"name": folder.name, "scale": 4, "ndisp": 11}))
    return truth


def test_eval_truth_against_itself(tmp_path):
    truth = write_v2_scene(tmp_path / "toy")
    io.write_pfm(tmp_path / "gt.pfm", truth)
    result = invoke("eval", tmp_path / "gt.pfm", tmp_path / "toy", "--json")
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert report["scene"] == "toy" and report["layout"] == "v2"
    assert list(report["scores"]) == ["nonocc", "all", "disc"]
    for row in report["scores"].values():
        assert row["bad-0.5"] == 0.0 and row["mae"] == 0.0 and row["density"] == 100.0
    table = invoke("eval", tmp_path / "gt.pfm", tmp_path / "toy")
    assert table.exit_code == 0 and "nonocc" in table.output and "bad-1.0" in table.output


def test_eval_png16_with_holes(tmp_path):
    truth = write_v2_scene(tmp_path / "toy")
    estimate = truth.copy()
    estimate[:, :32] = np.nan  # no estimate on the left half
    io.write_disparity(tmp_path / "half.png", estimate)
    result = invoke("eval", tmp_path / "half.png", tmp_path / "toy", "--json")
    assert result.exit_code == 0, result.output
    scores = json.loads(result.output)["scores"]["all"]
    known = np.isfinite(truth)
    missing = 100 * known[:, :32].sum() / known.sum()
    assert scores["bad-1.0"] == pytest.approx(missing)
    assert scores["density"] == pytest.approx(100 - missing)


def test_eval_errors_are_one_line(tmp_path):
    write_v2_scene(tmp_path / "toy")
    io.write_pfm(tmp_path / "small.pfm", np.zeros((5, 5), np.float32))
    result = invoke("eval", tmp_path / "small.pfm", tmp_path / "toy")
    assert result.exit_code == 1
    assert result.output.count("\n") == 1 and "5x5 pixels" in result.output
    result = invoke("eval", tmp_path / "small.pfm", tmp_path)
    assert result.exit_code == 1 and "not a scene folder" in result.output
    assert "Traceback" not in result.output


def test_bench_table_and_json(tmp_path):
    write_v2_scene(tmp_path / "data" / "a", seed=5)
    write_v2_scene(tmp_path / "data" / "b", seed=6, foreground=7)
    out = tmp_path / "bench.json"
    result = invoke("bench", tmp_path / "data", "--methods", "block,dsi5", "--json", out, "--quiet")
    assert result.exit_code == 0, result.output
    for word in ("bad-1.0 nonocc", "disc", "mean", "block", "dsi5", "time ms"):
        assert word in result.output
    payload = json.loads(out.read_text())
    assert [(r["scene"], r["method"]) for r in payload["rows"]] == [
        ("a", "block"),
        ("a", "dsi5"),
        ("b", "block"),
        ("b", "dsi5"),
    ]
    assert payload["machine"]["numba_threads"] >= 1 and payload["window"] is None  # own
    assert payload["rows"][1]["dense"]["nonocc"]["bad-1.0"] < 20.0


def test_bench_subpixel_occlusion_cost_and_threshold(tmp_path):
    write_v2_scene(tmp_path / "data" / "a", seed=5)
    maes = {}
    for extra in ([], ["--subpixel", "parabola", "--occlusion-cost", "12", "--median", "3"]):
        out = tmp_path / f"bench{len(extra)}.json"
        result = invoke(
            "bench", tmp_path / "data", "--methods", "dc", "--threshold", "0.25", "--json", out,
            "--quiet", *extra,
        )  # fmt: skip
        assert result.exit_code == 0, result.output
        assert "bad-0.25 nonocc %" in result.output and "bad-1.0" not in result.output
        payload = json.loads(out.read_text())
        dense = payload["rows"][0]["dense"]["nonocc"]
        assert {"bad-0.25", "bad-0.5", "bad-1.0", "bad-2.0", "bad-4.0"} <= set(dense)
        maes[len(extra)] = dense["mae"]
        expected = {"subpixel": None}  # the others not given: each method's default
        if extra:
            expected = {"occlusion_cost": 12.0, "subpixel": "parabola", "median": 3}
        assert payload["match_options"] == expected
    assert maes[0] != maes[6]  # the refined, filtered map scores differently


def test_bench_method_options_reach_the_methods_that_read_them(tmp_path):
    # dc's options reach dc (with its extra tests off and no floor it accepts more pairs)
    # and leave dsi5's scores alone; an option that none of the methods run reads is
    # refused before any runs
    write_v2_scene(tmp_path / "data" / "a", seed=5)
    rows = {}
    for extra in ([], ["--edge-guard", "0", "--uniqueness", "0", "--feature-floor", "0"]):
        out = tmp_path / f"bench{len(extra)}.json"
        result = invoke(
            "bench", tmp_path / "data", "--methods", "dc,dsi5", "--json", out, "--quiet", *extra
        )
        assert result.exit_code == 0, result.output
        payload = json.loads(out.read_text())
        rows[len(extra)] = {r["method"]: r for r in payload["rows"]}
        if extra:
            assert payload["match_options"]["edge_guard"] == 0
            assert payload["match_options"]["uniqueness"] == 0.0
            assert payload["match_options"]["feature_floor"] == 0.0
        else:
            assert "edge_guard" not in payload["match_options"]
    assert rows[0]["dsi5"]["dense"] == rows[6]["dsi5"]["dense"]
    assert rows[0]["dc"]["features"] < rows[6]["dc"]["features"]
    for methods, message in [
        ("dsi5,block", "Error: --ser-min is read only by dc, dc-linear, none of the methods run "
         "(dsi5, block)"),
        ("dsi3+bt", "Error: --ser-min is read only by dc, dc-linear, not by dsi3+bt"),
    ]:  # fmt: skip
        result = invoke("bench", tmp_path / "data", "--methods", methods, "--ser-min", "3")
        lines = result.output.strip().splitlines()
        assert result.exit_code == 1 and lines == [message], lines
    result = invoke("bench", tmp_path / "data", "--methods", "dc+bt", "--ser-min", "3", "-q")
    assert result.exit_code == 0, result.output


def test_bench_bad_threshold_or_median_fails_before_running(tmp_path):
    write_v2_scene(tmp_path / "data" / "a", seed=5)
    for option, value, message in [
        ("--threshold", "0", "--threshold must be a positive number of pixels"),
        ("--threshold", "-1", "--threshold must be a positive number of pixels"),
        ("--threshold", "nan", "--threshold must be a positive number of pixels"),
        ("--median", "4", "--median must be 0 (off) or an odd integer from 3 to 15, got 4"),
    ]:
        result = invoke("bench", tmp_path / "data", "--methods", "block,dc", option, value)
        lines = result.output.strip().splitlines()
        assert result.exit_code == 1 and len(lines) == 1 and message in lines[0], lines


def test_bench_errors(tmp_path):
    (tmp_path / "empty").mkdir()
    result = invoke("bench", tmp_path / "empty", "--methods", "block")
    assert result.exit_code == 1 and "no scene folder" in result.output
    result = invoke("bench", tmp_path / "empty", "--methods", "block,magic")
    assert result.exit_code == 1 and "unknown method 'magic'" in result.output


def test_bench_gt_scale_reaches_the_2005_scenes_only(tmp_path):
    from test_datasets import write_2005_scene

    write_v2_scene(tmp_path / "data" / "a", seed=5)
    write_2005_scene(tmp_path / "data" / "s05", height=20)  # grays 6 and 12: 2 and 4 at scale 3
    result = invoke("bench", tmp_path / "data", "--methods", "block", "--quiet")
    assert result.exit_code == 1 and "bench --gt-scale S" in result.output
    assert "a:" not in result.output  # the v2 scene loads without a scale
    rows = {}
    for scale in (3, 1.5):
        out = tmp_path / f"bench{scale}.json"
        result = invoke(
            "bench", tmp_path / "data", "--methods", "block", "--gt-scale", scale, "--json",
            out, "--quiet",
        )  # fmt: skip
        assert result.exit_code == 0, result.output
        rows[scale] = {r["scene"]: r for r in json.loads(out.read_text())["rows"]}
    assert rows[3]["s05"]["max_disparity"] == 4 and rows[1.5]["s05"]["max_disparity"] == 8
    assert rows[3]["a"]["max_disparity"] == rows[1.5]["a"]["max_disparity"]
    result = invoke("bench", tmp_path / "data", "--methods", "block", "--gt-scale", 0)
    assert result.exit_code == 1 and "scale must be a positive number, got 0" in result.output


@pytest.fixture
def pair(tmp_path):
    truth = write_v2_scene(tmp_path / "toy")
    return tmp_path / "toy" / "left.png", tmp_path / "toy" / "right.png", truth


def panels(figure, rows, columns):
    """Split a compare figure into its panels (caption strips removed)."""
    out = {}
    for r in range(rows):
        for c in range(columns):
            top = r * (HEIGHT + 16) + 16
            left = c * (WIDTH + 4)
            out[r, c] = figure[top : top + HEIGHT, left : left + WIDTH]
    return out


def test_compare_with_ground_truth(pair, tmp_path):
    left, right, _ = pair
    out = tmp_path / "fig.png"
    result = invoke(
        "compare", left, right, "-o", out, "--max-disparity", 10, "--gt", tmp_path / "toy"
    )
    assert result.exit_code == 0, result.output
    figure = io.read_image(out)
    assert figure.shape == (3 * (HEIGHT + 16), 4 * (WIDTH + 4) - 4, 3)
    parts = panels(figure, 3, 4)
    assert not np.array_equal(parts[0, 0], parts[0, 1])  # left image vs dsi3
    assert not np.array_equal(parts[1, 0], parts[1, 3])  # ground truth vs dc in colour
    assert not np.array_equal(parts[0, 1], parts[1, 1])  # paper display vs colour
    red = (parts[2, 2] == [255, 0, 0]).all(axis=-1)
    gray = (parts[2, 2] == [200, 200, 200]).all(axis=-1)
    assert gray.sum() > red.sum()  # dsi5 is mostly right on this scene


def test_compare_without_truth_and_more_methods(pair, tmp_path):
    left, right, _ = pair
    out = tmp_path / "fig.png"
    result = invoke(
        "compare", left, right, "-o", out, "--max-disparity", 10, "--methods", "block,dc"
    )
    assert result.exit_code == 0, result.output
    figure = io.read_image(out)
    assert figure.shape == (2 * (HEIGHT + 16), 3 * (WIDTH + 4) - 4, 3)
    parts = panels(figure, 2, 3)
    assert not np.array_equal(parts[0, 1], parts[0, 2])  # block differs from dc


def test_compare_method_options_reach_dcstereos_methods_only(pair, tmp_path, monkeypatch):
    # dc's options go to dcstereo's methods (those that do not read one ignore it), never
    # to OpenCV's; an option none of the methods reads is refused before any runs
    from dcstereo.evaluation import scoring as evaluation

    left, right, _ = pair
    calls = {}
    real = evaluation.run_method

    def spy(method, *args, **kwargs):
        calls[method] = kwargs
        return real(method, *args, **kwargs)

    monkeypatch.setattr(evaluation, "run_method", spy)
    out = tmp_path / "fig.png"
    methods = "dc,dsi5,opencv-sgbm" if _opencv_installed() else "dc,dsi5"
    result = invoke(
        "compare", left, right, "-o", out, "--max-disparity", 10, "--methods", methods,
        "--ser-min", "7", "--slant-cost", "2",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert calls["dc"]["ser_min"] == 7.0 and calls["dc"]["slant_cost"] == 2.0
    assert calls["dsi5"]["slant_cost"] == 2.0
    if "opencv-sgbm" in calls:
        assert "ser_min" not in calls["opencv-sgbm"] and "slant_cost" not in calls["opencv-sgbm"]
    calls.clear()
    refused = invoke(
        "compare", left, right, "-o", tmp_path / "g.png", "--max-disparity", 10, "--methods",
        "block,dsi3", "--ser-min", "7",
    )  # fmt: skip
    assert refused.exit_code == 1 and calls == {} and not (tmp_path / "g.png").exists()
    assert refused.output.strip().splitlines() == [
        "Error: --ser-min is read only by dc, dc-linear, none of the methods run (block, dsi3)"
    ]


def _opencv_installed():
    import importlib.util

    return importlib.util.find_spec("cv2") is not None


def test_compare_errors(pair, tmp_path):
    left, right, _ = pair
    result = invoke("compare", left, right, "-o", tmp_path / "no" / "f.png", "--max-disparity", 9)
    assert result.exit_code == 1 and "does not exist" in result.output
    result = invoke(
        "compare", left, tmp_path / "missing.png", "-o", tmp_path / "f.png", "--max-disparity", 9
    )
    assert result.exit_code == 1 and result.output.count("\n") == 1


def test_scanline_picture(pair, tmp_path):
    left, right, _ = pair
    out = tmp_path / "row.png"
    result = invoke(
        "scanline",
        left,
        right,
        "--row",
        12,
        "--max-disparity",
        10,
        "-o",
        out,
        "--width",
        400,
        "--height",
        300,
    )
    assert result.exit_code == 0, result.output
    assert "feature pairs" in result.output
    picture = io.read_image(out)
    assert picture.shape == (300, 400, 3)
    top, bottom = picture[:150], picture[150:]
    assert not np.array_equal(top, bottom)
    assert (picture == [255, 255, 0]).all(axis=-1).any()  # the yellow feature circles
    result = invoke("scanline", left, right, "--row", 99, "--max-disparity", 10, "-o", out)
    assert result.exit_code == 1 and "row must be in 0..23" in result.output


def test_scanline_takes_the_method_options(pair, tmp_path):
    # --feature-floor reaches dc's row: the pairs it reports are those of a whole-image
    # run with the same option; refused for methods that do not read it
    import dcstereo

    left, right, _ = pair
    counts = {}
    for floor in ("0", "1e9"):
        out = tmp_path / f"row{floor}.png"
        result = invoke(
            "scanline", left, right, "--row", 12, "--max-disparity", 10, "-o", out,
            "--methods", "dc", "--feature-floor", floor, "--width", 400, "--height", 300,
        )  # fmt: skip
        assert result.exit_code == 0, result.output
        counts[floor] = int(result.output.split(", ")[-1].split()[0])
        full = dcstereo.match(
            io.read_image(left), io.read_image(right), max_disparity=10, method="dc",
            feature_floor=float(floor),
        )  # fmt: skip
        assert counts[floor] == int((full.features[:, 0] == 12).sum())
    assert counts["1e9"] == 0 < counts["0"]
    refused = invoke(
        "scanline", left, right, "--row", 12, "--max-disparity", 10, "-o", tmp_path / "r.png",
        "--methods", "dsi3,dsi5", "--feature-floor", "0",
    )  # fmt: skip
    assert refused.exit_code == 1 and not (tmp_path / "r.png").exists()
    assert "--feature-floor is read only by dc, dc-linear, none of the methods run" in (
        refused.output
    )


def test_scanline_data_matches_a_full_run(pair):
    import dcstereo
    from dcstereo.viz.explore import dsi_row, scanline

    left, right, _ = pair
    left, right = io.read_image(left), io.read_image(right)
    data = scanline(left, right, 1, max_disparity=10, methods=("dsi5", "dc"))
    full = dcstereo.match(left, right, max_disparity=10, method="dsi5")
    np.testing.assert_array_equal(data["paths"]["dsi5"], full.disparity[1])
    dsi = dsi_row(left, right, 1, max_disparity=10)
    assert dsi.shape == (11, WIDTH) and np.isnan(dsi[10, :10]).all()
    # A hand-computed cell: window 5 around (x=30, y=1), edge-replicated rows above.
    gray_l, gray_r = left.astype(float), right.astype(float)
    rows = np.clip(np.arange(-1, 4), 0, HEIGHT - 1)
    patch_l = gray_l[rows][:, 28:33]
    patch_r = gray_r[rows][:, 28 - 8 : 33 - 8]
    assert dsi[8, 30] == pytest.approx(np.abs(patch_l - patch_r).mean())
    feats = data["features"]["dc"]
    assert feats.shape[1] == 2 and (feats[:, 0] - feats[:, 1] >= 0).all()


def test_scanline_bt_names_run_with_the_bt_cost(pair):
    import dcstereo
    from dcstereo.viz.explore import scanline

    left, right, _ = pair
    left, right = io.read_image(left), io.read_image(right)
    data = scanline(left, right, 1, max_disparity=10, methods=("dsi5+bt", "dsi5"))
    assert list(data["paths"]) == ["dsi5+bt", "dsi5"]
    bt = dcstereo.match(left, right, max_disparity=10, method="dsi5", cost="bt")
    sad = dcstereo.match(left, right, max_disparity=10, method="dsi5")
    np.testing.assert_array_equal(data["paths"]["dsi5+bt"], bt.disparity[1])
    np.testing.assert_array_equal(data["paths"]["dsi5"], sad.disparity[1])


def test_datasets_list_and_fetch(tmp_path, http_server, monkeypatch):  # noqa: F811
    result = invoke("datasets", "list")
    assert result.exit_code == 0
    assert "art-2005-third" in result.output and "unverified" in result.output
    www, base = http_server
    digest = zipped_scene(tmp_path, www)
    entry = downloads.RegistryEntry(
        "toy", "2014", (downloads.RemoteFile(f"{base}/Toy.zip", digest),), "Toy", "", ""
    )
    monkeypatch.setitem(downloads.REGISTRY, "toy", entry)
    result = invoke("datasets", "fetch", "toy", "--cache", tmp_path / "cache")
    assert result.exit_code == 0, result.output
    assert result.output.strip().endswith(str(tmp_path / "cache" / "toy" / "Toy"))
    assert digest in result.output
    bad = downloads.RegistryEntry(
        "bad", "2014", (downloads.RemoteFile(f"{base}/Toy.zip", "1" * 64),), "Toy", "", ""
    )
    monkeypatch.setitem(downloads.REGISTRY, "bad", bad)
    result = invoke("datasets", "fetch", "bad", "--cache", tmp_path / "c2")
    assert result.exit_code == 1
    assert (
        result.output.startswith("Error: checksum mismatch for bad")
        and result.output.count("\n") == 1
    )
    assert [p for p in (tmp_path / "c2").rglob("*") if p.is_file()] == []
    result = invoke("datasets", "fetch", "art-2005-third", "--cache", tmp_path / "c3")
    assert result.exit_code == 1 and "not verified" in result.output


def test_eval_json_no_estimates_prints_null_not_nan(tmp_path):
    write_v2_scene(tmp_path / "toy")
    io.write_pfm(tmp_path / "empty.pfm", np.full((HEIGHT, WIDTH), np.nan, np.float32))
    result = invoke("eval", tmp_path / "empty.pfm", tmp_path / "toy", "--json")
    assert result.exit_code == 0, result.output
    assert "NaN" not in result.output
    scores = json.loads(result.output, parse_constant=pytest.fail)["scores"]["all"]
    assert scores["mae"] is None and scores["rms"] is None and scores["density"] == 0.0


def test_eval_broken_meta_json_names_the_file(tmp_path, monkeypatch):
    truth = write_v2_scene(tmp_path / "sc_badjson")
    (tmp_path / "sc_badjson" / "meta.json").write_text("{scale: 4}")
    io.write_pfm(tmp_path / "gt.pfm", truth)
    monkeypatch.chdir(tmp_path)
    result = invoke("eval", "gt.pfm", "sc_badjson")
    assert result.exit_code == 1
    assert result.output == (
        "Error: cannot read sc_badjson/meta.json: invalid JSON (line 1 column 2)\n"
    )


def test_bench_broken_scene_fails_before_any_run(tmp_path):
    write_v2_scene(tmp_path / "data" / "a", seed=5)
    write_v2_scene(tmp_path / "data" / "b", seed=6)
    (tmp_path / "data" / "b" / "meta.json").write_text("{scale: 4}")
    result = CliRunner().invoke(main, ["bench", str(tmp_path / "data"), "--methods", "block"])
    assert result.exit_code == 1
    assert result.output.count("\n") == 1 and "Traceback" not in result.output
    assert "1 of 2 scene folders" in result.output
    assert f"cannot read {tmp_path / 'data' / 'b' / 'meta.json'}: invalid JSON" in result.output
    assert " ms" not in result.output  # nothing ran, not even scene a


def test_eval_scale_options(tmp_path):
    truth = write_v2_scene(tmp_path / "toy")
    gray = np.where(np.isfinite(truth), np.rint(4 * np.nan_to_num(truth)), 0).astype(np.uint8)
    Image.fromarray(gray).save(tmp_path / "pred8.png")
    result = invoke("eval", tmp_path / "pred8.png", tmp_path / "toy", "--json")
    assert result.exit_code == 1 and "needs a scale" in result.output
    result = invoke("eval", tmp_path / "pred8.png", tmp_path / "toy", "--json", "--scale", 4)
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["scores"]["all"]["bad-0.5"] == 0.0
    # A 2005/2006 scene of no standard size: the ground truth's scale is --gt-scale.
    from test_datasets import write_2005_scene

    _, _, gray, _ = write_2005_scene(tmp_path / "s05", height=20)
    io.write_pfm(tmp_path / "o1.pfm", np.where(gray > 0, gray / 3.0, np.nan).astype(np.float32))
    result = invoke("eval", tmp_path / "o1.pfm", tmp_path / "s05")
    assert result.exit_code == 1 and "--gt-scale" in result.output
    result = invoke("eval", tmp_path / "o1.pfm", tmp_path / "s05", "--gt-scale", 3, "--json")
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["scores"]["nonocc"]["bad-0.5"] == 0.0
    result = invoke("eval", tmp_path / "pred8.png", tmp_path / "toy", "--scale", 4, "--gt-scale", 4)
    assert result.exit_code == 1 and "2005/2006 scenes only" in result.output
    assert "--scale" in invoke("eval", "--help").output


@pytest.mark.parametrize("command", ["bench", "compare", "scanline"])
def test_bench_compare_and_scanline_announce_compiling(command, tmp_path, monkeypatch):
    import dcstereo.api
    from dcstereo.cli._common import COMPILE_NOTICE
    from test_cli import compiling_first

    monkeypatch.setattr(dcstereo.api, "match", compiling_first(dcstereo.api.match))
    write_v2_scene(tmp_path / "data" / "toy")
    if command == "bench":
        args = ["bench", tmp_path / "data", "--methods", "dsi3,dsi5"]
    else:
        scene = tmp_path / "data" / "toy"
        args = [command, scene / "left.png", scene / "right.png", "-o", tmp_path / "fig.png"]
        args += ["--max-disparity", 10, "--methods", "dsi3,dsi5"]
        if command == "scanline":
            args += ["--row", 5]
    result = CliRunner().invoke(main, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    assert result.stderr.startswith(COMPILE_NOTICE + "\n")
    assert result.stderr.count(COMPILE_NOTICE) == 1  # once, though two methods compile
    if command == "bench":
        quiet = CliRunner().invoke(main, [str(a) for a in [*args, "--quiet"]])
        assert quiet.exit_code == 0 and quiet.stderr == ""

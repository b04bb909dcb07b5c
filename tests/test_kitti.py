"""KITTI 2012/2015 training folders, one-pair KITTI folders, ETH3D two-view, and D1."""

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import synthetic
from dcstereo import io
from dcstereo.cli import main
from dcstereo.evaluation.datasets import default_data_dir, find_scenes, load_scene, scene_layout
from dcstereo.evaluation.kitti import frame_name, frames
from dcstereo.evaluation.metrics import d1_rate, evaluate
from dcstereo.evaluation.scoring import bench_folder, evaluate_file

HEIGHT, WIDTH = 24, 64
OUTDOOR = default_data_dir() / "outdoor"


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def png16(path, disparity):
    """KITTI's ground truth: uint16, d * 256, 0 = none."""
    stored = np.where(np.isfinite(disparity), np.rint(np.nan_to_num(disparity) * 256), 0)
    Image.fromarray(stored.astype(np.uint16)).save(path)


def toy_pair(seed):
    rng = np.random.default_rng(seed)
    left, right, truth = synthetic.object_pair(rng, HEIGHT, WIDTH, 2, 8, (24, 44))
    occ = truth.copy()  # as disp_occ: the occluded band has ground truth too
    occ[np.isnan(occ)] = 2.0
    occ[:, :2] = np.nan
    sparse = rng.random(truth.shape) < 0.4  # LiDAR: sparse
    occ[sparse] = np.nan
    noc = np.where(np.isfinite(truth), occ, np.nan)
    return left, right, occ, noc


def write_kitti(root, layout, frames_=("000000_10", "000046_10"), gray=False):
    names = {
        "kitti2012": ("image_0", "image_1") if gray else ("colored_0", "colored_1"),
        "kitti2015": ("image_2", "image_3"),
    }[layout]
    occ_dir, noc_dir = (
        ("disp_occ", "disp_noc") if layout == "kitti2012" else ("disp_occ_0", "disp_noc_0")
    )
    for sub in (*names, occ_dir, noc_dir):
        (root / sub).mkdir(parents=True, exist_ok=True)
    truths = {}
    for index, frame in enumerate(frames_):
        left, right, occ, noc = toy_pair(index)
        if not gray:
            left, right = np.dstack([left] * 3), np.dstack([right] * 3)
        Image.fromarray(left).save(root / names[0] / f"{frame}.png")
        Image.fromarray(right).save(root / names[1] / f"{frame}.png")
        png16(root / occ_dir / f"{frame}.png", occ)
        png16(root / noc_dir / f"{frame}.png", noc)
        truths[frame] = (occ, noc)
    return truths


def test_d1_by_hand():
    truth = np.array([[10.0, 100.0, 100.0, 50.0, np.nan]])
    estimate = np.array([[13.5, 104.0, 106.0, np.nan, 0.0]])
    # 13.5: 3.5 > 3 and > 0.5: out; 104: 4 > 3 but 4 <= 5: in; 106: out; NaN: out
    assert d1_rate(estimate, truth) == pytest.approx(75.0)
    assert d1_rate(estimate, truth, mask=np.array([[True, True, False, False, True]])) == 50.0
    scores = evaluate(estimate, truth, {"all": np.isfinite(truth)}, (2.0, 3.0), d1=True)
    assert list(scores["all"])[:3] == ["d1", "bad-2.0", "bad-3.0"]
    assert "d1" not in evaluate(estimate, truth, {"all": np.isfinite(truth)})["all"]


@pytest.mark.parametrize(
    "layout, gray", [("kitti2012", False), ("kitti2012", True), ("kitti2015", False)]
)
def test_kitti_training_folder(tmp_path, layout, gray):
    truths = write_kitti(tmp_path / "training", layout, gray=gray)
    folder = tmp_path / "training"
    assert scene_layout(folder) == layout
    assert frames(folder) == ["000000_10", "000046_10"]
    assert find_scenes(tmp_path) == [folder]
    scene = load_scene(folder, frame="000046_10")
    occ, noc = truths["000046_10"]
    assert scene.left.ndim == (2 if gray else 3)
    np.testing.assert_allclose(scene.disparity, occ, atol=1 / 256)
    np.testing.assert_array_equal(scene.masks["all"], np.isfinite(occ))
    np.testing.assert_array_equal(scene.masks["nonocc"], np.isfinite(noc))
    assert scene.max_disparity == 8 and scene.meta["layout"] == layout
    assert load_scene(folder, frame=46).name == scene.name


def test_eval_kitti_frame_json_has_d1_per_region(tmp_path):
    truths = write_kitti(tmp_path / "training", "kitti2015")
    occ, noc = truths["000046_10"]
    estimate = np.where(np.isfinite(occ), occ, 5.0).astype(np.float32)
    estimate[:, 30:34] += 4.0  # 4 px off at d = 8: over 3 px and over 5 %: D1 outliers
    io.write_pfm(tmp_path / "pred.pfm", estimate)
    result = invoke(
        "eval", "--json", tmp_path / "pred.pfm", tmp_path / "training", "--frame", "000046_10"
    )
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert report["layout"] == "kitti2015"
    assert set(report["scores"]) == {"nonocc", "all"}
    for region, mask in (("all", np.isfinite(occ)), ("nonocc", np.isfinite(noc))):
        row = report["scores"][region]
        expected = 100 * np.mean(np.abs(estimate - occ)[mask] > 3)
        assert row["d1"] == pytest.approx(expected)
        assert {"bad-2.0", "bad-3.0", "bad-4.0"} <= set(row)
    table = invoke("eval", tmp_path / "pred.pfm", tmp_path / "training", "--frame", "46")
    assert table.exit_code == 0 and "d1" in table.output


def test_kitti_missing_frames_one_line(tmp_path):
    write_kitti(tmp_path / "training", "kitti2012")
    folder = tmp_path / "training"
    io.write_pfm(tmp_path / "pred.pfm", np.zeros((HEIGHT, WIDTH), np.float32))
    no_frame = invoke("eval", tmp_path / "pred.pfm", folder)
    assert no_frame.exit_code != 0 and "give a frame (--frame 000000_10)" in no_frame.output
    wrong = invoke("eval", tmp_path / "pred.pfm", folder, "--frame", "000099_10")
    assert wrong.exit_code != 0
    assert "has no frame 000099_10" in wrong.output and "000046_10" in wrong.output
    assert "Traceback" not in wrong.output and len(wrong.output.strip().splitlines()) == 1
    (folder / "colored_1" / "000046_10.png").unlink()
    lacking = invoke("eval", tmp_path / "pred.pfm", folder, "--frame", "000046_10")
    assert lacking.exit_code != 0 and "lacks colored_1/000046_10.png" in lacking.output
    with pytest.raises(ValueError, match="1 of 2 scene folders"):
        bench_folder(tmp_path, ["sgm"])
    with pytest.raises(ValueError, match="name such as 000046_10"):
        frame_name("abc")


def test_bench_kitti_folder_table(tmp_path):
    write_kitti(tmp_path / "training", "kitti2012")
    result = invoke("bench", tmp_path, "--methods", "sgm", "-q", "--json", tmp_path / "b.json")
    assert result.exit_code == 0, result.output
    assert "KITTI's measures" in result.output and "D1 noc %" in result.output
    assert "training/000046_10" in result.output
    rows = json.loads((tmp_path / "b.json").read_text())["rows"]
    assert len(rows) == 2 and all("d1" in row["dense"]["all"] for row in rows)


def write_pair_folder(folder, gt_type="disp_occ"):
    left, right, occ, noc = toy_pair(3)
    folder.mkdir(parents=True)
    Image.fromarray(left).save(folder / "left.png")
    Image.fromarray(right).save(folder / "right.png")
    truth = occ if gt_type == "disp_occ" else noc
    png16(folder / "disp_gt.png", truth)
    meta = {"name": folder.name, "scale": 256.0, "ndisp": 12, "gt_type": gt_type}
    (folder / "meta.json").write_text(json.dumps(meta))
    return left, right, truth


@pytest.mark.parametrize("gt_type, region", [("disp_occ", "all"), ("disp_noc", "nonocc")])
def test_one_pair_folder(tmp_path, gt_type, region):
    _, _, truth = write_pair_folder(tmp_path / "pair", gt_type)
    scene = load_scene(tmp_path / "pair")
    assert scene.meta["layout"] == "kitti-pair" and list(scene.masks) == [region]
    assert scene.max_disparity == 11
    io.write_disparity_png16(tmp_path / "pred.png", np.where(np.isfinite(truth), truth, 1.0))
    result = evaluate_file(tmp_path / "pred.png", tmp_path / "pair")
    assert result["scores"][region]["d1"] == 0.0
    assert region not in result["masks_missing"]


def test_eth3d_two_view(tmp_path):
    """ETH3D's files are MiddEval3's: im0/im1, disp0GT.pfm (inf = none), mask0nocc.png."""
    left, right, occ, noc = toy_pair(4)
    folder = tmp_path / "delivery_area_1l"
    folder.mkdir()
    Image.fromarray(left).save(folder / "im0.png")
    Image.fromarray(right).save(folder / "im1.png")
    io.write_pfm(folder / "disp0GT.pfm", np.where(np.isfinite(occ), occ, np.inf))
    mask = np.where(np.isfinite(noc), 255, np.where(np.isfinite(occ), 128, 0)).astype(np.uint8)
    Image.fromarray(mask).save(folder / "mask0nocc.png")
    (folder / "calib.txt").write_text(
        "cam0=[541.764 0 30.5; 0 541.764 11.5; 0 0 1]\ncam1=[541.764 0 30.5; 0 541.764 11.5; "
        "0 0 1]\ndoffs=0\nbaseline=59.9201\nwidth=64\nheight=24\nisint=0\nvmin=2\nvmax=8\n"
        "dyavg=0\ndymax=0\n"
    )  # no ndisp: ETH3D's files may lack it
    scene = load_scene(folder)
    assert scene.meta["layout"] == "2014" and scene.max_disparity == 8
    np.testing.assert_array_equal(scene.masks["nonocc"], np.isfinite(noc))
    np.testing.assert_array_equal(scene.masks["all"], np.isfinite(occ))
    assert scene.calibration.baseline == pytest.approx(59.9201)


# --- the shared outdoor pairs (skipped when absent) --------------------------------------


def outdoor_pairs():
    if not OUTDOOR.is_dir():
        return []
    return sorted(p for p in OUTDOOR.iterdir() if (p / "disp_gt.png").is_file())


@pytest.mark.dataset
def test_outdoor_pairs_load():
    pairs = outdoor_pairs()
    if not pairs:
        pytest.skip(f"no outdoor pairs at {OUTDOOR}")
    assert [scene_layout(p) for p in pairs] == ["kitti-pair"] * len(pairs)
    for folder in pairs[:3] + pairs[-2:]:
        scene = load_scene(folder)
        meta = json.loads((folder / "meta.json").read_text())
        region = "all" if meta["gt_type"] == "disp_occ" else "nonocc"
        known = np.isfinite(scene.disparity)
        assert list(scene.masks) == [region]
        assert known.mean() == pytest.approx(meta["gt_valid_fraction"], abs=1e-3)
        assert scene.max_disparity == meta["ndisp"] - 1


@pytest.mark.dataset
def test_outdoor_eval_matches_numpy(tmp_path):
    pairs = outdoor_pairs()
    if not pairs:
        pytest.skip(f"no outdoor pairs at {OUTDOOR}")
    folder = Path(pairs[0])
    stored = np.asarray(Image.open(folder / "disp_gt.png")).astype(np.float64)
    truth = np.where(stored > 0, stored / 256, np.nan)
    rng = np.random.default_rng(11)
    estimate = np.where(np.isfinite(truth), truth, 0) + rng.normal(0, 2.0, truth.shape)
    io.write_pfm(tmp_path / "pred.pfm", estimate.astype(np.float32))
    result = invoke("eval", "--json", tmp_path / "pred.pfm", folder)
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    (region,) = report["scores"]
    known = np.isfinite(truth)
    error = np.abs(estimate.astype(np.float32) - truth)[known]
    d1 = 100 * np.mean((error > 3) & (error > 0.05 * truth[known]))
    assert report["scores"][region]["d1"] == pytest.approx(d1, abs=1e-6)
    assert report["scores"][region]["bad-3.0"] == pytest.approx(100 * np.mean(error > 3))

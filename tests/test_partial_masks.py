"""Scene folders with only some of the v2 masks: scored on those, and the output says so."""

import json

import numpy as np
import pytest

from dcstereo import io
from dcstereo.evaluation.datasets import load_middlebury, load_scene
from dcstereo.evaluation.scoring import evaluate_file, mask_lines, missing_mask_lines, scene_masks
from test_cli_eval import invoke, write_v2_scene
from test_datasets import write_scene


@pytest.mark.parametrize(
    ("skip", "kept"),
    [
        (("all.png", "disc.png"), ["nonocc"]),
        (("nonocc.png",), ["all", "disc"]),
        (("disc.png",), ["nonocc", "all"]),
    ],
)
def test_a_folder_with_some_masks_loads_those(tmp_path, skip, kept):
    files = write_scene(tmp_path / "toy", skip=skip)
    scene = load_middlebury(tmp_path / "toy")
    assert sorted(scene.masks) == sorted(kept)
    for name in kept:
        np.testing.assert_array_equal(scene.masks[name], files[f"{name}.png"] == 255)
    report = scene_masks(scene)
    assert list(report["masks"]) == kept
    assert report["masks"] == {name: f"{name}.png" for name in kept}
    assert report["masks_missing"] == {
        file.removesuffix(".png"): f"no {file} in the folder" for file in skip
    }


def test_a_folder_without_masks_is_scored_on_the_known_truth(tmp_path):
    write_scene(tmp_path / "toy", skip=("nonocc.png", "all.png", "disc.png"))
    scene = load_scene(tmp_path / "toy")
    assert list(scene.masks) == ["all"]
    np.testing.assert_array_equal(scene.masks["all"], np.isfinite(scene.disparity))
    report = scene_masks(scene)
    assert report["masks"] == {"all": "every pixel with ground truth (the folder has no mask file)"}
    assert set(report["masks_missing"]) == {"nonocc", "disc"}


def test_other_layouts_say_they_have_no_disc(middlebury_root):
    scene = load_scene(middlebury_root / "Adirondack")
    report = scene_masks(scene)
    assert report["masks"] == {
        "nonocc": "mask0nocc.png == 255",
        "all": "every pixel with ground truth",
    }
    assert report["masks_missing"] == {"disc": "the 2014 layout has no disc mask"}
    assert scene_masks(load_scene(middlebury_root / "tsukuba"))["masks_missing"] == {}


def test_eval_scores_the_masks_present_and_says_which(tmp_path):
    truth = write_v2_scene(tmp_path / "toy")
    (tmp_path / "toy" / "all.png").unlink()
    (tmp_path / "toy" / "disc.png").unlink()
    estimate = truth.copy()
    estimate[:, :16] += 3.0  # wrong on a quarter of the columns
    io.write_pfm(tmp_path / "est.pfm", estimate)
    result = invoke("eval", tmp_path / "est.pfm", tmp_path / "toy", "--json")
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert list(report["scores"]) == ["nonocc"]
    known = np.isfinite(truth)
    expected = 100 * known[:, :16].sum() / known.sum()
    assert report["scores"]["nonocc"]["bad-1.0"] == pytest.approx(expected)
    assert report["masks"] == {"nonocc": "nonocc.png"}
    assert report["masks_missing"] == {
        "all": "no all.png in the folder",
        "disc": "no disc.png in the folder",
    }
    text = invoke("eval", tmp_path / "est.pfm", tmp_path / "toy")
    assert text.exit_code == 0, text.output
    assert "scored on: nonocc (nonocc.png)" in text.output
    assert (
        "not scored: all (no all.png in the folder), disc (no disc.png in the folder)"
        in text.output
    )


def test_eval_of_a_folder_without_masks(tmp_path):
    truth = write_v2_scene(tmp_path / "toy")
    for name in ("nonocc.png", "all.png", "disc.png"):
        (tmp_path / "toy" / name).unlink()
    io.write_pfm(tmp_path / "gt.pfm", truth)
    result = evaluate_file(tmp_path / "gt.pfm", tmp_path / "toy")
    assert list(result["scores"]) == ["all"]
    assert result["scores"]["all"]["bad-0.5"] == 0.0
    assert result["scores"]["all"]["density"] == 100.0
    lines = mask_lines(result)
    assert (
        lines[0] == "scored on: all (every pixel with ground truth (the folder has no mask file))"
    )
    assert lines[1].startswith("not scored: nonocc (no nonocc.png in the folder)")


def test_a_full_scene_prints_no_mask_lines(tmp_path):
    truth = write_v2_scene(tmp_path / "toy")
    io.write_pfm(tmp_path / "gt.pfm", truth)
    result = invoke("eval", tmp_path / "gt.pfm", tmp_path / "toy")
    assert result.exit_code == 0 and "scored" not in result.output


def test_bench_over_scenes_with_different_masks(tmp_path):
    write_v2_scene(tmp_path / "data" / "a", seed=5)
    write_v2_scene(tmp_path / "data" / "b", seed=6, foreground=7)
    (tmp_path / "data" / "b" / "disc.png").unlink()
    out = tmp_path / "bench.json"
    result = invoke("bench", tmp_path / "data", "--methods", "block", "--json", out)
    assert result.exit_code == 0, result.output
    assert (
        "disc: not scored on 1 of 2 scenes (no disc.png in the folder: b); its mean is over "
        "the other 1" in result.output
    )
    rows = json.loads(out.read_text())["rows"]
    assert [row["masks_missing"] for row in rows] == [{}, {"disc": "no disc.png in the folder"}]
    assert "disc" in rows[0]["dense"] and "disc" not in rows[1]["dense"]
    table_row = next(line for line in result.output.splitlines() if line.startswith("│ b "))
    assert "-" in table_row.split("│")[5]  # the disc cell
    quiet = invoke("bench", tmp_path / "data", "--methods", "block", "--quiet")
    assert quiet.exit_code == 0 and "not scored" not in quiet.output


def test_missing_mask_lines_group_the_reasons():
    rows = [
        {"scene": "a", "masks_missing": {}},
        {"scene": "b", "masks_missing": {"disc": "no disc.png in the folder"}},
        {"scene": "c", "masks_missing": {"disc": "the 2014 layout has no disc mask"}},
        {"scene": "c", "masks_missing": {"disc": "the 2014 layout has no disc mask"}},
        {"scene": "d", "masks_missing": {"disc": "no disc.png in the folder", "all": "x"}},
    ]
    assert missing_mask_lines(rows) == [
        "all: not scored on 1 of 4 scenes (x: d); its mean is over the other 3",
        "disc: not scored on 3 of 4 scenes (no disc.png in the folder: b, d; the 2014 layout "
        "has no disc mask: c); its mean is over the other 1",
    ]
    assert missing_mask_lines(rows[:1]) == []


def test_compare_with_a_scene_without_nonocc(pair, tmp_path):
    folder, _ = pair
    write_v2_scene(tmp_path / "toy")
    (tmp_path / "toy" / "nonocc.png").unlink()
    out = tmp_path / "fig.png"
    result = invoke(
        "compare", folder / "left.png", folder / "right.png", "-o", out, "--max-disparity", 10,
        "--gt", tmp_path / "toy", "--methods", "block",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert out.is_file()

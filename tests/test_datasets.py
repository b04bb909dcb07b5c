import json

import numpy as np
import pytest
from PIL import Image

from dcstereo.datasets import (
    StereoScene,
    default_data_dir,
    list_middlebury,
    load_middlebury,
    load_motorcycle,
    middlebury_dir,
)

MIDDLEBURY_SIZES = {
    "cones": (375, 450),
    "teddy": (375, 450),
    "tsukuba": (288, 384),
    "venus": (383, 434),
}
MIDDLEBURY_NDISP = {"cones": 60, "teddy": 60, "tsukuba": 16, "venus": 20}


def write_scene(folder, *, scale=4.0, ndisp=8, seed=0, skip=()):
    """Write a tiny 5x6 scene in the README layout; return what was written."""
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True)
    left = rng.integers(0, 256, (5, 6, 3), dtype=np.uint8)
    right = rng.integers(0, 256, (5, 6, 3), dtype=np.uint8)
    gray = rng.integers(1, 4 * ndisp, (5, 6), dtype=np.uint8)
    gray[0, :2] = 0  # unknown
    nonocc = np.where(rng.random((5, 6)) < 0.7, 255, 0).astype(np.uint8)
    nonocc[gray == 0] = 0
    full = np.where(gray > 0, 255, 0).astype(np.uint8)
    disc = np.where(nonocc == 255, 128, 0).astype(np.uint8)
    disc[2, :] = np.where(nonocc[2, :] == 255, 255, 0)
    files = {
        "left.png": left,
        "right.png": right,
        "disp_gt.png": gray,
        "nonocc.png": nonocc,
        "all.png": full,
        "disc.png": disc,
    }
    for name, array in files.items():
        if name not in skip:
            Image.fromarray(array).save(folder / name)
    meta = {"name": folder.name, "scale": scale, "ndisp": ndisp}
    if "meta.json" not in skip:
        (folder / "meta.json").write_text(json.dumps(meta))
    return files


def test_synthetic_scene_loads_exactly(tmp_path):
    files = write_scene(tmp_path / "middlebury" / "toy", scale=4.0, ndisp=8)
    scene = load_middlebury("toy", root=tmp_path)
    assert isinstance(scene, StereoScene)
    assert scene.name == "toy"
    assert scene.left.dtype == np.uint8 and scene.left.shape == (5, 6, 3)
    np.testing.assert_array_equal(scene.left, files["left.png"])
    np.testing.assert_array_equal(scene.right, files["right.png"])
    gray = files["disp_gt.png"]
    assert scene.disparity.dtype == np.float32 and scene.disparity.shape == (5, 6)
    assert np.isnan(scene.disparity[0, :2]).all()
    known = gray > 0
    np.testing.assert_array_equal(np.isfinite(scene.disparity), known)
    np.testing.assert_array_equal(scene.disparity[known], gray[known] / np.float32(4.0))
    assert set(scene.masks) == {"nonocc", "all", "disc"}
    for name, mask in scene.masks.items():
        assert mask.dtype == bool
        np.testing.assert_array_equal(mask, files[f"{name}.png"] == 255)
    # 128 in disc.png is not part of the disc mask.
    assert not scene.masks["disc"][[0, 1, 3, 4]].any()
    assert scene.max_disparity == 7 and scene.min_disparity == 0
    assert scene.meta["ndisp"] == 8
    assert scene.shape == (5, 6)
    assert repr(scene) == "StereoScene(name='toy', max_disparity=7, min_disparity=0)"


def test_scene_by_path_and_listing(tmp_path):
    write_scene(tmp_path / "middlebury" / "b_scene")
    write_scene(tmp_path / "middlebury" / "a_scene", seed=1)
    (tmp_path / "middlebury" / "not_a_scene").mkdir()
    assert list_middlebury(tmp_path) == ["a_scene", "b_scene"]
    by_path = load_middlebury(tmp_path / "middlebury" / "a_scene")
    by_str = load_middlebury(str(tmp_path / "middlebury" / "a_scene"))
    by_name = load_middlebury("a_scene", root=tmp_path)
    np.testing.assert_array_equal(by_path.left, by_name.left)
    np.testing.assert_array_equal(by_str.disparity, by_name.disparity)


def test_missing_scene_lists_the_available_ones(tmp_path):
    write_scene(tmp_path / "middlebury" / "toy")
    with pytest.raises(ValueError, match=r"unknown Middlebury scene 'nope'.*available: toy"):
        load_middlebury("nope", root=tmp_path)
    with pytest.raises(ValueError, match="available: none"):
        load_middlebury("nope", root=tmp_path / "empty")
    with pytest.raises(ValueError, match="left.png is missing"):
        load_middlebury(tmp_path / "nowhere")


def test_missing_files_and_bad_meta(tmp_path):
    write_scene(tmp_path / "a", skip=("disc.png",))
    with pytest.raises(ValueError, match="lacks disc.png"):
        load_middlebury(tmp_path / "a")
    folder = tmp_path / "b"
    write_scene(folder)
    (folder / "meta.json").write_text(json.dumps({"scale": 4}))
    with pytest.raises(ValueError, match="'ndisp'"):
        load_middlebury(folder)


def test_size_mismatch_is_reported(tmp_path):
    folder = tmp_path / "toy"
    write_scene(folder)
    Image.fromarray(np.zeros((4, 6), np.uint8)).save(folder / "nonocc.png")
    with pytest.raises(ValueError, match=r"nonocc.png is 6x4 pixels but left.png is 6x5"):
        load_middlebury(folder)


def test_default_data_dir(monkeypatch, tmp_path):
    monkeypatch.setenv("DCSTEREO_DATA", str(tmp_path))
    assert default_data_dir() == tmp_path
    assert middlebury_dir() == tmp_path / "middlebury"
    assert list_middlebury() == []
    monkeypatch.delenv("DCSTEREO_DATA")
    assert default_data_dir().parts[-2:] == ("shared", "data")


def test_scene_validates_shapes():
    image = np.zeros((4, 5, 3), np.uint8)
    with pytest.raises(ValueError, match="disparity has shape"):
        StereoScene("x", image, image, np.zeros((4, 4), np.float32), {}, 3)
    with pytest.raises(ValueError, match="mask 'all'"):
        StereoScene("x", image, image, np.zeros((4, 5), np.float32), {"all": np.ones((4, 5))}, 3)


@pytest.mark.dataset
@pytest.mark.parametrize("name", sorted(MIDDLEBURY_SIZES))
def test_real_middlebury_scene(middlebury_root, name):
    if name not in list_middlebury(middlebury_root.parent):
        pytest.skip(f"scene {name} not found in {middlebury_root}")
    scene = load_middlebury(name, root=middlebury_root.parent)
    height, width = MIDDLEBURY_SIZES[name]
    assert scene.left.shape == scene.right.shape == (height, width, 3)
    assert scene.left.dtype == np.uint8
    assert scene.disparity.shape == (height, width)
    assert scene.max_disparity == MIDDLEBURY_NDISP[name] - 1
    known = scene.disparity[np.isfinite(scene.disparity)]
    assert known.min() > 0 and known.max() < MIDDLEBURY_NDISP[name]  # ndisp is exclusive
    masks = scene.masks
    assert not (masks["nonocc"] & ~masks["all"]).any()
    assert not (masks["disc"] & ~masks["nonocc"]).any()
    assert np.isfinite(scene.disparity[masks["all"]]).all()
    assert 0 < masks["disc"].sum() < masks["nonocc"].sum() < masks["all"].sum()


@pytest.mark.dataset
def test_tsukuba_range(middlebury_root):
    scene = load_middlebury(middlebury_root / "tsukuba")
    assert scene.max_disparity == 15
    assert np.nanmin(scene.disparity) == 5.0 and np.nanmax(scene.disparity) == 14.0


def test_motorcycle():
    pytest.importorskip("skimage")
    scene = load_motorcycle()
    assert scene.left.shape == scene.right.shape == (500, 741, 3)
    assert scene.disparity.shape == (500, 741) and scene.disparity.dtype == np.float32
    assert not np.isinf(scene.disparity).any()
    assert np.isnan(scene.disparity).any()
    np.testing.assert_array_equal(scene.masks["all"], np.isfinite(scene.disparity))
    np.testing.assert_array_equal(scene.masks["nonocc"], scene.masks["all"])
    assert scene.max_disparity == 64
    assert 5 < np.nanmin(scene.disparity) and np.nanmax(scene.disparity) < scene.max_disparity

import json
import re

import numpy as np
import pytest
from PIL import Image

from dcstereo.evaluation.datasets import (
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
    write_scene(tmp_path / "a", skip=("disp_gt.png",))
    with pytest.raises(ValueError, match="lacks disp_gt.png"):
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


# --- load_scene: every layout -------------------------------------------------------

from dcstereo import io as dio  # noqa: E402
from dcstereo.evaluation.datasets import (  # noqa: E402
    cross_check,
    find_scenes,
    load_scene,
    read_calib,
    scene_layout,
)
from dcstereo.evaluation.downloads import REGISTRY, RegistryEntry, RemoteFile, fetch  # noqa: E402


def write_2005_scene(folder, *, height=370, width=12, with_right=True, seed=3):
    """A scene in the 2005/2006 layout: constant disparity 2 (gray 6 at third size)."""
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True)
    scale = {1110: 1, 555: 2, 370: 3}.get(height, 3)
    left = rng.integers(0, 256, (height, width, 3), dtype=np.uint8)
    right = rng.integers(0, 256, (height, width, 3), dtype=np.uint8)
    gray = np.full((height, width), 2 * scale, np.uint8)
    gray[:, :2] = 0  # unknown left border
    gray[5, 6] = 4 * scale  # disagrees with the right view: occluded by the cross-check
    right_gray = np.full((height, width), 2 * scale, np.uint8)
    Image.fromarray(left).save(folder / "view1.png")
    Image.fromarray(right).save(folder / "view5.png")
    Image.fromarray(gray).save(folder / "disp1.png")
    if with_right:
        Image.fromarray(right_gray).save(folder / "disp5.png")
    return left, right, gray, scale


def test_2005_layout_third_size(tmp_path):
    folder = tmp_path / "Art"
    left, right, gray, scale = write_2005_scene(folder)
    assert scale == 3 and scene_layout(folder) == "2005/2006"
    scene = load_scene(folder)
    assert scene.name == "Art" and scene.meta["layout"] == "2005/2006"
    np.testing.assert_array_equal(scene.left, left)
    np.testing.assert_array_equal(scene.right, right)
    assert np.isnan(scene.disparity[:, :2]).all()
    assert scene.disparity[0, 5] == 2.0 and scene.disparity[5, 6] == 4.0
    np.testing.assert_array_equal(scene.masks["all"], gray > 0)
    expected = gray > 0
    expected[5, 6] = False  # right view says 2, left says 4: more than 1 apart
    np.testing.assert_array_equal(scene.masks["nonocc"], expected)
    assert "disc" not in scene.masks
    assert scene.max_disparity == 4


def test_2005_layout_scale_from_size_or_argument(tmp_path):
    write_2005_scene(tmp_path / "half", height=555, with_right=False)
    scene = load_scene(tmp_path / "half")
    assert np.nanmax(scene.disparity) == 4.0 and scene.meta["scale"] == 2.0
    np.testing.assert_array_equal(scene.masks["nonocc"], scene.masks["all"])
    write_2005_scene(tmp_path / "odd", height=20)
    with pytest.raises(ValueError, match="cannot infer the disparity scale.*20 pixels high"):
        load_scene(tmp_path / "odd")
    assert np.nanmax(load_scene(tmp_path / "odd", scale=3).disparity) == 4.0


def write_2014_scene(folder, *, mask=True, right_pfm=False, ndisp=16, seed=4):
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True)
    left = rng.integers(0, 256, (6, 9, 3), dtype=np.uint8)
    right = rng.integers(0, 256, (6, 9, 3), dtype=np.uint8)
    truth = rng.uniform(1, 4, (6, 9)).astype(np.float32)
    truth[0, 0] = np.inf
    Image.fromarray(left).save(folder / "im0.png")
    Image.fromarray(right).save(folder / "im1.png")
    dio.write_pfm(folder / "disp0GT.pfm", truth)
    (folder / "calib.txt").write_text(
        "cam0=[1 0 0; 0 1 0; 0 0 1]\ndoffs=0\nbaseline=100\nwidth=9\nheight=6\n"
        f"ndisp={ndisp}\nvmin=1\nvmax=4\n"
    )
    codes = np.full((6, 9), 255, np.uint8)
    codes[1, :3] = 128
    codes[2, 4] = 0
    if mask:
        Image.fromarray(codes).save(folder / "mask0nocc.png")
    if right_pfm:
        dio.write_pfm(folder / "disp1.pfm", np.full((6, 9), 100.0, np.float32))
    return left, truth, codes


def test_2014_layout_with_mask(tmp_path):
    folder = tmp_path / "Adirondack"
    left, truth, codes = write_2014_scene(folder)
    assert scene_layout(folder) == "2014"
    scene = load_scene(folder)
    np.testing.assert_array_equal(scene.left, left)
    assert np.isnan(scene.disparity[0, 0])
    np.testing.assert_allclose(scene.disparity[1:], truth[1:])
    known = np.isfinite(truth) & (codes != 0)
    np.testing.assert_array_equal(scene.masks["all"], known)
    np.testing.assert_array_equal(scene.masks["nonocc"], known & (codes == 255))
    assert not scene.masks["nonocc"][1, :3].any() and scene.masks["all"][1, :3].all()
    assert not scene.masks["all"][2, 4]
    assert scene.max_disparity == 15 and scene.meta["ndisp"] == 16
    assert read_calib(folder / "calib.txt")["baseline"] == "100"


def test_2014_layout_cross_check_and_no_mask(tmp_path):
    write_2014_scene(tmp_path / "a", mask=False, right_pfm=True)
    scene = load_scene(tmp_path / "a")
    assert not scene.masks["nonocc"].any()  # the right view disagrees everywhere
    assert scene.masks["all"].sum() == 6 * 9 - 1
    write_2014_scene(tmp_path / "b", mask=False)
    scene = load_scene(tmp_path / "b")
    np.testing.assert_array_equal(scene.masks["nonocc"], scene.masks["all"])
    (tmp_path / "b" / "calib.txt").write_text("width=9\n")
    # no ndisp (ETH3D's calib.txt may lack it): the ground truth's ceiling bounds the range
    no_ndisp = load_scene(tmp_path / "b")
    assert no_ndisp.max_disparity == int(np.ceil(np.nanmax(no_ndisp.disparity)))
    (tmp_path / "b" / "calib.txt").write_text("width=9\nndisp=7.5\n")
    with pytest.raises(ValueError, match="integer ndisp"):
        load_scene(tmp_path / "b")


def test_cross_check_by_hand():
    left = np.array([[np.nan, 1.0, 1.0, 2.0, 0.0]])
    right = np.array([[1.0, 1.0, 5.0, 0.0, 0.0]])
    # x=1 -> right 0 (1 vs 1 ok); x=2 -> 1 (ok); x=3 -> 1 (1 vs 2: ok at tol 1); x=4 -> 4 (0 ok)
    np.testing.assert_array_equal(cross_check(left, right, 1.0), [[False, True, True, True, True]])
    np.testing.assert_array_equal(cross_check(left, right, 0.5), [[False, True, True, False, True]])


def test_load_scene_v2_and_unknown_folder(tmp_path):
    write_scene(tmp_path / "toy")
    scene = load_scene(tmp_path / "toy")
    assert scene.meta["layout"] == "v2" and set(scene.masks) == {"nonocc", "all", "disc"}
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="not a scene folder of a known layout.*view1.png"):
        load_scene(tmp_path / "empty")


def test_find_scenes_walks_every_layout(tmp_path):
    write_scene(tmp_path / "v2" / "toy")
    write_2005_scene(tmp_path / "2005" / "Art", height=20)
    write_2014_scene(tmp_path / "deep" / "er" / "Pipes")
    (tmp_path / "nothing").mkdir()
    found = find_scenes(tmp_path)
    assert [p.name for p in found] == ["Art", "Pipes", "toy"]
    assert find_scenes(tmp_path / "v2" / "toy") == [tmp_path / "v2" / "toy"]
    assert find_scenes(tmp_path / "missing") == []


@pytest.mark.dataset
def test_load_scene_reads_the_dev_data(middlebury_root):
    scene = load_scene(middlebury_root / "tsukuba")
    reference = load_middlebury("tsukuba", root=middlebury_root.parent)
    np.testing.assert_array_equal(scene.disparity, reference.disparity)
    assert len(find_scenes(middlebury_root)) >= 4


# --- registry and fetcher -----------------------------------------------------------


def test_registry_entries_are_consistent():
    assert len(REGISTRY) > 20
    for name, entry in REGISTRY.items():
        assert entry.name == name
        assert entry.layout in ("2005/2006", "2014")
        assert entry.files and all(f.url.startswith("https://") for f in entry.files)
        for remote in entry.files:
            assert remote.sha256 is None or len(remote.sha256) == 64


@pytest.fixture
def http_server(tmp_path, monkeypatch):
    """A local HTTP server on 127.0.0.1 serving tmp_path/www, stopped after the test."""
    import functools
    import http.server
    import threading

    root = tmp_path / "www"
    root.mkdir()
    for var in ("HTTP_PROXY", "http_proxy", "HTTPS_PROXY", "https_proxy", "ALL_PROXY"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setenv("NO_PROXY", "127.0.0.1,localhost")

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass

    handler = functools.partial(Quiet, directory=str(root))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield root, f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()
        thread.join()


def zipped_scene(tmp_path, www):
    """Zip a 2014-layout scene folder 'Toy' into www/Toy.zip; return its sha256."""
    import hashlib
    import zipfile

    source = tmp_path / "src" / "Toy"
    write_2014_scene(source)
    with zipfile.ZipFile(www / "Toy.zip", "w") as bundle:
        for path in sorted(source.iterdir()):
            bundle.write(path, f"Toy/{path.name}")
    return hashlib.sha256((www / "Toy.zip").read_bytes()).hexdigest()


def test_fetch_downloads_checks_and_extracts(tmp_path, http_server):
    www, base = http_server
    digest = zipped_scene(tmp_path, www)
    registry = {
        "toy": RegistryEntry("toy", "2014", (RemoteFile(f"{base}/Toy.zip", digest),), "Toy", "", "")
    }
    cache = tmp_path / "cache"
    folder, hashes = fetch("toy", cache=cache, registry=registry)
    assert folder == cache / "toy" / "Toy"
    assert hashes == {f"{base}/Toy.zip": digest}
    scene = load_scene(folder)
    assert scene.shape == (6, 9) and scene.max_disparity == 15
    (www / "Toy.zip").unlink()  # a second call uses the cache
    assert fetch("toy", cache=cache, registry=registry)[0] == folder


def test_fetch_checksum_mismatch_leaves_nothing(tmp_path, http_server):
    www, base = http_server
    digest = zipped_scene(tmp_path, www)
    wrong = "0" * 64
    registry = {
        "toy": RegistryEntry("toy", "2014", (RemoteFile(f"{base}/Toy.zip", wrong),), "Toy", "", "")
    }
    cache = tmp_path / "cache"
    with pytest.raises(ValueError) as info:
        fetch("toy", cache=cache, registry=registry)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith("checksum mismatch for toy")
    assert digest in message and wrong in message
    assert [p for p in cache.rglob("*") if p.is_file()] == []
    assert not (cache / "toy").exists()


def test_fetch_refuses_unverified_and_unknown(tmp_path, http_server):
    www, base = http_server
    digest = zipped_scene(tmp_path, www)
    registry = {
        "toy": RegistryEntry("toy", "2014", (RemoteFile(f"{base}/Toy.zip"),), "Toy", "", "")
    }
    with pytest.raises(ValueError, match="not verified"):
        fetch("toy", cache=tmp_path / "cache", registry=registry)
    assert not (tmp_path / "cache").exists()
    folder, hashes = fetch(
        "toy", cache=tmp_path / "cache", registry=registry, allow_unverified=True
    )
    assert hashes[f"{base}/Toy.zip"] == digest and scene_layout(folder) == "2014"
    with pytest.raises(ValueError, match="unknown dataset 'nope'"):
        fetch("nope", registry=registry)
    with pytest.raises(OSError, match="cannot download"):
        registry["gone"] = RegistryEntry(
            "gone", "2014", (RemoteFile(f"{base}/no.zip"),), "", "", ""
        )
        fetch("gone", cache=tmp_path / "c2", registry=registry, allow_unverified=True)


def test_broken_meta_json_names_the_file_and_the_place(tmp_path):
    folder = tmp_path / "sc_badjson"
    write_scene(folder)
    (folder / "meta.json").write_text('{"scale": 4,\n "ndisp" 8}')
    message = f"cannot read {folder / 'meta.json'}: invalid JSON (line 2 column 10)"
    with pytest.raises(ValueError, match=re.escape(message)):
        load_middlebury(folder)
    (folder / "meta.json").write_bytes(b'{"name": "\xff"}')
    with pytest.raises(ValueError, match="meta.json: it is not UTF-8 text"):
        load_middlebury(folder)


def test_scene_of_a_gray_left_and_a_colour_right_loads(tmp_path):
    folder = tmp_path / "mixed"
    files = write_scene(folder)
    Image.fromarray(files["left.png"][:, :, 0]).save(folder / "left.png")
    scene = load_middlebury(folder)
    assert scene.left.shape == (5, 6) and scene.right.shape == (5, 6, 3)
    with pytest.raises(ValueError, match="differ in shape"):
        StereoScene("x", scene.left, scene.right[:, :-1], scene.disparity, {}, 3)

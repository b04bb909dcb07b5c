import os
import shutil
import struct

import numpy as np
import pytest
from PIL import Image

from dcstereo import io


def _listing(directory):
    return sorted(p.name for p in directory.iterdir())


# --- atomic_write -------------------------------------------------------------------


def test_atomic_write_moves_temp_onto_target(tmp_path):
    target = tmp_path / "out.png"
    with io.atomic_write(target) as tmp:
        assert tmp.parent == tmp_path
        assert tmp.name.startswith(".out.tmp")
        assert tmp.suffix == ".png"
        assert not target.exists()
        tmp.write_bytes(b"payload")
    assert target.read_bytes() == b"payload"
    assert _listing(tmp_path) == ["out.png"]


def test_atomic_write_failure_leaves_nothing(tmp_path):
    target = tmp_path / "out.pfm"
    with pytest.raises(RuntimeError, match="boom"):
        with io.atomic_write(target) as tmp:
            tmp.write_bytes(b"half")
            raise RuntimeError("boom")
    assert _listing(tmp_path) == []


def test_atomic_write_failure_keeps_existing_target(tmp_path):
    target = tmp_path / "out.txt"
    target.write_bytes(b"old")
    with pytest.raises(KeyError):
        with io.atomic_write(target) as tmp:
            tmp.write_bytes(b"new but broken")
            raise KeyError("x")
    assert target.read_bytes() == b"old"
    assert _listing(tmp_path) == ["out.txt"]


def test_atomic_write_missing_directory(tmp_path):
    target = tmp_path / "nope" / "out.png"
    msg = f"cannot write '{target}': directory '{target.parent}' does not exist"
    with pytest.raises(ValueError, match=msg.replace("(", r"\(")):
        with io.atomic_write(target):
            pass


def test_atomic_write_onto_directory(tmp_path):
    (tmp_path / "sub").mkdir()
    with pytest.raises(ValueError, match="is a directory"):
        with io.atomic_write(tmp_path / "sub"):
            pass
    assert _listing(tmp_path) == ["sub"]


# --- atomic_writes: a group of outputs, all or none ---------------------------------


def _contents(directory):
    """Every entry of DIRECTORY (hidden ones included): a file's bytes, a link's target."""
    return {
        p.name: ("->", str(p.readlink())) if p.is_symlink() else p.read_bytes()
        for p in directory.iterdir()
    }


def test_atomic_writes_moves_the_group_at_the_end(tmp_path):
    (tmp_path / "b.txt").write_bytes(b"old b")
    with io.atomic_writes() as stage:
        for name in ("a.txt", "b.txt", "c.txt"):
            stage(tmp_path / name).write_bytes(b"new " + name.encode())
        assert _contents(tmp_path)["b.txt"] == b"old b"  # nothing moved yet
        assert "a.txt" not in _contents(tmp_path)
    assert _contents(tmp_path) == {"a.txt": b"new a.txt", "b.txt": b"new b.txt",
                                   "c.txt": b"new c.txt"}  # fmt: skip


def test_atomic_writes_failure_in_the_block_leaves_the_old_group(tmp_path):
    (tmp_path / "b.txt").write_bytes(b"old b")
    before = _contents(tmp_path)
    with pytest.raises(RuntimeError, match="boom"):
        with io.atomic_writes() as stage:
            stage(tmp_path / "a.txt").write_bytes(b"new a")
            stage(tmp_path / "b.txt").write_bytes(b"new b")
            raise RuntimeError("boom")
    assert _contents(tmp_path) == before


@pytest.mark.parametrize("links", [True, False], ids=["hard links", "copies"])
def test_atomic_writes_a_move_failing_partway_puts_the_moved_ones_back(
    tmp_path, monkeypatch, refuse_move, links
):
    (tmp_path / "b.txt").write_bytes(b"old b")
    (tmp_path / "c.txt").write_bytes(b"old c")
    os.symlink("b.txt", tmp_path / "link.txt")
    before = _contents(tmp_path)
    if not links:  # a file system without hard links: the earlier files are copied

        def no_link(*args, **kwargs):
            raise OSError(1, "Operation not permitted")

        monkeypatch.setattr(os, "link", no_link)
    refuse_move("c.txt")
    msg = f"^cannot write '{tmp_path / 'c.txt'}': permission denied$"
    with pytest.raises(ValueError, match=msg):
        with io.atomic_writes() as stage:
            # a new file, an existing one, a symbolic link, then the one that fails
            for name in ("a.txt", "b.txt", "link.txt", "c.txt", "d.txt"):
                stage(tmp_path / name).write_bytes(b"new " + name.encode())
    assert _contents(tmp_path) == before
    assert (tmp_path / "link.txt").is_symlink()


def test_atomic_writes_an_interrupted_move_puts_the_moved_ones_back(tmp_path, refuse_move):
    (tmp_path / "a.txt").write_bytes(b"old a")
    before = _contents(tmp_path)
    refuse_move("b.txt", KeyboardInterrupt())
    with pytest.raises(KeyboardInterrupt):
        with io.atomic_writes() as stage:
            stage(tmp_path / "a.txt").write_bytes(b"new a")
            stage(tmp_path / "b.txt").write_bytes(b"new b")
    assert _contents(tmp_path) == before


def test_atomic_writes_without_a_second_name_keeps_the_new_file(tmp_path, monkeypatch, refuse_move):
    # neither a hard link nor a copy can be made: the moved file cannot be put back, and
    # is kept rather than removed (the old contents are gone either way)
    (tmp_path / "a.txt").write_bytes(b"old a")

    def refuse(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "link", refuse)
    monkeypatch.setattr(shutil, "copy2", refuse)
    refuse_move("b.txt")
    with pytest.raises(ValueError, match="cannot write .*b.txt': permission denied"):
        with io.atomic_writes() as stage:
            stage(tmp_path / "a.txt").write_bytes(b"new a")
            stage(tmp_path / "b.txt").write_bytes(b"new b")
    assert _contents(tmp_path) == {"a.txt": b"new a"}


def test_atomic_writes_makes_no_second_name_for_the_last_move(tmp_path, monkeypatch):
    (tmp_path / "a.txt").write_bytes(b"old a")
    made = []
    real = os.link
    monkeypatch.setattr(os, "link", lambda src, dst: made.append(src) or real(src, dst))
    with io.atomic_writes() as stage:
        stage(tmp_path / "b.txt").write_bytes(b"new b")  # nothing there before
        stage(tmp_path / "a.txt").write_bytes(b"new a")  # last: never undone
    with io.atomic_write(tmp_path / "a.txt") as tmp:  # a group of one
        tmp.write_bytes(b"newer a")
    assert made == []
    assert _contents(tmp_path) == {"a.txt": b"newer a", "b.txt": b"new b"}


# --- PFM ----------------------------------------------------------------------------


def test_pfm_gray_round_trip(tmp_path):
    rng = np.random.default_rng(1)
    values = rng.uniform(0, 60, (7, 11)).astype(np.float32)
    path = tmp_path / "d.pfm"
    io.write_pfm(path, values)
    back = io.read_pfm(path)
    assert back.dtype == np.float32 and back.shape == (7, 11)
    np.testing.assert_array_equal(back, values)
    assert path.read_bytes().startswith(b"Pf\n11 7\n-1.0\n")
    np.testing.assert_array_equal(io.read_image(path), values)


def test_pfm_colour_round_trip(tmp_path):
    rng = np.random.default_rng(2)
    values = rng.normal(size=(5, 4, 3)).astype(np.float32)
    path = tmp_path / "c.pfm"
    io.write_pfm(path, values)
    assert path.read_bytes().startswith(b"PF\n4 5\n")
    np.testing.assert_array_equal(io.read_pfm(path), values)


def test_pfm_non_finite_written_as_inf_and_read_as_nan(tmp_path):
    values = np.array([[1.5, np.nan, -np.inf], [np.inf, 0.0, 2.5]], dtype=np.float32)
    path = tmp_path / "d.pfm"
    io.write_pfm(path, values)
    raw = io.read_pfm(path)
    assert np.isposinf(raw[[0, 0, 1], [1, 2, 0]]).all()
    d = io.read_disparity(path)
    assert d.dtype == np.float32
    np.testing.assert_array_equal(np.isnan(d), ~np.isfinite(values))
    np.testing.assert_array_equal(d[np.isfinite(values)], values[np.isfinite(values)])


def test_pfm_hand_made_big_endian_bottom_to_top(tmp_path):
    # 3 wide, 2 high; rows stored bottom first; scale +1.0 means big endian.
    bottom, top = [4.0, 5.0, 6.5], [1.0, 2.0, 3.0]
    data = b"Pf\n3 2\n1.0\n" + struct.pack(">6f", *bottom, *top)
    path = tmp_path / "hand.pfm"
    path.write_bytes(data)
    back = io.read_pfm(path)
    assert back.dtype == np.float32
    np.testing.assert_array_equal(back, [top, bottom])


def test_pfm_hand_made_colour_little_endian(tmp_path):
    pixels = np.arange(2 * 2 * 3, dtype="<f4").reshape(2, 2, 3)  # stored order
    path = tmp_path / "hand.pfm"
    path.write_bytes(b"PF\n2 2\n-1.0\n" + pixels.tobytes())
    np.testing.assert_array_equal(io.read_pfm(path), pixels[::-1])


def test_pfm_truncated(tmp_path):
    path = tmp_path / "short.pfm"
    path.write_bytes(b"Pf\n4 4\n-1.0\n" + b"\0" * 20)
    with pytest.raises(ValueError, match=r"cannot read PFM file '.*short\.pfm': data is short"):
        io.read_pfm(path)
    with pytest.raises(ValueError, match="data is short"):
        io.read_disparity(path)


@pytest.mark.parametrize(
    "header",
    [b"P5\n2 2\n255\n", b"Pf\n2 x\n-1.0\n", b"Pf\n2 2\n0.0\n", b"Pf\n-2 2\n-1.0\n", b""],
)
def test_pfm_malformed_header(tmp_path, header):
    path = tmp_path / "bad.pfm"
    path.write_bytes(header + b"\0" * 64)
    with pytest.raises(ValueError, match=r"cannot read PFM file '.*bad\.pfm'"):
        io.read_pfm(path)


def test_read_pfm_missing_file(tmp_path):
    with pytest.raises(ValueError, match="file does not exist"):
        io.read_pfm(tmp_path / "missing.pfm")


@pytest.mark.parametrize("shape", [(4,), (2, 3, 2), (2, 3, 4), (0, 3)])
def test_write_pfm_bad_shape(tmp_path, shape):
    with pytest.raises(ValueError, match="shape"):
        io.write_pfm(tmp_path / "x.pfm", np.zeros(shape, dtype=np.float32))
    assert _listing(tmp_path) == []


def test_write_pfm_rejects_strings(tmp_path):
    with pytest.raises(TypeError, match="real numbers"):
        io.write_pfm(tmp_path / "x.pfm", np.array([["a"]]))


# --- 16-bit PNG disparity -----------------------------------------------------------


def test_png16_round_trip(tmp_path):
    rng = np.random.default_rng(3)
    d = rng.uniform(0.01, 200, (9, 13)).astype(np.float32)
    d[2, 3] = np.nan
    path = tmp_path / "d.png"
    io.write_disparity_png16(path, d)
    with Image.open(path) as im:
        assert im.mode == "I;16"
    back = io.read_disparity(path)
    assert back.dtype == np.float32 and back.shape == d.shape
    assert np.isnan(back[2, 3]) and np.isfinite(np.delete(back.ravel(), 2 * 13 + 3)).all()
    np.testing.assert_allclose(back, d, atol=1 / (2 * 256), equal_nan=True)


def test_png16_custom_scale_round_trip(tmp_path):
    rng = np.random.default_rng(4)
    d = rng.uniform(0, 600, (6, 5))
    path = tmp_path / "d.png"
    io.write_disparity_png16(path, d, scale=100)
    np.testing.assert_allclose(io.read_disparity(path, scale=100), d, atol=1 / 200)


def test_png16_zero_disparity_stored_as_one(tmp_path):
    d = np.array([[0.0, 1e-4, np.nan, np.inf, 1.0]])
    path = tmp_path / "d.png"
    io.write_disparity_png16(path, d)
    np.testing.assert_array_equal(io.read_image(path), [[1, 1, 0, 0, 256]])
    back = io.read_disparity(path)
    np.testing.assert_array_equal(back, np.array([[1 / 256, 1 / 256, np.nan, np.nan, 1.0]]))


def test_png16_overflow_writes_nothing(tmp_path):
    d = np.array([[1.0, 300.25]])
    with pytest.raises(ValueError, match=r"largest disparity 300\.25 exceeds .* limit 255\.996"):
        io.write_disparity_png16(tmp_path / "d.png", d)
    assert _listing(tmp_path) == []


def test_png16_largest_value_that_fits(tmp_path):
    path = tmp_path / "d.png"
    io.write_disparity_png16(path, np.array([[65535 / 256]]))
    assert io.read_image(path)[0, 0] == 65535


def test_png16_negative_writes_nothing(tmp_path):
    target = tmp_path / "d.png"
    target.write_bytes(b"old")
    with pytest.raises(ValueError, match=r"smallest disparity -0\.5 is negative"):
        io.write_disparity_png16(target, np.array([[2.0, -0.5]]))
    assert target.read_bytes() == b"old"
    assert _listing(tmp_path) == ["d.png"]


@pytest.mark.parametrize("scale", [0, -1, np.inf])
def test_png16_bad_scale(tmp_path, scale):
    with pytest.raises(ValueError, match="scale must be a positive finite number"):
        io.write_disparity_png16(tmp_path / "d.png", np.ones((2, 2)), scale=scale)


def test_png16_rejects_3d(tmp_path):
    with pytest.raises(ValueError, match=r"disparity must be 2-D \(H, W\), got shape"):
        io.write_disparity_png16(tmp_path / "d.png", np.ones((2, 2, 3)))


# --- write_disparity dispatch -------------------------------------------------------


def test_write_disparity_dispatch(tmp_path):
    d = np.array([[1.5, np.nan], [0.0, 7.25]], dtype=np.float32)
    io.write_disparity(tmp_path / "a.pfm", d)
    io.write_disparity(tmp_path / "b.PNG", d, scale=4)
    assert (tmp_path / "a.pfm").read_bytes().startswith(b"Pf")
    np.testing.assert_array_equal(io.read_disparity(tmp_path / "a.pfm"), d)
    back = io.read_disparity(tmp_path / "b.PNG", scale=4)
    np.testing.assert_array_equal(back, np.array([[1.5, np.nan], [0.25, 7.25]]))


def test_write_disparity_wrong_suffix(tmp_path):
    with pytest.raises(ValueError, match=r"unsupported suffix '\.jpg', use one of \.pfm, \.png"):
        io.write_disparity(tmp_path / "d.jpg", np.ones((2, 2)))
    assert _listing(tmp_path) == []


def test_write_disparity_pfm_rejects_colour_and_options(tmp_path):
    with pytest.raises(ValueError, match="2-D"):
        io.write_disparity(tmp_path / "d.pfm", np.ones((2, 2, 3)))
    with pytest.raises(TypeError, match="scale"):
        io.write_disparity(tmp_path / "d.pfm", np.ones((2, 2)), scale=256)
    assert _listing(tmp_path) == []


def test_write_disparity_missing_directory(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        io.write_disparity(tmp_path / "no" / "d.png", np.ones((2, 2)))


# --- depth maps ---------------------------------------------------------------------


def test_depth_png16_by_hand(tmp_path):
    z = np.array([[1234.4, np.nan, 0.2], [65535.4, 65535.6, np.inf]])
    assert io.write_depth_png16(tmp_path / "z.png", z) == 1  # 65535.6 rounds past 16 bits
    stored = np.asarray(Image.open(tmp_path / "z.png"))
    assert stored.dtype == np.uint16
    # rounded; none -> 0; a depth rounding to 0 kept as 1; too far -> 0
    np.testing.assert_array_equal(stored, [[1234, 0, 1], [65535, 0, 0]])
    back = io.read_depth(tmp_path / "z.png")
    np.testing.assert_array_equal(back, np.array([[1234, np.nan, 1], [65535, np.nan, np.nan]]))


def test_depth_png16_scale_round_trip(tmp_path):
    # TUM RGB-D: 5000 per metre; depths in metres to 0.2 mm
    z = np.array([[0.5, 1.2346], [12.0, 13.2]])
    assert io.write_depth_png16(tmp_path / "z.png", z, scale=5000) == 1  # 66000 > 65535
    back = io.read_depth(tmp_path / "z.png", scale=5000)
    np.testing.assert_allclose(back[:, :1].ravel(), [0.5, 12.0], atol=1e-6)
    assert back[0, 1] == pytest.approx(6173 / 5000) and np.isnan(back[1, 1])


def test_depth_png16_refuses_and_writes_nothing(tmp_path):
    with pytest.raises(ValueError, match="smallest depth -1 is negative"):
        io.write_depth_png16(tmp_path / "z.png", np.array([[-1.0, 2.0]]))
    with pytest.raises(ValueError, match="depth must be 2-D"):
        io.write_depth_png16(tmp_path / "z.png", np.ones(3))
    with pytest.raises(ValueError, match="scale must be a positive finite number"):
        io.write_depth_png16(tmp_path / "z.png", np.ones((2, 2)), scale=0)
    with pytest.raises(TypeError, match="depth must hold real numbers"):
        io.write_depth_png16(tmp_path / "z.png", np.ones((2, 2), complex))
    assert _listing(tmp_path) == []


@pytest.mark.parametrize("name", ["d.pfm", "d.png"])
def test_write_disparity_refuses_a_boolean_map_as_viz_and_geometry_do(tmp_path, name):
    # one check of a map for every module (dcstereo._checks.disparity_array)
    with pytest.raises(TypeError, match="^disparity must hold real numbers, got dtype bool$"):
        io.write_disparity(tmp_path / name, np.ones((2, 2), bool))
    with pytest.raises(ValueError, match=r"^disparity is empty \(shape \(0, 3\)\)$"):
        io.write_disparity(tmp_path / name, np.ones((0, 3)))
    assert _listing(tmp_path) == []


def test_write_depth_dispatch(tmp_path):
    z = np.array([[1500.25, np.nan], [2.0, 7.75]], dtype=np.float32)
    assert io.write_depth(tmp_path / "z.pfm", z) == 0
    assert io.write_depth(tmp_path / "z.PNG", z) == 0
    assert io.write_depth(tmp_path / "z4.png", z, scale=4) == 0
    np.testing.assert_array_equal(io.read_depth(tmp_path / "z.pfm"), z)
    np.testing.assert_array_equal(io.read_depth(tmp_path / "z.PNG"), np.rint(z))
    np.testing.assert_array_equal(io.read_depth(tmp_path / "z4.png", scale=4), z)
    with pytest.raises(ValueError, match=r"cannot write depth '.*z\.tif': unsupported suffix "
                       r"'\.tif', use one of \.pfm, \.png"):  # fmt: skip
        io.write_depth(tmp_path / "z.tif", z)
    with pytest.raises(TypeError, match="a scale for a .png file only"):
        io.write_depth(tmp_path / "y.pfm", z, scale=1000)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["z.PNG", "z.pfm", "z4.png"]


def test_check_suffix_one_or_several(tmp_path):
    io.check_suffix("a.PLY", ".ply", "--ply")
    io.check_suffix("a.png", (".pfm", ".png"), "--depth-out")
    with pytest.raises(ValueError, match=r"cannot write --ply 'a.txt': unsupported suffix "
                       r"'\.txt', use \.ply$"):  # fmt: skip
        io.check_suffix("a.txt", ".ply", "--ply")
    with pytest.raises(ValueError, match=r"use one of \.pfm, \.png$"):
        io.check_suffix("a", (".pfm", ".png"), "--depth-out")


# --- read_disparity from 8-bit images -----------------------------------------------


def test_read_disparity_8bit_with_scale(tmp_path):
    stored = np.array([[0, 8, 16], [255, 4, 0]], dtype=np.uint8)
    path = tmp_path / "gt.png"
    Image.fromarray(stored).save(path)
    d = io.read_disparity(path, scale=8)
    expected = np.where(stored == 0, np.nan, stored / 8.0)
    np.testing.assert_array_equal(d, expected.astype(np.float32))


def test_read_disparity_8bit_needs_scale(tmp_path):
    path = tmp_path / "gt.pgm"
    Image.fromarray(np.ones((2, 2), dtype=np.uint8)).save(path)
    with pytest.raises(ValueError, match="8-bit disparity image needs a scale"):
        io.read_disparity(path)


def test_read_disparity_colour_png(tmp_path):
    path = tmp_path / "c.png"
    Image.fromarray(np.zeros((2, 2, 3), dtype=np.uint8)).save(path)
    with pytest.raises(ValueError, match="colour image"):
        io.read_disparity(path, scale=1)


def test_read_disparity_colour_pfm(tmp_path):
    path = tmp_path / "c.pfm"
    io.write_pfm(path, np.zeros((2, 2, 3)))
    with pytest.raises(ValueError, match="colour image"):
        io.read_disparity(path)


# --- read_image ---------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".png", ".ppm", ".tif", ".bmp"])
def test_read_colour_lossless(tmp_path, suffix):
    rng = np.random.default_rng(5)
    rgb = rng.integers(0, 256, (6, 9, 3), dtype=np.uint8)
    path = tmp_path / f"c{suffix}"
    Image.fromarray(rgb).save(path)
    back = io.read_image(path)
    assert back.dtype == np.uint8
    np.testing.assert_array_equal(back, rgb)


@pytest.mark.parametrize("suffix", [".png", ".pgm", ".tif"])
def test_read_gray_lossless(tmp_path, suffix):
    rng = np.random.default_rng(6)
    gray = rng.integers(0, 256, (6, 9), dtype=np.uint8)
    path = tmp_path / f"g{suffix}"
    Image.fromarray(gray).save(path)
    np.testing.assert_array_equal(io.read_image(path), gray)


def test_read_jpeg(tmp_path):
    rng = np.random.default_rng(7)
    rgb = rng.integers(0, 256, (16, 24, 3), dtype=np.uint8)
    Image.fromarray(rgb).save(tmp_path / "c.jpg")
    Image.fromarray(rgb[..., 0]).save(tmp_path / "g.jpeg")
    colour, gray = io.read_image(tmp_path / "c.jpg"), io.read_image(tmp_path / "g.jpeg")
    assert colour.shape == (16, 24, 3) and colour.dtype == np.uint8
    assert gray.shape == (16, 24) and gray.dtype == np.uint8


@pytest.mark.parametrize("suffix", [".png", ".pgm", ".tif"])
def test_read_16bit_gray(tmp_path, suffix):
    # Pillow opens 16-bit PNG/TIFF as mode "I;16" but 16-bit PGM as 32-bit mode "I".
    rng = np.random.default_rng(8)
    gray = rng.integers(0, 65536, (5, 7), dtype=np.uint16)
    gray[0, 0] = 65535
    path = tmp_path / f"g{suffix}"
    Image.fromarray(gray).save(path)
    back = io.read_image(path)
    assert back.dtype == np.uint16
    np.testing.assert_array_equal(back, gray)


def test_read_16bit_big_endian_mode(tmp_path):
    values = np.array([[0, 258, 65535]], dtype=np.uint16)
    im = Image.frombytes("I;16B", (3, 1), values.astype(">u2").tobytes())
    path = tmp_path / "b.tif"
    im.save(path)
    back = io.read_image(path)
    assert back.dtype == np.uint16 and back.dtype.isnative
    np.testing.assert_array_equal(back, values)


def test_read_float_tiff(tmp_path):
    values = np.array([[0.5, -2.0], [np.inf, 3.0]], dtype=np.float32)
    path = tmp_path / "f.tif"
    Image.fromarray(values).save(path)
    back = io.read_image(path)
    assert back.dtype == np.float32
    np.testing.assert_array_equal(back, values)


def test_read_one_bit(tmp_path):
    path = tmp_path / "m.png"
    Image.fromarray(np.array([[True, False], [False, True]])).save(path)
    back = io.read_image(path)
    assert back.dtype == np.uint8
    np.testing.assert_array_equal(back, [[255, 0], [0, 255]])


def test_read_palette_as_rgb(tmp_path):
    im = Image.new("P", (3, 2))
    im.putpalette([0, 0, 0, 255, 0, 0, 0, 255, 0])
    im.putdata([0, 1, 2, 2, 1, 0])
    path = tmp_path / "p.png"
    im.save(path)
    back = io.read_image(path)
    assert back.shape == (2, 3, 3) and back.dtype == np.uint8
    np.testing.assert_array_equal(back[0], [[0, 0, 0], [255, 0, 0], [0, 255, 0]])


def test_read_palette_with_transparency(tmp_path):
    im = Image.new("P", (2, 1))
    im.putpalette([10, 20, 30, 40, 50, 60])
    im.putdata([0, 1])
    im.info["transparency"] = 0
    path = tmp_path / "p.png"
    im.save(path)
    np.testing.assert_array_equal(io.read_image(path), [[[10, 20, 30], [40, 50, 60]]])


def test_read_rgba_and_la_drop_alpha(tmp_path):
    rng = np.random.default_rng(9)
    rgba = rng.integers(0, 256, (4, 5, 4), dtype=np.uint8)
    Image.fromarray(rgba).save(tmp_path / "a.png")
    back = io.read_image(tmp_path / "a.png")
    np.testing.assert_array_equal(back, rgba[..., :3])
    Image.fromarray(rgba[..., :2], mode="LA").save(tmp_path / "la.png")
    np.testing.assert_array_equal(io.read_image(tmp_path / "la.png"), rgba[..., 0])


def test_read_cmyk_jpeg_becomes_rgb(tmp_path):
    Image.new("CMYK", (4, 3), (0, 0, 0, 0)).save(tmp_path / "k.jpg")
    back = io.read_image(tmp_path / "k.jpg")
    assert back.shape == (3, 4, 3) and back.dtype == np.uint8


def test_read_image_missing_file(tmp_path):
    path = tmp_path / "x.png"
    with pytest.raises(ValueError, match=r"cannot read image '.*x\.png': file does not exist"):
        io.read_image(path)
    with pytest.raises(ValueError, match="file does not exist"):
        io.read_disparity(path, scale=1)


def test_read_image_directory(tmp_path):
    with pytest.raises(ValueError, match="not a regular file"):
        io.read_image(tmp_path)


def test_read_image_text_file(tmp_path):
    path = tmp_path / "x.png"
    path.write_text("this is not a PNG\n")
    with pytest.raises(ValueError, match=r"'.*x\.png': not a recognised image format"):
        io.read_image(path)


def test_read_image_truncated_png(tmp_path):
    rng = np.random.default_rng(10)
    path = tmp_path / "t.png"
    Image.fromarray(rng.integers(0, 256, (64, 64, 3), dtype=np.uint8)).save(path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match=r"cannot read image '.*t\.png': truncated or corrupt"):
        io.read_image(path)


def test_read_image_truncated_pfm(tmp_path):
    path = tmp_path / "t.pfm"
    io.write_pfm(path, np.ones((8, 8)))
    path.write_bytes(path.read_bytes()[:-10])
    with pytest.raises(ValueError, match="data is short"):
        io.read_image(path)


# --- masks and RGB ------------------------------------------------------------------


def test_write_mask_png(tmp_path):
    mask = np.array([[True, False, True]])
    path = tmp_path / "m.png"
    io.write_mask_png(path, mask)
    with Image.open(path) as im:
        assert im.mode == "L"
    np.testing.assert_array_equal(io.read_image(path), [[255, 0, 255]])


def test_write_mask_png_validates(tmp_path):
    with pytest.raises(TypeError, match="mask must be a bool array"):
        io.write_mask_png(tmp_path / "m.png", np.ones((2, 2), dtype=np.uint8))
    with pytest.raises(ValueError, match="mask must be 2-D"):
        io.write_mask_png(tmp_path / "m.png", np.ones((2, 2, 1), dtype=bool))
    assert _listing(tmp_path) == []


@pytest.mark.parametrize("shape", [(5, 6), (5, 6, 3)])
def test_write_rgb_png_round_trip(tmp_path, shape):
    rng = np.random.default_rng(11)
    image = rng.integers(0, 256, shape, dtype=np.uint8)
    path = tmp_path / "i.png"
    io.write_rgb_png(path, image)
    np.testing.assert_array_equal(io.read_image(path), image)


def test_write_rgb_png_is_png_whatever_the_suffix(tmp_path):
    path = tmp_path / "i.jpg"
    io.write_rgb_png(path, np.zeros((2, 2), dtype=np.uint8))
    assert path.read_bytes().startswith(b"\x89PNG")


def test_write_rgb_png_validates(tmp_path):
    with pytest.raises(TypeError, match="uint8"):
        io.write_rgb_png(tmp_path / "i.png", np.zeros((2, 2), dtype=np.float32))
    with pytest.raises(ValueError, match=r"\(H, W\) or \(H, W, 3\)"):
        io.write_rgb_png(tmp_path / "i.png", np.zeros((2, 2, 4), dtype=np.uint8))
    with pytest.raises(ValueError, match="empty"):
        io.write_rgb_png(tmp_path / "i.png", np.zeros((0, 2), dtype=np.uint8))
    assert _listing(tmp_path) == []


def test_check_writable_refuses_what_atomic_write_cannot_write(tmp_path):
    a_file = tmp_path / "file.txt"
    a_file.write_text("x")
    with pytest.raises(ValueError, match="it is a directory"):
        io.check_writable(tmp_path)
    with pytest.raises(ValueError, match="directory '.*missing' does not exist"):
        io.check_writable(tmp_path / "missing" / "out.md")
    with pytest.raises(ValueError, match="file.txt' is not a directory"):
        io.check_writable(a_file / "out.md", make_folders=True)
    io.check_writable(tmp_path / "missing" / "deeper" / "out.md", make_folders=True)
    io.check_writable(a_file)  # an existing file is replaced
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.txt"]  # nothing made


def test_stale_temporaries_are_the_temporary_scheme_only(tmp_path):
    target = tmp_path / "a[1]*.pfm"  # glob characters in the name are matched literally
    leftover = tmp_path / ".a[1]*.tmp0123abcd.pfm"  # what a killed writer leaves
    leftover.write_text("")
    (tmp_path / ".a[1]*.tmp0123abcdx.pfm").write_text("")  # too long: not of the scheme
    (tmp_path / ".a[1]*.tmpXX.pfm").write_text("")  # too short
    (tmp_path / ".ab.tmp0123abcd.pfm").write_text("")  # another target's
    with pytest.raises(RuntimeError), io.atomic_write(target) as tmp:
        assert io.stale_temporaries(target) == sorted([leftover, tmp])  # its own, while open
        raise RuntimeError
    assert len(leftover.name) == len(target.name) + io.TEMPORARY_NAME_EXTRA
    assert io.stale_temporaries(target) == [leftover]

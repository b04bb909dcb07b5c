"""A bounded, seeded fuzz of the public API, the readers and ``dcstereo run``.

The promises (``docs/guide/reliability.md``): any input gives either a result of the
documented shape and dtype, the same every time, or one ``ValueError`` / ``TypeError``
of one line (in the CLI: ``Error: ...`` on one line and a non-zero exit code); never a
traceback, another exception, a warning, or a file half-written at an output path.

Each property runs a fixed number of examples from a fixed seed (``derandomize``): the
same cases on every run, in CI's budget. Sizes are small; the images' pixels come from a
seeded generator (drawn by hypothesis as a seed), the shapes, dtypes, ranges and options
from hypothesis.
"""

import contextlib
import io as bytes_io
import os
import struct
import warnings
import zlib

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from PIL import Image

import dcstereo
from dcstereo import io
from dcstereo.cli import main
from dcstereo.params import METHOD_OPTIONS

#: Examples per property (the docs' reliability page quotes these counts).
MATCH_EXAMPLES = 200
READER_EXAMPLES = 300
WRITER_EXAMPLES = 100
RUN_EXAMPLES = 100


def fuzz(examples):
    """Hypothesis settings of this file: ``examples`` cases from a fixed seed, no deadline."""
    return settings(
        max_examples=examples,
        derandomize=True,
        database=None,
        deadline=None,
        suppress_health_check=[
            HealthCheck.too_slow,
            HealthCheck.function_scoped_fixture,
            HealthCheck.data_too_large,
        ],
    )


def one_line(exc):
    """Assert ``exc`` is a clear one-line error: a ValueError or TypeError with a message."""
    assert isinstance(exc, (ValueError, TypeError)), repr(exc)
    event(f"error: {type(exc).__name__}")
    message = str(exc)
    assert message.strip() and "\n" not in message, repr(message)
    assert "Traceback" not in message


@contextlib.contextmanager
def no_warnings():
    """Fail on any warning in the block, even one that code inside would catch as an error.

    Strict pytest turns a warning into an exception, which a reader's ``except`` could
    then report as a damaged file: that would hide a warning printed in normal use.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield
    assert not caught, [f"{w.category.__name__}: {w.message}" for w in caught]


# --------------------------------------------------------------------------- match

#: Each property draws a well-formed case three times in four ("valid": every choice from
#: the first list of ``pick``), else any case (from both lists): most examples reach a
#: result, and the rest probe the checks.
VALID_SHARE = 3


def pick(draw, valid, values, invalid=()):
    """Draw from ``values``, or, unless ``valid``, from ``values`` and ``invalid``."""
    return draw(st.sampled_from(list(values) + ([] if valid else list(invalid))))


GOOD_DTYPES = [np.uint8, np.uint16, np.float32, np.float64, np.dtype(">u2")]
BAD_DTYPES = [np.int16, np.int64, np.bool_, np.complex64, np.float16]

#: Values of each method's own options: (valid, invalid).
OPTION_VALUES = {
    "slant_cost": ([0.0, 1.0, 8.0, 30.0], [-1.0, float("nan")]),
    "ser_min": ([0.0, 0.5, 1.0, 3.0], [-1.0]),
    "vs_max": ([0.0, 0.2, 1.0, 5.0], [-0.1]),
    "vs_relative": ([True, False], ["no"]),
    "feature_floor": ([0.0, 10.0, 100.0, 1e6], [-5.0]),
    "uniqueness": ([0.0, 1.0, 2.0, 4.0], [-1.0]),
    "edge_guard": ([0, 1, 3, 50], [-1, 2.5]),
    "lr_check": ([True, False], [None]),
    "max_candidates": ([0, 1, 5, 1000], [-2]),
    "gcp_uniqueness": ([0.0, 1.5, 3.0], [-1.0]),
    "gcp_variance_floor": ([0.0, 50.0, 100.0, 1e5], [-1.0]),
    "orientations": ([(0.0,), (-0.5, 0.0, 0.5), (0.0625, -0.125, 1.0)], [(), (0.3,)]),
    "orientation_cost": ([0.0, 0.5, 2.0], [-1.0]),
    "occlusion_discount": ([0.0, 0.2, 0.9], [1.0, -0.1]),
    "occlusion_discount_pixels": ([0, 1, 5, 64], [65, -1]),
}


def _takes(method, **options):
    """Whether ``method`` takes ``options`` (``redert`` has no BT cost)."""
    try:
        dcstereo.MatchParams(max_disparity=1, method=method, **options)
    except (ValueError, TypeError):
        return False
    return True


def image(seed, height, width, dtype, channels, special):
    """A seeded random image; ``special`` puts NaN, inf or an out-of-range value in it."""
    rng = np.random.default_rng(seed)
    shape = (height, width) if channels is None else (height, width, channels)
    dtype = np.dtype(dtype)
    if dtype.kind == "u":
        pixels = rng.integers(0, np.iinfo(dtype).max, shape, endpoint=True).astype(dtype)
    elif dtype.kind == "i":
        pixels = rng.integers(-5, 300, shape).astype(dtype)
    elif dtype.kind == "b":
        pixels = rng.random(shape) > 0.5
    else:
        pixels = rng.random(shape).astype(dtype)
        if special is not None and pixels.size:
            pixels.flat[rng.integers(pixels.size)] = special
    return pixels


@st.composite
def match_problems(draw):
    valid = draw(st.integers(0, VALID_SHARE)) > 0
    height = draw(st.integers(1 if valid else 0, 12))
    width = draw(st.integers(2 if valid else 0, 40))
    seed = draw(st.integers(0, 2**32 - 1))
    images = []
    for side in range(2):
        dtype = pick(draw, valid, GOOD_DTYPES, BAD_DTYPES)
        channels = pick(draw, valid, [None, None, 3, 4], [1, 2])
        special = pick(draw, valid, [None], [np.nan, np.inf, -0.5, 1.5])
        other = pick(draw, valid, [0], [1])  # a height apart
        images.append(image(seed + side, height + other, width, dtype, channels, special))
    if draw(st.booleans()) and images[0].shape == images[1].shape:
        images[1] = np.roll(images[0], -draw(st.integers(0, 6)), axis=1)  # a real shift
    method = pick(draw, valid, dcstereo.METHODS, ["nope"])
    if valid:
        dmin = draw(st.integers(-(width - 1), width - 1))
        dmax = draw(st.integers(dmin, width - 1))
    else:
        dmin = draw(st.integers(-(width + 2), width + 2))
        dmax = draw(st.integers(dmin - 2, width + 2))
    options = {"min_disparity": dmin}
    if valid or draw(st.booleans()):  # the default, 5, is too wide for the smallest
        windows = [w for w in (1, 3, 5, 7, 9) if w <= min(height, width)] or [1]
        options["window"] = pick(draw, valid, windows, [0, 2, -1, 3.0, 99])
    if draw(st.booleans()):
        costs = ["sad", "bt"] if _takes(method, cost="bt") else ["sad"]
        options["cost"] = pick(draw, valid, costs, ["bt", "ncc"])
    if draw(st.booleans()):
        options["occlusion_cost"] = pick(draw, valid, [0.5, 2.0, 10.0, 40.0], [0.0, -1.0])
    if draw(st.integers(0, 3)) == 0:
        options["fill"] = pick(draw, valid, [True, False], [1])
    if draw(st.integers(0, 3)) == 0:
        options["subpixel"] = pick(draw, valid, [None, "parabola", "equiangular"], ["cubic"])
    if draw(st.integers(0, 3)) == 0:
        options["median"] = pick(draw, valid, [0, 3, 5], [4, 17])
    readers = sorted(name for name in METHOD_OPTIONS if name in OPTION_VALUES)
    for name in draw(st.lists(st.sampled_from(readers), max_size=3, unique=True)):
        # the method's own options; unless valid, now and then one only another reads
        if method in METHOD_OPTIONS[name] or (not valid and draw(st.booleans())):
            options[name] = pick(draw, valid, *OPTION_VALUES[name])
    return images[0], images[1], method, dmax, options


def _same_result(a, b):
    assert a.disparity.tobytes() == b.disparity.tobytes()
    assert a.flags.tobytes() == b.flags.tobytes()
    assert a.path_cost.tobytes() == b.path_cost.tobytes()
    assert (a.features is None) == (b.features is None)
    if a.features is not None:
        assert a.features.tobytes() == b.features.tobytes()


@fuzz(MATCH_EXAMPLES)
@given(match_problems())
def test_match_gives_a_result_of_the_documented_shape_or_a_one_line_error(problem):
    left, right, method, dmax, options = problem
    try:
        with no_warnings():
            result = dcstereo.match(left, right, max_disparity=dmax, method=method, **options)
    except (ValueError, TypeError) as exc:
        one_line(exc)
        return
    event(f"result of {method}")
    height, width = left.shape[:2]
    assert isinstance(result, dcstereo.DisparityResult)
    assert result.disparity.shape == (height, width) and result.disparity.dtype == np.float32
    assert result.flags.shape == (height, width) and result.flags.dtype == np.uint8
    assert result.path_cost.shape == (height,)
    finite = np.isfinite(result.disparity)
    assert (~np.isinf(result.disparity)).all()  # no estimate is NaN, never inf
    low = options["min_disparity"] - 1  # sub-pixel refinement moves less than a pixel
    assert ((result.disparity[finite] >= low) & (result.disparity[finite] <= dmax + 1)).all()
    again = dcstereo.match(left.copy(), right.copy(), max_disparity=dmax, method=method, **options)
    _same_result(again, result)


# --------------------------------------------------------------------------- readers


def _png_chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def _encode(kind, seed):
    """A small valid file of ``kind`` (a 7 x 9 image, or a map for PFM), as bytes."""
    rng = np.random.default_rng(seed)
    gray = rng.integers(0, 256, (7, 9), dtype=np.uint8)
    rgb = rng.integers(0, 256, (7, 9, 3), dtype=np.uint8)
    if kind.startswith("pfm"):
        values = rng.random((7, 9, 3) if kind == "pfm-colour" else (7, 9)).astype(np.float32)
        values[0, 0] = np.inf
        order = ">" if kind == "pfm-big-endian" else "<"
        magic = b"PF" if kind == "pfm-colour" else b"Pf"
        scale = b"1.0" if order == ">" else b"-1.0"
        body = np.ascontiguousarray(values[::-1], dtype=order + "f4").tobytes()
        return magic + b"\n9 7\n" + scale + b"\n" + body
    pictures = {
        "png-gray": (Image.fromarray(gray), "PNG"),
        "png-16": (Image.fromarray(gray.astype(np.uint16) * 257), "PNG"),
        "png-rgb": (Image.fromarray(rgb), "PNG"),
        "png-rgba": (Image.fromarray(np.dstack([rgb, gray])), "PNG"),
        "png-palette": (Image.fromarray(rgb).convert("P"), "PNG"),
        "png-1bit": (Image.fromarray(gray > 128), "PNG"),
        "png-la": (Image.fromarray(np.dstack([gray, gray])), "PNG"),
        "jpeg": (Image.fromarray(rgb), "JPEG"),
        "tiff-float": (Image.fromarray(rng.random((7, 9)).astype(np.float32)), "TIFF"),
        "tiff-16": (Image.fromarray(gray.astype(np.uint16) * 257), "TIFF"),
        "pgm": (Image.fromarray(gray), "PPM"),
        "ppm": (Image.fromarray(rgb), "PPM"),
        "bmp": (Image.fromarray(rgb), "BMP"),
        "gif": (Image.fromarray(gray), "GIF"),
    }
    picture, fmt = pictures[kind]
    out = bytes_io.BytesIO()
    picture.save(out, format=fmt)
    return out.getvalue()


KINDS = ["pfm", "pfm-colour", "pfm-big-endian", "png-gray", "png-16", "png-rgb", "png-rgba",
         "png-palette", "png-1bit", "png-la", "jpeg", "tiff-float", "tiff-16", "pgm", "ppm",
         "bmp", "gif"]  # fmt: skip


def _oversized(data, kind, width, height):
    """``data`` with a header that claims ``width x height`` (PNG: a valid CRC; PFM)."""
    if kind.startswith("png"):
        ihdr = bytearray(data[16:29])
        ihdr[0:8] = struct.pack(">II", width, height)
        return data[:8] + _png_chunk(b"IHDR", bytes(ihdr)) + data[33:]
    if kind.startswith("pfm"):
        magic, _, rest = data.split(b"\n", 2)
        return magic + f"\n{width} {height}\n".encode() + rest
    return data


@st.composite
def damaged_files(draw):
    kind = draw(st.sampled_from(KINDS))
    data = _encode(kind, draw(st.integers(0, 2**16)))
    how = draw(st.sampled_from(["intact"] * 3 + ["truncate", "flip", "insert", "append",
                                "oversize", "empty", "magic"]))  # fmt: skip
    if how == "truncate":
        data = data[: draw(st.integers(0, len(data) - 1))]
    elif how == "flip":
        data = bytearray(data)
        for _ in range(draw(st.integers(1, 8))):
            at = draw(st.integers(0, len(data) - 1))
            data[at] = draw(st.integers(0, 255))
        data = bytes(data)
    elif how == "insert":
        at = draw(st.integers(0, len(data)))
        data = data[:at] + draw(st.binary(min_size=1, max_size=16)) + data[at:]
    elif how == "append":
        data = data + draw(st.binary(min_size=1, max_size=64))
    elif how == "oversize":
        side = draw(st.sampled_from([3, 2**12, 2**15, 2**31 - 1]))
        data = _oversized(data, kind, side, draw(st.sampled_from([side, 1, 7])))
    elif how == "empty":
        data = b""
    elif how == "magic":
        data = data[:4]
    return kind, how, data


def _read_or_one_line(read, *args, **kwargs):
    try:
        with no_warnings():
            return read(*args, **kwargs)
    except (ValueError, TypeError) as exc:
        one_line(exc)
        return None


@fuzz(READER_EXAMPLES)
@given(damaged_files(), st.sampled_from([None, 1.0, 4.0, 256.0]))
def test_readers_give_an_array_or_a_one_line_error_on_damaged_files(tmp_path, case, scale):
    kind, how, data = case
    for earlier in tmp_path.iterdir():  # an example that failed before (shrinking)
        earlier.unlink()
    path = tmp_path / f"{kind}-{how}.{'pfm' if kind.startswith('pfm') else 'img'}"
    path.write_bytes(data)
    limit = 2**20  # a damaged header claims at most this much memory
    image = _read_or_one_line(io.read_image, path, max_pixels=limit)
    event(f"{how}: {'read' if image is not None else 'refused'}")
    if image is not None:
        assert image.dtype in (np.uint8, np.uint16, np.float32)
        assert image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)
        assert 0 < image.shape[0] * image.shape[1] <= limit
        again = io.read_image(path, max_pixels=limit)
        assert again.dtype == image.dtype and again.tobytes() == image.tobytes()
    if how == "intact":
        assert image is not None and image.shape[:2] == (7, 9)
    disparity = _read_or_one_line(io.read_disparity, path, scale=scale, max_pixels=limit)
    if disparity is not None:
        assert disparity.dtype == np.float32 and disparity.ndim == 2
        assert not np.isinf(disparity).any()  # no estimate is NaN
    with no_warnings():
        assert io.is_complete(path) in (True, False)
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]  # nothing written
    path.unlink()


@pytest.mark.parametrize("kind", ["png-gray", "pfm"])
def test_an_oversized_header_names_the_limit(tmp_path, kind):
    path = tmp_path / f"big.{'pfm' if kind == 'pfm' else 'png'}"
    path.write_bytes(_oversized(_encode(kind, 0), kind, 2**15, 2**15))
    what = "PFM file" if kind == "pfm" else "image"
    message = f"^cannot read {what} '.*': 32768 x 32768 is 1,073,741,824 pixels, more than"
    with pytest.raises(ValueError, match=message + " the limit of 100,000,000 per image"):
        io.read_image(path)


# --------------------------------------------------------------------------- writers


@st.composite
def maps(draw):
    valid = draw(st.integers(0, VALID_SHARE)) > 0
    shape = pick(draw, valid, [(3, 4), (1, 1), (5, 2)], [(0, 3), (3,), (2, 2, 3), (2, 3, 2)])
    dtype = pick(draw, valid, [np.float32, np.float64, np.uint8, np.int32], [np.bool_])
    name = pick(draw, valid, ["d.pfm", "d.png", "d.PFM"], ["d.txt", "d"])
    seed = draw(st.integers(0, 2**16))
    low, high = (0, 250) if valid and name.endswith(".png") else (-20, 300)
    values = (np.random.default_rng(seed).random(shape) * (high - low) + low).astype(dtype)
    if values.size and values.dtype.kind == "f" and draw(st.booleans()):
        values.flat[0] = pick(draw, valid, [np.nan, np.inf, -np.inf], [1e30, -1.0])
    scales = [{}, {"scale": 256}, {"scale": 1.0}] if name.endswith(".png") else [{}]
    options = pick(draw, valid, scales, [{"scale": 0}, {"scale": 256}])
    return values, name, options


@fuzz(WRITER_EXAMPLES)
@given(maps(), st.booleans())
def test_write_disparity_writes_whole_files_or_nothing(tmp_path, case, existing):
    values, name, options = case
    path = tmp_path / name
    if existing:
        path.write_bytes(b"earlier")
    try:
        io.write_disparity(path, values, **options)
    except (ValueError, TypeError) as exc:
        one_line(exc)
        # nothing half-written: the earlier file (or none) is there, untouched
        assert sorted(p.name for p in tmp_path.iterdir()) == ([name] if existing else [])
        if existing:
            assert path.read_bytes() == b"earlier"
    else:
        assert sorted(p.name for p in tmp_path.iterdir()) == [name]
        assert io.is_complete(path)
        back = io.read_disparity(path)
        assert back.shape == values.shape
    for p in tmp_path.iterdir():
        p.unlink()


# --------------------------------------------------------------------------- dcstereo run


@pytest.fixture(scope="module")
def pair_files(tmp_path_factory):
    """A 16 x 40 pair (uint8 gray left, RGB right) and damaged versions of it."""
    folder = tmp_path_factory.mktemp("run-inputs")
    rng = np.random.default_rng(8)
    right = rng.integers(0, 256, (16, 40, 3), dtype=np.uint8)
    left = np.roll(right, 4, axis=1)[:, :, 1]
    Image.fromarray(left).save(folder / "left.png")
    Image.fromarray(right).save(folder / "right.png")
    data = (folder / "right.png").read_bytes()
    (folder / "truncated.png").write_bytes(data[: len(data) // 2])
    (folder / "notimage.png").write_bytes(b"not an image at all")
    (folder / "other-size.png").write_bytes(_encode("png-gray", 1))
    (folder / "bomb.png").write_bytes(_oversized(_encode("png-gray", 2), "png-gray", 13000, 13000))
    (folder / "folder.png").mkdir()
    return folder


@st.composite
def run_commands(draw, inputs):
    valid = draw(st.booleans())  # half and half: each failure is worth a look here
    bad_inputs = ["truncated.png", "notimage.png", "other-size.png", "bomb.png", "folder.png",
                  "missing.png"]  # fmt: skip
    args = ["run"] + [
        str(inputs / pick(draw, valid, [name], bad_inputs)) for name in ("left.png", "right.png")
    ]
    output = pick(draw, valid, ["d.pfm", "d.png", "d.PFM"], ["d.txt", "sub/d.pfm", "left.png"])
    method = pick(draw, valid, dcstereo.METHODS)
    args += ["-o", output, "--method", method, "-q"]
    dmin = draw(st.integers(-8, 8)) if draw(st.booleans()) else 0
    if dmin:
        args += ["--min-disparity", str(dmin)]
    dmax = draw(st.integers(max(dmin, 0), 39) if valid else st.integers(-3, 45))  # 40 wide
    args += ["--max-disparity", str(dmax)]
    if dmin < 0 and output.endswith(".png") and valid:
        args[args.index("--min-disparity") + 1] = "0"  # a PNG holds no negative disparity
    if draw(st.booleans()):
        args += ["--window", str(pick(draw, valid, [1, 3, 5, 7], [4, 0, 99, "x"]))]
    if draw(st.booleans()) and (_takes(method, cost="bt") or not valid):
        args += ["--cost", "bt"]
    if draw(st.integers(0, 3)) == 0:
        args += ["--occlusion-cost", str(pick(draw, valid, [2.0, 5.0], [0.0, -1.0]))]
    if draw(st.integers(0, 3)) == 0:
        args += ["--median", str(pick(draw, valid, [3, 5], [4]))]
    if draw(st.integers(0, 3)) == 0:
        args += ["--subpixel", "parabola"]
    if draw(st.integers(0, 3)) == 0:
        args += ["--fill"]
    extras = []
    if draw(st.integers(0, 3)) == 0:
        extras.append(("--preview", pick(draw, valid, ["p.png"], ["p.jpg", output])))
    if draw(st.integers(0, 3)) == 0:
        extras.append(("--occlusion-out", pick(draw, valid, ["o.png"], ["o.pfm"])))
    if draw(st.integers(0, 5)) == 0:
        extras.append(("--confidence-out", "c.pfm"))
    for flag, name in extras:
        args += [flag, name]
    existing = draw(st.booleans())
    return args, [output] + [name for _, name in extras], existing


@fuzz(RUN_EXAMPLES)
@given(data=st.data())
def test_run_exits_zero_with_whole_outputs_or_one_error_line_and_no_file(
    pair_files, tmp_path, data
):
    args, outputs, existing = data.draw(run_commands(pair_files))
    workdir = tmp_path / "work"
    workdir.mkdir()
    old = os.getcwd()
    os.chdir(workdir)
    try:
        before = {}
        if existing:  # an earlier file at each output path must survive a failure untouched
            for name in outputs:
                if "/" not in name:
                    (workdir / name).write_bytes(b"earlier " + name.encode())
                    before[name] = (workdir / name).read_bytes()
        with no_warnings():
            result = CliRunner().invoke(main, args)
        assert result.exception is None or isinstance(result.exception, SystemExit), (
            args,
            result.output,
            repr(result.exception),
        )
        lines = result.output.splitlines()
        event(f"exit code {result.exit_code}")
        if result.exit_code == 0:
            assert lines == []  # -q: nothing on success
            disparity = io.read_disparity(outputs[0])
            assert disparity.shape == (16, 40)
            for name in outputs:
                assert io.is_complete(name), name
        else:
            assert "Traceback" not in result.output
            if result.exit_code == 1:
                assert len(lines) == 1 and lines[0].startswith("Error: "), (args, lines)
            else:  # click's own usage errors: its usage lines, then one "Error:" line
                assert result.exit_code == 2 and lines[-1].startswith("Error: "), (args, lines)
            # no output written, earlier files untouched, no temporary file left
            files = sorted(str(p.relative_to(workdir)) for p in workdir.rglob("*") if p.is_file())
            assert files == sorted(before), (args, files)
            for name, content in before.items():
                assert (workdir / name).read_bytes() == content
        assert not [p for p in workdir.rglob(".*")], args
    finally:
        os.chdir(old)
        for p in sorted(workdir.rglob("*"), reverse=True):
            p.rmdir() if p.is_dir() else p.unlink()
        workdir.rmdir()

"""The leaks an outside fuzz found (issue #50), and the promises around them.

1. A PNG whose header claims 89-179 million pixels printed Pillow's
   ``DecompressionBombWarning`` (a site-packages path and a ``warnings.warn(`` line)
   before the one-line error: the readers now have a pixel limit of their own. (The
   fuzz of ``test_fuzz.py`` found a second such leak: a TIFF cut after its header printed
   Pillow's ``Corrupt EXIF data`` warning; Pillow's warnings are now silenced while
   dcstereo decodes.)
2. A ``dcstereo run`` killed mid-write left ``.d.tmpXXXXXXXX.pfm`` and a nested
   ``..d.tmpX.tmpY.pfm`` (``write_pfm``'s atomic write inside ``run``'s) that no later
   run removed: one level of temporary files, and every name a killed run leaves is
   cleaned by the next ``run``, ``batch`` or ``video`` of that output.
"""

import os
import pathlib
import signal
import struct
import subprocess
import sys
import textwrap
import warnings
import zlib

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import dcstereo
from dcstereo import api, io
from dcstereo.cli import main

DATA = pathlib.Path(__file__).parent / "data"

# --------------------------------------------------------------------------- pixel limit


def png_header_only(path, width, height):
    """Write a PNG whose header claims ``width x height`` gray pixels, with no real data."""

    def chunk(kind, data):
        return (
            struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
        )

    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(b"\0" * 16))
        + chunk(b"IEND", b"")
    )
    return path


def cli(*args, env=None, warnings_as_errors=True):
    """Run ``dcstereo ARGS`` in a fresh process (``-W error`` by default)."""
    command = [sys.executable] + (["-W", "error"] if warnings_as_errors else [])
    command += ["-c", "from dcstereo.cli import main; main()", *map(str, args)]
    environment = {**os.environ, **(env or {})}
    return subprocess.run(command, capture_output=True, text=True, env=environment, timeout=300)


def scene(folder):
    """A Middlebury 2014 scene folder (im0, im1, disp0GT.pfm, calib.txt) of 20 x 30."""
    folder.mkdir()
    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, (20, 30), dtype=np.uint8)
    Image.fromarray(image).save(folder / "im0.png")
    Image.fromarray(image).save(folder / "im1.png")
    io.write_pfm(folder / "disp0GT.pfm", np.full((20, 30), 2.0, np.float32))
    (folder / "calib.txt").write_text(
        "cam0=[100 0 15; 0 100 10; 0 0 1]\ncam1=[100 0 15; 0 100 10; 0 0 1]\ndoffs=0\n"
        "baseline=100\nwidth=30\nheight=20\nndisp=8\n"
    )
    return folder


@pytest.mark.parametrize("warnings_as_errors", [False, True], ids=["default", "-W error"])
@pytest.mark.parametrize("command", ["run", "eval"])
def test_a_png_claiming_169_million_pixels_is_one_line_naming_the_limit(
    tmp_path, command, warnings_as_errors
):
    # before: Pillow's DecompressionBombWarning (its file and line, then "warnings.warn(")
    # printed above "Error: ... truncated or corrupt image data"; under -W error the
    # warning became that error's text
    bomb = DATA / "png_header_13000x13000.png"  # the file, 68 bytes
    if command == "run":
        args = ["run", bomb, bomb, "-o", tmp_path / "d.pfm", "--max-disparity", 16]
    else:
        args = ["eval", bomb, scene(tmp_path / "scene")]
    done = cli(*args, warnings_as_errors=warnings_as_errors)
    assert done.returncode == 1
    assert done.stderr.splitlines() == [
        f"Error: cannot read image '{bomb}': "
        "13000 x 13000 is 169,000,000 pixels, more than the limit of 100,000,000 per "
        "image; raise it with the environment variable DCSTEREO_MAX_PIXELS=<pixels> "
        "(in Python: max_pixels=)"
    ]
    assert not (tmp_path / "d.pfm").exists()


@pytest.mark.parametrize("command", ["run", "eval"])
def test_a_tiff_cut_after_its_header_is_one_line_without_pillows_exif_warning(tmp_path, command):
    # before: "UserWarning: Corrupt EXIF data.  Expecting to read 2 bytes but only got 0."
    # (TiffImagePlugin.py's path and "warnings.warn(str(msg))") above the error line
    cut = DATA / "tiff_truncated_after_header.tif"  # b"II*\0\x08\0\0\0"
    if command == "run":
        args = ["run", cut, cut, "-o", tmp_path / "d.pfm", "--max-disparity", 4]
    else:
        args = ["eval", cut, scene(tmp_path / "scene")]
    done = cli(*args, warnings_as_errors=False)
    assert done.returncode == 1
    assert done.stderr.splitlines() == [
        f"Error: cannot read image '{cut}': not a recognised image format"
    ]
    assert not io.is_complete(cut)  # is_complete opens it too: silently


@pytest.mark.parametrize(
    ("side", "limit"),
    [(9500, None), (20000, "500_000_000")],
    ids=["between Pillow's warning and our limit", "past Pillow's error, limit raised"],
)
def test_no_pillow_warning_below_the_limit(tmp_path, side, limit):
    # 90.25 million pixels: past Pillow's warning (89.5 million) but within our limit;
    # 400 million: past Pillow's own error (179 million), within a raised limit. Either
    # is read (and found truncated: the header is all there is) without a word of Pillow's
    big = png_header_only(tmp_path / "big.png", side, side)
    env = {} if limit is None else {"DCSTEREO_MAX_PIXELS": limit}
    done = cli("run", big, big, "-o", tmp_path / "d.pfm", "--max-disparity", 16, env=env)
    assert done.returncode == 1
    assert done.stderr.splitlines() == [
        f"Error: cannot read image '{big}': truncated or corrupt image data (image file is "
        "truncated (0 bytes not processed))"
    ]


def test_the_limit_is_the_argument_then_the_environment_then_100_million(tmp_path, monkeypatch):
    path = tmp_path / "a.png"
    Image.fromarray(np.zeros((30, 40), np.uint8)).save(path)
    monkeypatch.delenv("DCSTEREO_MAX_PIXELS", raising=False)
    assert io.pixel_limit() == io.MAX_PIXELS == 100_000_000
    assert io.read_image(path, max_pixels=1200).shape == (30, 40)  # the limit is inclusive
    with pytest.raises(ValueError, match=r"^cannot read image '.*a.png': 40 x 30 is 1,200 "
                       r"pixels, more than the limit of 1,199 per image; raise it"):  # fmt: skip
        io.read_image(path, max_pixels=1199)
    monkeypatch.setenv("DCSTEREO_MAX_PIXELS", "1199")
    with pytest.raises(ValueError, match="more than the limit of 1,199 per image"):
        io.read_image(path)
    with pytest.raises(ValueError, match="more than the limit of 1,199 per image"):
        io.read_disparity(path, scale=1)
    assert io.read_image(path, max_pixels=1200).shape == (30, 40)  # the argument first
    for bad in ("abc", "0", "-5", "1e9"):
        monkeypatch.setenv("DCSTEREO_MAX_PIXELS", bad)
        with pytest.raises(ValueError, match=f"^DCSTEREO_MAX_PIXELS must be a whole number "
                           f"of pixels, 1 or more, got '{bad}'$"):  # fmt: skip
            io.read_image(path)
    with pytest.raises(TypeError, match="max_pixels must be an integer"):
        io.read_image(path, max_pixels=1e9)
    with pytest.raises(ValueError, match="max_pixels must be 1 or more"):
        io.read_image(path, max_pixels=0)


def test_a_pfm_over_the_limit_is_refused_from_its_header(tmp_path):
    path = tmp_path / "d.pfm"
    io.write_pfm(path, np.zeros((30, 40), np.float32))
    assert io.read_disparity(path, max_pixels=1200).shape == (30, 40)
    with pytest.raises(ValueError, match=r"^cannot read PFM file '.*d.pfm': 40 x 30 is 1,200"):
        io.read_pfm(path, max_pixels=1000)
    # a header that claims 400 million pixels is refused before any data is read
    (tmp_path / "huge.pfm").write_bytes(b"Pf\n20000 20000\n-1.0\n" + b"\0" * 64)
    with pytest.raises(ValueError, match="is 400,000,000 pixels, more than the limit"):
        io.read_disparity(tmp_path / "huge.pfm")


def test_pillows_own_settings_are_put_back(tmp_path):
    path = DATA / "png_header_13000x13000.png"
    before = Image.MAX_IMAGE_PIXELS, list(warnings.filters)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(ValueError, match="more than the limit"):
            io.read_image(path)
        with pytest.raises(ValueError, match="truncated"):
            io.read_image(path, max_pixels=10**9)
        assert io.is_complete(path)  # the chunks' CRCs are right
        assert not io.is_complete(DATA / "tiff_truncated_after_header.tif")
    assert caught == []
    assert (Image.MAX_IMAGE_PIXELS, list(warnings.filters)) == before
    # Pillow on its own still warns: its settings are set aside only while dcstereo reads
    with pytest.warns(Image.DecompressionBombWarning), Image.open(path):
        pass


# --------------------------------------------------------------------------- temporary files

#: Run the CLI with ``Path.write_bytes`` of a hidden (temporary) file writing half its data,
#: then SIGKILL of the process: a kill in the middle of writing an output.
KILL_MID_WRITE = textwrap.dedent(
    """
    import os, pathlib, signal, sys
    real = pathlib.Path.write_bytes
    def write_bytes(self, data):
        if self.name.startswith("."):
            with open(self, "wb") as f:
                f.write(data[: len(data) // 2])
            os.kill(os.getpid(), signal.SIGKILL)
        return real(self, data)
    pathlib.Path.write_bytes = write_bytes
    from dcstereo.cli import main
    main(sys.argv[1:])
    """
)


def hidden(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


@pytest.fixture
def sources(pair):
    """The conftest pair as ``run``'s two files, a ``batch`` source and ``video`` folders."""
    folder, _ = pair
    left, right = folder / "left.png", folder / "right.png"
    for sub in ("batch/p0", "batch/p1", "lefts", "rights"):
        (folder / sub).mkdir(parents=True)
    for sub in ("batch/p0", "batch/p1"):
        (folder / sub / "left.png").write_bytes(left.read_bytes())
        (folder / sub / "right.png").write_bytes(right.read_bytes())
    for index in range(2):
        (folder / "lefts" / f"{index}.png").write_bytes(left.read_bytes())
        (folder / "rights" / f"{index}.png").write_bytes(right.read_bytes())
    return folder


def command_of(kind, sources, out):
    """The arguments of ``dcstereo KIND`` writing ``out`` (a file for run, else a folder)."""
    common = ["--max-disparity", "12", "--method", "dsi3", "--threads", "1", "-q"]
    if kind == "run":
        return ["run", sources / "left.png", sources / "right.png", "-o", out, *common]
    if kind == "batch":
        return ["batch", sources / "batch", "-o", out, *common]
    return ["video", sources / "lefts", sources / "rights", "-o", out, *common]


#: The disparity file each command writes first, in the output folder.
FIRST_OUTPUT = {"run": "d.pfm", "batch": "p0.pfm", "video": "frame00000.pfm"}


@pytest.mark.parametrize("kind", ["run", "batch", "video"])
def test_a_command_killed_mid_write_leaves_one_temporary_that_the_next_run_removes(
    sources, tmp_path, kind
):
    # before: run left .d.tmpX.pfm (0 bytes) and ..d.tmpX.tmpY.pfm (part of the map), and
    # no later run removed either
    folder = tmp_path / "out"
    folder.mkdir()
    out = folder / "d.pfm" if kind == "run" else folder
    args = [str(a) for a in command_of(kind, sources, out)]
    killed = subprocess.run(
        [sys.executable, "-c", KILL_MID_WRITE, *args], capture_output=True, timeout=300
    )
    assert killed.returncode == -signal.SIGKILL, killed.stderr.decode()
    first = folder / FIRST_OUTPUT[kind]
    assert not first.exists()
    left = hidden(folder)
    assert len(left) == 1, left  # one level of temporary files
    assert left[0].startswith(f".{first.stem}.tmp") and left[0].endswith(".pfm")
    assert len(left[0]) == len(first.name) + io.TEMPORARY_NAME_EXTRA
    assert io.stale_temporaries(first) == [folder / left[0]]
    again = CliRunner().invoke(main, args)
    assert again.exit_code == 0, again.output
    assert hidden(folder) == []
    assert io.is_complete(first)


#: Names an earlier version left beside ``d.pfm`` when killed, and names it must keep.
OLD_LEFTOVERS = [".d.tmp0123abcd.pfm", "..d.tmp0123abcd.tmp4567cdef.pfm"]
NOT_LEFTOVERS = [
    ".d.tmp0123abcdx.pfm",  # a token too long
    ".d.tmp0123ABCD.pfm",  # not the lower-case hex of the tokens
    ".d.tmp0123abc.pfm",  # a token too short
    ".e.tmp0123abcd.pfm",  # another output's
    "..d.tmp0123abcd.pfm",  # the temporary file of ".d.pfm", not of "d.pfm"
    ".d.tmp0123abcd.png",  # of "d.png"
    ".d.pfm",
]


@pytest.mark.parametrize("kind", ["run", "batch", "video"])
def test_leftovers_of_earlier_versions_nested_or_not_are_removed(sources, tmp_path, kind):
    folder = tmp_path / "out"
    folder.mkdir()
    first = folder / FIRST_OUTPUT[kind]
    out = first if kind == "run" else folder
    leftovers = [n.replace("d.", f"{first.stem}.", 1) for n in OLD_LEFTOVERS]
    others = [n.replace("d.", f"{first.stem}.", 1) for n in NOT_LEFTOVERS]
    for name in leftovers + others:
        (folder / name).write_bytes(b"part of a map")
    assert io.stale_temporaries(first) == sorted(folder / n for n in leftovers)
    done = CliRunner().invoke(main, [str(a) for a in command_of(kind, sources, out)])
    assert done.exit_code == 0, done.output
    assert hidden(folder) == sorted(others)


def test_stale_temporaries_know_every_shape_of_name(tmp_path):
    cases = {
        "d.pfm": [".d.tmp01234567.pfm", "..d.tmp01234567.tmp89abcdef.pfm",
                  "...d.tmp01234567.tmp89abcdef.tmp00000000.pfm"],
        "no_suffix": [".no_suffix.tmp01234567", "..no_suffix.tmp01234567.tmp89abcdef"],
        ".hidden.pfm": ["..hidden.tmp01234567.pfm"],
        "a.b.c.png": [".a.b.c.tmp01234567.png"],
        "x[1]*?.pfm": [".x[1]*?.tmp01234567.pfm"],
        "t.tmp01234567.pfm": [".t.tmp01234567.tmp89abcdef.pfm"],  # a token in the name
    }  # fmt: skip
    for names in cases.values():
        for name in names:
            (tmp_path / name).write_bytes(b"")
    for target, names in cases.items():
        assert io.stale_temporaries(tmp_path / target) == sorted(tmp_path / n for n in names)
    # ".t.tmp01234567.tmp89abcdef.pfm" is not "t.pfm"'s nested one (that has two dots)
    assert io.stale_temporaries(tmp_path / "t.pfm") == []
    assert io.stale_temporaries(tmp_path / "missing" / "d.pfm") == []


def test_a_writer_inside_an_atomic_write_writes_its_temporary_file_directly(tmp_path, monkeypatch):
    written = []
    real = pathlib.Path.write_bytes
    monkeypatch.setattr(pathlib.Path, "write_bytes", lambda p, d: written.append(p) or real(p, d))
    target = tmp_path / "d.pfm"
    with io.atomic_writes() as stage:
        tmp = stage(target)
        io.write_disparity(tmp, np.ones((4, 5), np.float32))
        assert hidden(tmp_path) == [tmp.name]
    assert written == [tmp]  # no temporary file of the temporary file
    assert hidden(tmp_path) == []
    np.testing.assert_array_equal(io.read_disparity(target), np.ones((4, 5)))
    # outside any atomic write, a hidden name is an output like another
    io.write_pfm(tmp_path / ".x.pfm", np.ones((2, 2)))
    assert written[-1].name.startswith("..x.tmp")


HOLD_A_TEMPORARY = textwrap.dedent(
    """
    import sys
    from dcstereo import io
    with io.atomic_write(sys.argv[1]) as tmp:
        print(tmp.name, flush=True)
        sys.stdin.read()
    """
)


@pytest.mark.skipif(sys.platform == "win32", reason="the lock is POSIX flock")
def test_a_live_writers_temporary_is_never_removed_until_it_dies(tmp_path):
    target = tmp_path / "d.pfm"
    writer = subprocess.Popen(
        [sys.executable, "-c", HOLD_A_TEMPORARY, str(target)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        name = writer.stdout.readline().strip()
        assert io.stale_temporaries(target) == [tmp_path / name]
        assert io.remove_stale_temporaries(target) == []  # its writer is alive
        assert hidden(tmp_path) == [name]
        os.kill(writer.pid, signal.SIGKILL)
        writer.wait(timeout=60)
    finally:
        if writer.poll() is None:
            writer.kill()
        writer.wait()
        writer.stdin.close()
        writer.stdout.close()
    assert io.remove_stale_temporaries(target) == [tmp_path / name]
    assert hidden(tmp_path) == []


# --------------------------------------------------------------------------- out of memory


def test_out_of_memory_is_one_line_in_the_library_and_the_cli(pair, monkeypatch):
    # before: numpy's MemoryError (not numba's SystemError) went through match unchanged,
    # and through the CLI as a traceback
    folder, _ = pair
    real = np.empty

    def refuse_big(shape, *args, **kwargs):
        if int(np.prod(shape)) >= 24 * 64:  # the result's arrays
            raise MemoryError("Unable to allocate 12.0 TiB for an array")
        return real(shape, *args, **kwargs)

    monkeypatch.setattr(api.np, "empty", refuse_big)
    left = io.read_image(folder / "left.png")
    message = "out of memory matching 24 x 64 images over 13 disparities with method 'dsi3'"
    with pytest.raises(MemoryError, match=f"^{message}$"):
        dcstereo.match(left, left, max_disparity=12, method="dsi3")
    out = folder / "d.pfm"
    done = CliRunner().invoke(
        main, ["run", str(folder / "left.png"), str(folder / "right.png"), "-o", str(out),
               "--max-disparity", "12", "--method", "dsi3", "-q"],
    )  # fmt: skip
    assert done.exit_code == 1
    assert done.output == f"Error: {message}\n"
    assert not out.exists() and hidden(folder) == []

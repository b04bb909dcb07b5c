"""The large-image paths, exercised on small images by setting small memory bounds.

Wide images take other paths than small ones: past ``mbands.DC_BAND_BYTES`` (8 MiB) ``dc``
and ``dsi3-gcp`` make the band's costs twice instead of keeping them; the band cost
arrays of the chunks running at once are held to ``mbands.BAND_ARRAY_BYTES`` (512 MiB)
together, fewer chunks at a time, and where one array alone would pass it the rows run
one at a time; ``tiling.match_tiled`` (``dcstereo run --tile-rows``) matches bands of
rows on their own. Here the bounds are set to a few KiB so that a 48 x 64 pair takes
every one of these paths, and each must give the map of the unbounded run, bit for bit
(``sgm``'s tiles where their context reaches the image's edges, as ``tiling`` promises).
When memory runs out all the same, ``match`` says so in one line (``MemoryError``), and
``dcstereo run`` prints that line; this is checked with a real failed allocation, in a
process whose address space is capped.
"""

import os
import subprocess
import sys
import textwrap
from unittest import mock

import numba
import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import dcstereo
import synthetic
from dcstereo import io
from dcstereo.batch.tiling import match_tiled
from dcstereo.cli import main
from dcstereo.methods import _bands as mbands
from dcstereo.methods import dc as mdc
from method_cases import method_cases

MAX_DISPARITY = 12


CASES = method_cases(MAX_DISPARITY, bt={"cost": "bt"}, lr={"lr_check": True})

#: (BAND_ARRAY_BYTES, DC_BAND_BYTES): a band's cost array of this pair is 64 columns x 15
#: disparities x 8 rows x 8 bytes, 60 KiB: none fits 4 KiB (row by row), one at a time
#: fits 64 KiB, four fit 256 KiB; DC_BAND_BYTES 0 makes dc's and dsi3-gcp's costs twice.
BOUNDS = [(0, 0), (4096, 4096), (64 * 1024, 0), (256 * 1024, 0), (256 * 1024, 64 * 1024)]

#: Output rows per tile. sgm's paths cross the bands, so its tiles equal the whole map only
#: where each band's context (``window // 2 + sgm.STRIP_MARGIN``, 33 rows) reaches both
#: edges of the image (the ``tiling`` module's text): 16-row bands of this 48-row pair do,
#: 13-row ones do not.
TILE_ROWS = {"sgm": 16, "sgm-accurate": 16}


def _pair():
    rng = np.random.default_rng(77)
    left, right, _ = synthetic.object_pair(rng, 48, 64, 3, 10, (20, 40))
    return left, right


def _same(got, expected, what):
    assert got.disparity.tobytes() == expected.disparity.tobytes(), what
    np.testing.assert_array_equal(got.flags, expected.flags, err_msg=what)
    assert got.path_cost.tobytes() == expected.path_cost.tobytes(), what
    if expected.features is None:
        assert got.features is None, what
    else:
        np.testing.assert_array_equal(got.features, expected.features, err_msg=what)


@pytest.fixture
def two_threads():
    """Run on two threads where numba has them (more chunks than one thread makes)."""
    before = numba.get_num_threads()
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    yield
    numba.set_num_threads(before)


@pytest.mark.parametrize(("name", "options"), CASES, ids=[name for name, _ in CASES])
def test_small_memory_bounds_and_tiles_give_the_unbounded_map(name, options, two_threads):
    left, right = _pair()
    expected = dcstereo.match(left, right, max_disparity=MAX_DISPARITY, **options)
    for band_bytes, dc_bytes in BOUNDS:
        with (
            mock.patch.object(mbands, "BAND_ARRAY_BYTES", band_bytes),
            mock.patch.object(mbands, "DC_BAND_BYTES", dc_bytes),
        ):
            got = dcstereo.match(left, right, max_disparity=MAX_DISPARITY, **options)
            _same(got, expected, f"bounds {band_bytes}, {dc_bytes}")
            rows = TILE_ROWS.get(name, 13)
            tiled = match_tiled(left, right, tile_rows=rows, max_disparity=MAX_DISPARITY, **options)
            _same(tiled, expected, f"tiled, bounds {band_bytes}, {dc_bytes}")


def test_the_bounds_reach_the_paths():
    # the bounds above are read where the paths are chosen (not frozen at import): a band
    # array of this pair fits the default bounds, not 4 KiB (the paths of the scanline
    # methods: sgm's strips have a bound of their own, sgm.VOLUME_BYTES)
    params = dcstereo.MatchParams(max_disparity=MAX_DISPARITY, method="dc", cost="bt")
    assert mbands._band_array_fits(params, 64)
    with mock.patch.object(mbands, "BAND_ARRAY_BYTES", 4096):
        assert not mbands._band_array_fits(params, 64)
    dc = dcstereo.MatchParams(max_disparity=MAX_DISPARITY, method="dc")
    assert mdc._dc_band_mode(dc, 64) == 2  # the costs kept
    with mock.patch.object(mbands, "DC_BAND_BYTES", 0):
        assert mdc._dc_band_mode(dc, 64) == 3  # the costs made twice


#: Match a 1 x 60000 pair over 60000 disparities (gigabytes of DP records) in a process
#: whose address space is capped at 2.5 GB: the allocation fails for real.
OUT_OF_MEMORY = textwrap.dedent(
    """
    import resource, sys
    import numpy as np
    import dcstereo
    left = np.random.default_rng(0).integers(0, 256, (16, 64), dtype=np.uint8)
    for method in dcstereo.METHODS:  # loaded (or compiled) before the cap
        dcstereo.match(left, left, max_disparity=8, method=method, window=1)
    cap = 2500 * 2**20
    resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    if sys.argv[1:]:
        from dcstereo.cli import main
        main(sys.argv[1:])
    wide = np.random.default_rng(1).integers(0, 256, (1, 60000), dtype=np.uint8)
    for method in dcstereo.METHODS:
        try:
            dcstereo.match(wide, wide, max_disparity=59999, method=method, window=1)
            print(method, "matched")
        except MemoryError as exc:
            print(method, "MemoryError:", exc)
    """
)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_AS caps memory on Linux")
def test_a_real_failed_allocation_is_one_line_in_the_library_and_the_cli(tmp_path):
    small = np.random.default_rng(0).integers(0, 256, (16, 64), dtype=np.uint8)
    for method in dcstereo.METHODS:  # compiled here first: the processes load them
        dcstereo.match(small, small, max_disparity=8, method=method, window=1)
    env = {**os.environ, "NUMBA_NUM_THREADS": "2"}
    done = subprocess.run(
        [sys.executable, "-c", OUT_OF_MEMORY], capture_output=True, text=True, env=env,
        timeout=900,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == [
        f"{method} MemoryError: out of memory matching 1 x 60000 images over 60000 "
        f"disparities with method '{method}'"
        for method in dcstereo.METHODS
    ]
    wide = np.random.default_rng(1).integers(0, 256, (1, 60000), dtype=np.uint8)
    Image.fromarray(wide).save(tmp_path / "wide.png")
    out = tmp_path / "d.pfm"
    args = ["run", tmp_path / "wide.png", tmp_path / "wide.png", "-o", out,
            "--max-disparity", "59999", "--window", "1", "--method", "dsi3", "-q"]  # fmt: skip
    done = subprocess.run(
        [sys.executable, "-c", OUT_OF_MEMORY, *map(str, args)], capture_output=True, text=True,
        env=env, timeout=900,
    )  # fmt: skip
    assert done.returncode == 1
    assert done.stderr.splitlines() == [
        "Error: out of memory matching 1 x 60000 images over 60000 disparities with method 'dsi3'"
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["wide.png"]


def test_the_cli_tiles_a_pair_as_match_does(pair, two_threads):
    # dc with BT costs: the bounds are those of the scanline methods' band arrays
    folder, _ = pair
    out = folder / "tiled.pfm"
    with (
        mock.patch.object(mbands, "BAND_ARRAY_BYTES", 0),
        mock.patch.object(mbands, "DC_BAND_BYTES", 0),
    ):
        done = CliRunner().invoke(
            main, ["run", str(folder / "left.png"), str(folder / "right.png"), "-o", str(out),
                   "--max-disparity", "12", "--tile-rows", "5", "--method", "dc", "--cost", "bt",
                   "-q"],
        )  # fmt: skip
    assert done.exit_code == 0, done.output
    left = io.read_image(folder / "left.png")
    right = io.read_image(folder / "right.png")
    expected = dcstereo.match(left, right, max_disparity=12, method="dc", cost="bt")
    np.testing.assert_array_equal(io.read_disparity(out), expected.disparity)

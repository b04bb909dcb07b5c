"""What the commands write: never over an input, all outputs or none, only real formats."""

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import synthetic
from dcstereo import io
from dcstereo.cli import main
from dcstereo.cli._common import staged_outputs


@pytest.fixture
def folder(tmp_path, monkeypatch):
    """A pair in a fresh folder that is also the working directory."""
    monkeypatch.chdir(tmp_path)
    rng = np.random.default_rng(202)
    left, right, _ = synthetic.object_pair(rng, 24, 64, 2, 8, (24, 44))
    Image.fromarray(left).save(tmp_path / "left.png")
    Image.fromarray(right).save(tmp_path / "right.png")
    return tmp_path


def invoke(folder, *args):
    """Run ``dcstereo`` in FOLDER, the working directory."""
    assert folder.samefile(".")
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def snapshot(folder):
    """Every file in FOLDER (hidden temporaries included) with its bytes."""
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}


def assert_one_line_error(result, code, message):
    assert result.exit_code == code, result.output
    assert "Traceback" not in result.output
    errors = [line for line in result.output.splitlines() if line.startswith("Error: ")]
    assert len(errors) == 1 and message in errors[0], result.output
    if code == 1:
        assert result.output.strip() == errors[0]


PAIR = ["left.png", "right.png", "--max-disparity", 10]
PAIR_DC = [*PAIR, "--method", "dc"]  # feature outputs need a method with features


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["run", *PAIR, "-o", "left.png"], "--output 'left.png' is the left input"),
        (["run", *PAIR, "-o", "./right.png"], "--output './right.png' is the right input"),
        (["compare", *PAIR, "-o", "right.png"], "--output 'right.png' is the right input"),
        (
            ["compare", *PAIR, "--gt", "g.png", "-o", "./g.png"],
            "--output './g.png' is the --gt file",
        ),
        (["scanline", *PAIR, "-y", 3, "-o", "left.png"], "--output 'left.png' is the left"),
        (
            ["run", *PAIR, "-o", "dup.pfm", "--features-out", "dup.pfm"],
            "--features-out and --output are the same file 'dup.pfm'",
        ),
        (
            ["run", *PAIR, "-o", "same.png", "--preview", "./same.png"],
            "--preview and --output are the same file './same.png'",
        ),
        (
            ["run", *PAIR, "-o", "d.pfm", "--preview", "s.png", "--occlusion-out", "s.png"],
            "--preview and --occlusion-out are the same file 's.png'",
        ),
    ],
)
def test_output_over_an_input_or_another_output_is_refused(folder, args, message):
    Image.fromarray(np.full((24, 64), 512, np.uint16)).save(folder / "g.png")
    before = snapshot(folder)
    result = invoke(folder, *args)
    assert_one_line_error(result, 1, message)
    assert snapshot(folder) == before


def failing_writer(path, *args):
    raise OSError(f"cannot write '{path}': disk full")


@pytest.mark.parametrize("existing", [False, True])
def test_run_leaves_no_partial_outputs_when_a_later_write_fails(folder, monkeypatch, existing):
    if existing:
        for name in ("part.pfm", "part.png", "part.csv"):
            (folder / name).write_text("old")
    monkeypatch.setattr(io, "write_features_csv", failing_writer)
    before = snapshot(folder)
    result = invoke(
        folder,
        "run",
        *PAIR_DC,
        "-o",
        "part.pfm",
        "--preview",
        "part.png",
        "--features-out",
        "part.csv",
    )
    assert_one_line_error(result, 1, "cannot write 'part.csv': disk full")
    assert snapshot(folder) == before


@pytest.mark.parametrize("failing", ["part.pfm", "part.png", "part.csv"])
@pytest.mark.parametrize("existing", [False, True])
def test_run_puts_the_outputs_back_when_a_move_fails_partway(
    folder, refuse_move, existing, failing
):
    # every output is written; moving one onto its name fails (its folder's permissions
    # changed during the run, say): those moved already are put back
    if existing:
        for name in ("part.pfm", "part.png", "part.csv"):
            (folder / name).write_text("old")
    refuse_move(failing)
    before = snapshot(folder)
    result = invoke(
        folder, "run", *PAIR_DC, "-o", "part.pfm", "--preview", "part.png",
        "--features-out", "part.csv",
    )  # fmt: skip
    assert_one_line_error(result, 1, f"cannot write '{failing}': permission denied")
    assert snapshot(folder) == before


def test_run_leaves_no_partial_outputs_when_a_temporary_file_cannot_be_made(folder):
    # a 255-character name is valid, its hidden temporary sibling is too long
    long_name = "f" * 251 + ".csv"
    before = snapshot(folder)
    result = invoke(folder, "run", *PAIR_DC, "-o", "part.pfm", "--features-out", long_name)
    assert_one_line_error(result, 1, f"cannot write '{long_name}'")
    assert snapshot(folder) == before


def test_staged_outputs_names_the_output_not_its_temporary_file(tmp_path):
    def refuse(path, value):
        raise ValueError(f"cannot write '{path}': value {value} too large")

    (tmp_path / "kept.txt").write_text("old")
    with pytest.raises(ValueError, match=r"^cannot write '.*b\.png': value 7 too large$"):
        with staged_outputs() as write:
            write(lambda path, text: path.write_text(text), tmp_path / "a.txt", "new")
            write(lambda path, text: path.write_text(text), tmp_path / "kept.txt", "new")
            write(refuse, tmp_path / "b.png", 7)
    assert snapshot(tmp_path) == {"kept.txt": b"old"}
    with staged_outputs() as write:
        write(lambda path, text: path.write_text(text), tmp_path / "kept.txt", "new")
        assert (tmp_path / "kept.txt").read_text() == "old"  # renamed only at the end
    assert snapshot(tmp_path) == {"kept.txt": b"new"}


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["compare", *PAIR, "-o", "cmp.pfm"], "cannot write --output 'cmp.pfm': unsupported "),
        (["scanline", *PAIR, "-y", 3, "-o", "s.pfm"], "--output 's.pfm': unsupported suffix"),
        (["run", *PAIR, "-o", "d.pfm", "--preview", "p.jpg"], "suffix '.jpg', use .png"),
        (["run", *PAIR, "-o", "d.pfm", "--occlusion-out", "oc.bmp"], "--occlusion-out 'oc.bmp'"),
    ],
)
def test_unsupported_picture_suffix_is_refused_not_written_as_png(folder, args, message):
    before = snapshot(folder)
    result = invoke(folder, *args)
    assert_one_line_error(result, 1, message)
    assert snapshot(folder) == before


@pytest.mark.parametrize("size", [["--width", 100000], ["--height", "99999999999999999999999"]])
def test_scanline_huge_picture_is_a_usage_error(folder, size):
    before = snapshot(folder)
    result = invoke(folder, "scanline", *PAIR, "-y", 3, "-o", "s.png", *size)
    assert_one_line_error(result, 2, "is not in the range 200<=x<=10000")
    assert snapshot(folder) == before


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["run", *PAIR, "-o", "d.pfm", "--draw-features"], "--draw-features needs --preview"),
        (["compare", *PAIR, "-o", "c.png", "--gt-scale", 4], "--gt-scale needs --gt"),
    ],
)
def test_option_without_the_option_it_needs_is_refused(folder, args, message):
    before = snapshot(folder)
    result = invoke(folder, *args)
    assert_one_line_error(result, 2, message)
    assert snapshot(folder) == before


def test_scanline_accepts_bt_method_names_like_compare(folder):
    result = invoke(folder, "scanline", *PAIR, "-y", 3, "-o", "s.png", "--methods", "dsi5+bt,dc")
    assert result.exit_code == 0, result.output
    assert "row 3: dsi5+bt, dc," in result.output
    assert io.read_image(folder / "s.png").shape == (800, 1200, 3)


def _scene_folder(folder):
    """A v2 scene (24 x 64, truth 2 px at scale 4) in FOLDER/scene, from the folder's pair."""
    scene = folder / "scene"
    scene.mkdir()
    for name in ("left.png", "right.png"):
        (scene / name).write_bytes((folder / name).read_bytes())
    Image.fromarray(np.full((24, 64), 8, np.uint8)).save(scene / "disp_gt.png")
    for name in ("nonocc.png", "all.png", "disc.png"):
        Image.fromarray(np.full((24, 64), 255, np.uint8)).save(scene / name)
    (scene / "meta.json").write_text('{"scale": 4, "ndisp": 10}')
    return scene


@pytest.mark.parametrize("name", ["nonocc.png", "disp_gt.png"])
def test_compare_output_over_a_file_of_the_gt_scene_folder_is_refused(folder, name):
    scene = _scene_folder(folder)
    before = snapshot(scene)
    result = invoke(folder, "compare", *PAIR, "--gt", "scene", "-o", f"scene/{name}")
    assert_one_line_error(result, 1, f"--output 'scene/{name}' is a file of the --gt scene folder")
    assert snapshot(scene) == before


def test_compare_output_under_a_new_name_in_the_gt_scene_folder_is_written(folder):
    scene = _scene_folder(folder)
    result = invoke(folder, "compare", *PAIR, "--gt", "scene", "-o", "scene/figure.png")
    assert result.exit_code == 0, result.output
    assert (scene / "figure.png").is_file()

"""Argument handling of the scripts in scripts/: clean one-line errors, no tracebacks."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"


def load(name, monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPTS))  # tune_dc imports sweep_occlusion beside it
    spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_measure_gcp_bt_help_does_not_run_the_table():
    done = subprocess.run(
        [sys.executable, str(SCRIPTS / "measure_gcp_bt.py"), "--help"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0 and "table" in done.stdout and "| scene |" not in done.stdout
    assert "nonocc" not in done.stdout.split("usage:")[0]


def test_measure_gcp_bt_unknown_mode_fails(monkeypatch, capsys):
    script = load("measure_gcp_bt", monkeypatch)
    with pytest.raises(SystemExit) as exit_info:
        script.main(["bogus"])
    assert exit_info.value.code == 2
    assert "invalid choice" in capsys.readouterr().err


@pytest.mark.parametrize("groups", ["both", "mb,outdoor"])
def test_eval_stages_unknown_group_fails_before_scoring(groups, monkeypatch, capsys):
    # "both" once scored nothing and printed an empty table
    script = load("eval_stages", monkeypatch)
    with pytest.raises(SystemExit) as exit_info:
        script.main(["--groups", groups])
    assert exit_info.value.code == 2
    captured = capsys.readouterr()
    assert "unknown group" in captured.err and captured.out == ""


@pytest.mark.parametrize(
    "argv",
    [
        ["make", "{tmp}/seq", "--frames", "0"],
        ["make", "{tmp}/seq", "--frames", "2", "--height", "-4"],
        ["make", "{file}", "--frames", "2", "--height", "40", "--width", "64"],
        ["score", "{tmp}/nothere", "{tmp}/nothere"],
    ],
)
def test_synthetic_sequence_bad_arguments_fail_cleanly(argv, tmp_path, monkeypatch, capsys):
    script = load("synthetic_sequence", monkeypatch)
    plain = tmp_path / "file"
    plain.write_text("x")
    argv = [a.format(tmp=tmp_path, file=plain) for a in argv]
    assert script.main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1
    assert not (tmp_path / "seq").exists()  # nothing made before the arguments were checked


@pytest.mark.parametrize("name", ["sweep_occlusion", "tune_dc"])
def test_sweep_outputs_are_checked_before_the_sweep(name, tmp_path, monkeypatch, capsys):
    script = load(name, monkeypatch)
    plain = tmp_path / "file"
    plain.write_text("x")
    extra = ["--scenes", "nosuch"]
    assert script.main(extra + ["--out", str(tmp_path)]) == 2
    assert "is a directory" in capsys.readouterr().err
    assert script.main(extra + ["--out", str(plain / "out.md")]) == 2
    assert "not a directory" in capsys.readouterr().err


def test_tune_dc_rejects_zero_repeats(tmp_path, monkeypatch, capsys):
    script = load("tune_dc", monkeypatch)
    assert script.main(["--out", str(tmp_path / "t.md"), "--repeats", "0"]) == 2
    assert "--repeats" in capsys.readouterr().err


def test_sweep_occlusion_bad_window_fails_cleanly(tmp_path, monkeypatch, capsys, middlebury_root):
    script = load("sweep_occlusion", monkeypatch)
    out = tmp_path / "sweep.md"
    argv = ["--scenes", "tsukuba", "--methods", "dsi3", "--costs", "10", "--window", "0"]
    assert script.main(argv + ["--out", str(out)]) == 2
    assert "window" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize(
    "name", ["tune_redert", "make_results", "measure_subpixel", "measure_confidence"]
)
def test_missing_data_fails_cleanly(name, tmp_path, monkeypatch, capsys):
    script = load(name, monkeypatch)
    argv = ["--data", str(tmp_path / "none")]
    if name == "make_results":
        argv += ["--docs", str(tmp_path / "docs"), "--readme", str(tmp_path / "README.md")]
    assert script.main(argv) == 2
    assert capsys.readouterr().err.startswith("error: ")
    assert not (tmp_path / "docs").exists()


def test_tune_redert_bad_out_fails_before_the_sweep(tmp_path, monkeypatch, capsys):
    script = load("tune_redert", monkeypatch)
    assert script.main(["--out", str(tmp_path / "none" / "r.md")]) == 2
    assert "cannot write" in capsys.readouterr().err


def test_make_figures_out_that_is_a_file_fails_cleanly(tmp_path, monkeypatch, capsys):
    script = load("make_figures", monkeypatch)
    plain = tmp_path / "file"
    plain.write_text("x")
    assert script.main(["--out", str(plain)]) == 2
    assert capsys.readouterr().err.startswith("error: ")


def test_make_figures_render_paints_the_nearest_point(monkeypatch):
    import numpy as np

    script = load("make_figures", monkeypatch)
    # three points straight ahead at 1000, 2000 and 3000: their median is the middle one,
    # which the unturned camera sees at the picture's centre, behind the nearer one
    points = np.array([[0.0, 0.0, 1000.0], [0.0, 0.0, 2000.0], [0.0, 0.0, 3000.0]])
    colors = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255]], np.uint8)
    picture = script.render(points, colors, (5, 7), 0, 100.0)
    assert picture.shape == (5, 7, 3) and picture.dtype == np.uint8
    np.testing.assert_array_equal(picture[2:4, 3:5].reshape(-1, 3), [[255, 0, 0]] * 4)
    assert (picture[:2] == 255).all() and (picture[:, :3] == 255).all()
    # turned by 90 degrees about the middle point, the others lie left and right of it
    turned = script.render(points, colors, (5, 7), 90, 1.0)
    painted = {tuple(c) for c in turned.reshape(-1, 3)} - {(255, 255, 255)}
    assert painted == {(255, 0, 0), (0, 255, 0), (0, 0, 255)}

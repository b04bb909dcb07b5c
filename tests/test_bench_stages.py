"""The band kernel's stage clock and benchmarks/bench_stages.py (no timing assertions)."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import synthetic
from dcstereo.divide import bands
from dcstereo.methods import _bands as mbands
from dcstereo.methods import dc as mdc
from dcstereo.methods import dsi as mdsi
from dcstereo.params import MatchParams

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_stages.py"
STAGES = bands.CLOCK_STAGES


@pytest.mark.parametrize("method", ["dsi5", "dc"])
def test_the_clock_times_the_stages_it_runs_and_changes_no_result(method):
    left, right = synthetic.constant_pair(np.random.default_rng(3), 40, 90, 4)
    params = MatchParams(max_disparity=9, method=method)
    run = mdc._match_dc if method == "dc" else mdsi._match_dsi
    plain = run(left, right, params)
    clock = np.zeros((mbands._band_chunks(left.shape[0]), len(STAGES)), dtype=np.int64)
    timed = run(left, right, params, clock=clock)
    np.testing.assert_array_equal(timed.disparity, plain.disparity)
    np.testing.assert_array_equal(timed.flags, plain.flags)
    np.testing.assert_array_equal(timed.path_cost, plain.path_cost)
    if method == "dc":
        np.testing.assert_array_equal(timed.features, plain.features)
    totals = dict(zip(STAGES, clock.sum(axis=0), strict=True))
    assert (clock >= 0).all()
    # every chunk ran its bands' signals, forward pass and backtrack
    for stage in ("signals", "forward", "backtrack"):
        assert (clock[:, STAGES.index(stage)] > 0).all(), stage
    dc_only = ("costs", "variances", "block match", "mask", "search")
    if method == "dc":
        assert all(totals[stage] > 0 for stage in dc_only)
    else:
        assert all(totals[stage] == 0 for stage in dc_only)


def test_bench_stages_prints_and_writes_the_table(tmp_path, capsys, monkeypatch, middlebury_root):
    monkeypatch.syspath_prepend(str(SCRIPT.parent))  # it imports bench_speed beside it
    spec = importlib.util.spec_from_file_location("bench_stages", SCRIPT)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    out = tmp_path / "stages.md"
    args = ["--scenes", "tsukuba", "--synthetic", "200x40x12", "--repeat", "1"]
    assert bench.main(args + ["--markdown", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "sum of stages" in printed and "best call" in printed
    lines = out.read_text(encoding="utf-8").splitlines()
    assert lines[0] == "| method | stage | tsukuba | synthetic |"
    rows = {tuple(cell.strip() for cell in line.strip("|").split("|")[:2]) for line in lines[2:]}
    assert ("dc", "block match") in rows and ("dsi5", "forward") in rows
    assert ("dsi5", "block match") not in rows  # a stage dsi5 does not run
    assert bench.main(["--methods", "dsi9"]) == 2
    assert bench.main(["--scenes", "nowhere"]) == 2


def test_bench_stages_bad_output_fails_before_measuring(tmp_path, capsys, monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPT.parent))
    spec = importlib.util.spec_from_file_location("bench_stages", SCRIPT)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    assert bench.main(["--synthetic", "200x40x12", "--markdown", str(tmp_path)]) == 2
    assert "is a directory" in capsys.readouterr().err
    assert bench.main(["--synthetic", "200x40x12", "--methods", ","]) == 2
    assert "no method" in capsys.readouterr().err

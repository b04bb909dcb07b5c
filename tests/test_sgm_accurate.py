"""``sgm-accurate``: ``sgm`` with the five stages that won, by one name.

It is ``sgm`` run with ``photometric="matched"``, ``row_alignment="estimated"``,
``planes=True``, ``median="weighted-planes"`` and ``edges="support-weights"``: bit for bit,
in ``match``, in tiles, in a sequence and on the command line; its stages are fixed, its
other options are ``sgm``'s. Each stage's kernels are tested against their naive twins in
their own modules (test_photometric, test_row_offsets, test_planes, test_weighted_median,
test_local_planes, test_edges).
"""

import dataclasses

import numpy as np
import pytest
from click.testing import CliRunner

import dcstereo
import synthetic
from dcstereo import io
from dcstereo import params as P
from dcstereo.batch.tiling import match_tiled
from dcstereo.cli import main
from dcstereo.methods import REGISTRY
from pins import kitti_d1, middlebury_bad1

#: The options that make ``sgm`` what ``sgm-accurate`` is.
STAGES = {
    "photometric": "matched",
    "row_alignment": "estimated",
    "planes": True,
    "median": "weighted-planes",
    "edges": "support-weights",
}


def _pair(height=48, width=80):
    rng = np.random.default_rng(5)
    left, right, _ = synthetic.object_pair(rng, height, width, 3, 11, (24, 52))
    return left, right


def _same(a, b):
    assert a.disparity.tobytes() == b.disparity.tobytes()
    np.testing.assert_array_equal(a.flags, b.flags)
    assert a.path_cost.tobytes() == b.path_cost.tobytes()


@pytest.mark.parametrize("options", [{}, {"median": 5}, {"p1": 40, "p2": 300, "fill": False}])
def test_it_is_sgm_with_its_five_stages(options):
    left, right = _pair()
    ours = dcstereo.match(left, right, max_disparity=16, method="sgm-accurate", **options)
    spelled = dcstereo.match(left, right, max_disparity=16, **{**STAGES, **options})
    _same(ours, spelled)
    assert ours.params.method == "sgm-accurate"
    # the stages change the map: not sgm's
    plain = dcstereo.match(left, right, max_disparity=16, **options)
    assert ours.disparity.tobytes() != plain.disparity.tobytes()


def test_its_stages_are_fixed_and_its_record_has_no_switch():
    params = P.MatchParams(max_disparity=16, method="sgm-accurate")
    assert {name: getattr(params, name) for name in STAGES} == STAGES
    # a record made again (dataclasses.replace) keeps them
    again = dataclasses.replace(params, fill=False)
    assert {name: getattr(again, name) for name in STAGES} == STAGES
    # the fixed value, or the option's default, is taken; another value is refused
    assert P.MatchParams(max_disparity=16, method="sgm-accurate", planes=True).planes is True
    for name, other in (("planes", False), ("photometric", "none"), ("edges", "none")):
        with pytest.raises(ValueError, match=f"^{name}={other!r}: sgm-accurate always runs"):
            P.MatchParams(max_disparity=16, method="sgm-accurate", **{name: other})
    # sgm keeps its defaults: every stage off, planes resolved to False
    sgm = P.MatchParams(max_disparity=16)
    assert (sgm.photometric, sgm.row_alignment, sgm.planes, sgm.edges, sgm.median) == (
        None, None, False, None, 5,
    )  # fmt: skip
    record = dcstereo.SGMAccurateParams(max_disparity=16, p1=50)
    assert not {"planes", "photometric", "row_alignment", "edges"} & {
        f.name for f in dataclasses.fields(record)
    }
    assert record.match_params() == P.MatchParams(max_disparity=16, method="sgm-accurate", p1=50)
    assert REGISTRY["sgm-accurate"].params is dcstereo.SGMAccurateParams
    # its costs: census-ad only (the photometric stage aligns the colour term)
    with pytest.raises(ValueError, match="not supported by sgm-accurate"):
        P.MatchParams(max_disparity=16, method="sgm-accurate", cost="census")


def test_spelled_out_names_sgm_and_its_stages():
    kwargs = {"max_disparity": 16, "method": "sgm-accurate", "median": None, "p1": 50}
    spelled = P.spelled_out(kwargs)
    assert spelled["method"] == "sgm" and spelled["p1"] == 50
    assert {name: spelled[name] for name in STAGES} == STAGES
    assert P.MatchParams(**spelled).num_disparities == 17
    plain = {"max_disparity": 16, "median": 3}
    assert P.spelled_out(plain) == plain


def test_tiles_equal_the_whole_map():
    left, right = _pair(height=40)
    whole = dcstereo.match(left, right, max_disparity=16, method="sgm-accurate")
    # 10-row bands with sgm's 33 rows of context each read the whole 40-row pair
    tiled = match_tiled(left, right, tile_rows=10, max_disparity=16, method="sgm-accurate")
    _same(tiled, whole)
    assert tiled.params.method == "sgm-accurate"


def test_a_sequence_gives_each_frame_its_map(tmp_path):
    from dcstereo.batch.video import match_sequence, open_sequence
    from dcstereo.evaluation.synthetic import synthetic_sequence

    frames = synthetic_sequence(2, height=48, width=80, seed=3)
    for side in ("left", "right"):
        (tmp_path / side).mkdir()
        for i, frame in enumerate(frames):
            io.write_rgb_png(tmp_path / side / f"img{i:03d}.png", getattr(frame, side))
    sequence = open_sequence(tmp_path / "left", tmp_path / "right")
    report = match_sequence(sequence, tmp_path / "out", max_disparity=16, method="sgm-accurate")
    assert len(report.done) == 2
    for i, frame in enumerate(frames):
        d = dcstereo.match(frame.left, frame.right, max_disparity=16, method="sgm-accurate")
        written = io.read_pfm(tmp_path / "out" / f"frame{i:05d}.pfm")
        assert np.array_equal(written, np.where(np.isnan(d.disparity), np.inf, d.disparity))


def test_cli_runs_it_and_refuses_its_fixed_stages(pair):
    folder, _ = pair
    from cli_runs import run_equals_match

    runner, args = run_equals_match(
        folder, ["--method", "sgm-accurate", "--p1", "50"], max_disparity=10,
        method="sgm-accurate", p1=50,
    )  # fmt: skip
    out = folder / "refused.pfm"
    for flag in ("--planes", "--no-planes"):
        bad = runner.invoke(main, [*args, "-o", str(out), "--method", "sgm-accurate", flag])
        assert bad.exit_code != 0
        assert "is fixed in sgm-accurate, which always runs its stages" in bad.output
        assert "Traceback" not in bad.output and not out.exists()


def test_demo_writes_its_map_and_its_png(tmp_path):
    # the demo writes a 16-bit PNG too, which holds no negative value: every pixel of the
    # map, the filled ones' fitted planes included, stays in the searched range
    pytest.importorskip("skimage")
    from dcstereo.evaluation.datasets import load_motorcycle

    out = tmp_path / "demo"
    result = CliRunner().invoke(
        main, ["demo", "--output", str(out), "--method", "sgm-accurate", "--threads", "1"]
    )
    assert result.exit_code == 0, result.output
    assert "method sgm-accurate" in result.output
    scene = load_motorcycle()
    expected = dcstereo.match(scene.left, scene.right, max_disparity=64, method="sgm-accurate")
    written = io.read_disparity(out / "disparity.pfm")
    np.testing.assert_array_equal(written, expected.disparity)
    assert (out / "disparity.png").is_file()
    assert np.nanmin(expected.disparity) >= 0 and np.nanmax(expected.disparity) <= 64


def test_the_api_and_the_cli_list_it():
    assert "sgm-accurate" in dcstereo.METHODS and dcstereo.DEFAULT_METHOD == "sgm"
    result = CliRunner().invoke(main, ["run", "--help"])
    assert "sgm-accurate" in result.output


# ---------------------------------------------------------------------- measured


@pytest.mark.slow
@pytest.mark.dataset
@pytest.mark.parametrize(
    ("name", "pinned"),
    # measured with scripts/eval_stages.py: the pins of sgm with the five stages (test_edges)
    [("tsukuba", 2.607), ("cones", 2.143)],
)
def test_it_keeps_its_measured_accuracy(middlebury_root, name, pinned):
    bad = middlebury_bad1(middlebury_root, name, method="sgm-accurate")
    assert bad <= pinned + 0.01, f"{name}: bad-1.0 {bad:.3f} % > {pinned}"


@pytest.mark.slow
@pytest.mark.dataset
def test_it_keeps_its_measured_d1_outdoors():
    d1 = kitti_d1("kitti2012_000066_10", method="sgm-accurate")
    assert d1 <= 3.660 + 0.01, f"D1 {d1:.3f} % > 3.660"

"""A CLI option checked against the library: ``dcstereo run`` with it equals ``match``."""

import numpy as np
from click.testing import CliRunner
from PIL import Image

import dcstereo
from dcstereo import io
from dcstereo.cli import main


def run_equals_match(folder, cli_args, max_disparity=10, **options):
    """Run ``dcstereo run`` on ``folder``'s pair with ``cli_args``; assert ``match``'s map.

    ``folder`` holds ``left.png`` and ``right.png`` (the conftest ``pair``); ``options``
    are ``match``'s for the same choice. Returns the runner and the ``run`` arguments
    without the options, for the test's own refusals.
    """
    left = np.asarray(Image.open(folder / "left.png"))
    right = np.asarray(Image.open(folder / "right.png"))
    args = ["run", str(folder / "left.png"), str(folder / "right.png")]
    args += ["--max-disparity", str(max_disparity)]
    runner = CliRunner()
    out = folder / "d.pfm"
    result = runner.invoke(main, [*args, "-o", str(out), *cli_args, "-q"])
    assert result.exit_code == 0, result.output
    expected = dcstereo.match(left, right, max_disparity=max_disparity, **options)
    assert io.read_pfm(out).tobytes() == expected.disparity.tobytes()
    return runner, args

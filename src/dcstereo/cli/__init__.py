"""The ``dcstereo`` command: a thin click layer, one module per subcommand.

Every command parses its options, builds parameters, calls one library function, writes
its outputs atomically and returns an exit code. Errors print one line and exit non-zero.
"""

import click

from dcstereo import __version__
from dcstereo.cli.batch import batch
from dcstereo.cli.bench import bench
from dcstereo.cli.compare import compare
from dcstereo.cli.datasets import datasets
from dcstereo.cli.demo import demo
from dcstereo.cli.eval import eval_command
from dcstereo.cli.rectify import rectify
from dcstereo.cli.run import run
from dcstereo.cli.scanline import scanline
from dcstereo.cli.video import video


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="dcstereo")
def main():
    """Dense stereo disparity with explicit occlusions (Tsai and Katsaggelos)."""


main.add_command(run)
main.add_command(demo)
main.add_command(batch)
main.add_command(video)
main.add_command(eval_command)
main.add_command(bench)
main.add_command(datasets)
main.add_command(compare)
main.add_command(scanline)
main.add_command(rectify)

"""``dcstereo datasets``: list the Middlebury registry and fetch a scene into the cache."""

import click

from dcstereo.cli._common import one_line_errors


@click.group()
def datasets():
    """Public Middlebury scenes: list them, fetch one into the cache."""


@datasets.command("list")
@one_line_errors
def list_command():
    """List the registry: name, layout, whether its checksums are verified, description."""
    from rich.table import Table

    from dcstereo.evaluation.downloads import REGISTRY
    from dcstereo.evaluation.scoring import render

    table = Table(title=f"{len(REGISTRY)} Middlebury scenes (dcstereo datasets fetch NAME)")
    for column in ("name", "layout", "files", "checksum", "description"):
        table.add_column(column)
    for name, entry in REGISTRY.items():
        table.add_row(
            name,
            entry.layout,
            str(len(entry.files)),
            "sha256" if entry.verified else "unverified",
            entry.description,
        )
    click.echo(render(table, width=140), nl=False)


@datasets.command("fetch")
@click.argument("name")
@click.option(
    "--cache",
    type=click.Path(file_okay=False),
    default=None,
    help="Cache folder (default: $DCSTEREO_CACHE, else the user cache of pooch).",
)
@click.option(
    "--allow-unverified",
    is_flag=True,
    help="Download even though the registry has no checksum for it; the sha256 of each "
    "file is printed so that you can confirm it with a trusted source.",
)
@one_line_errors
def fetch_command(name, cache, allow_unverified):
    """Download scene NAME once (checked against its sha256) and print its folder."""
    from dcstereo.evaluation.datasets import load_scene, scene_layout
    from dcstereo.evaluation.downloads import fetch

    folder, hashes = fetch(name, cache=cache, allow_unverified=allow_unverified)
    for url, digest in hashes.items():
        click.echo(f"sha256 {digest}  {url}", err=True)
    if scene_layout(folder) is not None:
        scene = load_scene(folder)
        click.echo(
            f"{name}: {scene.shape[1]}x{scene.shape[0]}, disparities "
            f"{scene.min_disparity}..{scene.max_disparity}, layout {scene.meta['layout']}",
            err=True,
        )
    click.echo(str(folder))

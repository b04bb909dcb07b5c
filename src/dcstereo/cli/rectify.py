"""``dcstereo rectify``: rectify a pair from a calibration; write the pair and its calib.txt."""

from pathlib import Path

import click

from dcstereo.cli._common import (
    CommandError,
    check_distinct_paths,
    one_line_errors,
    staged_outputs,
)

#: The files ``dcstereo rectify`` writes into its output folder.
OUTPUT_FILES = ("left.png", "right.png", "calib.txt", "valid.png")


def rectify_images(left_image, right_image, calib_paths, alpha):
    """Rectify two images read by :func:`dcstereo.io.read_image` with the files ``calib_paths``.

    Returns :func:`dcstereo.rectify`'s :class:`~dcstereo.rectification.RectifiedPair`. A
    Middlebury ``calib.txt`` is checked against the images' size (its width and height).
    """
    from dcstereo.rectification import read_calibration, rectify

    paths = list(calib_paths)
    try:
        if len(paths) == 1 and paths[0].lower().endswith(".txt"):
            return rectify(left_image, right_image, paths[0], alpha=alpha)
        return rectify(left_image, right_image, read_calibration(*paths), alpha=alpha)
    except ImportError as exc:  # OpenCV missing: one line naming the extra
        raise CommandError(str(exc)) from None


@click.command()
@click.argument("left", type=click.Path(dir_okay=False))
@click.argument("right", type=click.Path(dir_okay=False))
@click.argument("calib", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option(
    "-o",
    "--output",
    "output_dir",
    required=True,
    type=click.Path(file_okay=False),
    help="Folder for left.png, right.png, calib.txt (Middlebury's format, for run --calib) "
    "and valid.png (255: the left pixel holds image content); made when missing.",
)
@click.option(
    "--alpha",
    type=float,
    default=0.0,
    show_default=True,
    help="0: crop to pixels that all hold content; 1: keep every source pixel (black "
    "corners); between: in between (cv2.stereoRectify's alpha).",
)
@click.option("--quiet", "-q", is_flag=True, help="Print nothing on success.")
@one_line_errors
def rectify(left, right, calib, output_dir, alpha, quiet):
    """Rectify LEFT and RIGHT with the calibration CALIB; write the pair into a folder.

    CALIB is an OpenCV FileStorage file (YAML, XML or JSON) with K1, D1, K2, D2, R, T
    (M1/M2, cameraMatrix1/2 and distCoeffs1/2 are read too) and optionally image_size,
    or two such files (OpenCV's stereo_calib sample writes intrinsics.yml and
    extrinsics.yml), or a Middlebury calib.txt of a pair that is already rectified (the
    images are then copied as they are). Camera 1 took LEFT; T[0] must be negative
    (camera 2 to the right); vertical rigs are refused. Needs OpenCV (dcstereo[opencv]).
    """
    from dcstereo import io
    from dcstereo.rectification import write_middlebury_calib

    folder = Path(output_dir)
    outputs = {f"{folder / name}": folder / name for name in OUTPUT_FILES}
    inputs = {"the left input": left, "the right input": right}
    inputs.update({f"calibration {i + 1}": path for i, path in enumerate(calib)})
    check_distinct_paths(inputs, {f"-o {name}": path for name, path in outputs.items()})
    if folder.exists() and not folder.is_dir():
        raise CommandError(f"-o {folder}: it exists and is not a folder")
    left_image = io.read_image(left)
    right_image = io.read_image(right)
    pair = rectify_images(left_image, right_image, calib, alpha)
    height, width = pair.left.shape[:2]
    made = not folder.exists()
    folder.mkdir(parents=True, exist_ok=True)
    try:
        with staged_outputs() as write:
            write(_write_image, folder / "left.png", pair.left)
            write(_write_image, folder / "right.png", pair.right)
            write(write_middlebury_calib, folder / "calib.txt", pair.calibration, (width, height))
            write(io.write_mask_png, folder / "valid.png", pair.valid)
    except BaseException:
        if made:  # nothing half-written: the folder this command made goes too
            for name in OUTPUT_FILES:
                (folder / name).unlink(missing_ok=True)
            folder.rmdir()
        raise
    if not quiet:
        c = pair.calibration
        click.echo(
            f"rectified {width}x{height}: focal {c.focal:.2f} px, baseline {c.baseline:g}, "
            f"principal point ({c.cx:.2f}, {c.cy:.2f}), {100 * pair.valid.mean():.1f} % of "
            f"the left pixels valid -> {folder}"
        )


def _write_image(path, image):
    """Write a rectified image as PNG: 8-bit gray or RGB, or 16-bit gray."""
    import numpy as np
    from PIL import Image

    from dcstereo import io

    if image.dtype == np.uint16 and image.ndim == 2:
        Image.fromarray(image).save(path, format="PNG")
        return
    if image.dtype != np.uint8:
        raise ValueError(f"cannot write a {image.dtype} image as PNG: 8-bit or 16-bit gray only")
    io.write_rgb_png(path, image)

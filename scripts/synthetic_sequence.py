"""Make the synthetic stereo sequence of dcstereo.evaluation.synthetic, and score results on it.

    python scripts/synthetic_sequence.py make seq --frames 40 --height 240 --width 320
    dcstereo video seq/left seq/right -o seq-out --max-disparity 40
    python scripts/synthetic_sequence.py score seq seq-out

``make`` writes ``left/`` and ``right/`` frame folders (PNG), ``truth/`` (PFM, inf where
the left pixel is occluded) and a side-by-side video ``sbs.mp4``; ``score`` prints the
bad-pixel rates of ``frameNNNNN.pfm`` against the truth (occluded pixels not scored).
"""

import argparse
import sys
from pathlib import Path

import numpy as np

from dcstereo import io
from dcstereo.batch.video import write_video
from dcstereo.evaluation.metrics import bad_pixel_rate, density
from dcstereo.evaluation.synthetic import synthetic_sequence


def make(args):
    root = Path(args.folder)
    frames = synthetic_sequence(
        args.frames,
        height=args.height,
        width=args.width,
        background_disparity=(args.width // 40, args.width // 16),
        foreground_disparity=args.width // 9,
        seed=args.seed,
    )
    for sub in ("left", "right", "truth"):
        (root / sub).mkdir(parents=True, exist_ok=True)
    for i, frame in enumerate(frames):
        io.write_rgb_png(root / "left" / f"{i:05d}.png", frame.left)
        io.write_rgb_png(root / "right" / f"{i:05d}.png", frame.right)
        io.write_disparity(root / "truth" / f"{i:05d}.pfm", frame.disparity)
    write_video(root / "sbs.mp4", (np.hstack([f.left, f.right]) for f in frames), fps=10)
    top = int(np.nanmax(frames[0].disparity))
    print(f"{len(frames)} frames of {args.width}x{args.height} in {root}, disparities up to {top}")


def score(args):
    truths = sorted((Path(args.folder) / "truth").glob("*.pfm"))
    if not truths:
        raise ValueError(f"no truth frames (*.pfm) in '{Path(args.folder) / 'truth'}'")
    rows = []
    for i, path in enumerate(truths):
        truth = io.read_disparity(path)
        estimate = io.read_disparity(Path(args.results) / f"frame{i:05d}.pfm")
        rows.append(
            [bad_pixel_rate(estimate, truth, threshold=t) for t in (1.0, 2.0)]
            + [density(estimate, truth)]
        )
    bad1, bad2, dense = np.mean(rows, axis=0)
    print(
        f"{len(rows)} frames: bad > 1 px {bad1:.2f} %, bad > 2 px {bad2:.2f} %, "
        f"density {dense:.1f} % (mean over frames, occluded pixels not scored)"
    )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(required=True)
    p = sub.add_parser("make", help="write the sequence's frames, truth and sbs.mp4")
    p.add_argument("folder", help="where to write left/, right/, truth/ and sbs.mp4")
    p.add_argument("--frames", type=int, default=40, help="number of frames (default: 40)")
    p.add_argument("--height", type=int, default=240, help="frame height (default: 240)")
    p.add_argument("--width", type=int, default=320, help="frame width (default: 320)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    p.set_defaults(func=make)
    p = sub.add_parser("score", help="score frameNNNNN.pfm results against the truth")
    p.add_argument("folder", help="the folder 'make' wrote")
    p.add_argument("results", help="folder of frameNNNNN.pfm (dcstereo video's output)")
    p.set_defaults(func=score)
    args = parser.parse_args(argv)
    try:
        args.func(args)
    except (OSError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())

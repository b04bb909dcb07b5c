"""Evaluation: the metrics, the datasets and their layouts, scoring and benchmarks.

* :mod:`.metrics`: pure metric functions with explicit masks;
* :mod:`.datasets`: the Middlebury layouts (and, through :mod:`.kitti`, KITTI's and
  ETH3D's); :mod:`.downloads`: the public scenes' registry and fetcher;
* :mod:`.scoring`: a method run on a scene and scored (``bench``, ``evaluate_file``);
* :mod:`.synthetic`: synthetic pairs with known disparity.

The names of :mod:`.scoring` are re-exported here.
"""

from dcstereo.evaluation.scoring import (  # noqa: F401
    MASK_ORDER,
    available_methods,
    bench,
    bench_folder,
    bench_table,
    evaluate_file,
    json_rows,
    machine_description,
    mask_lines,
    mean_rows,
    missing_mask_lines,
    opencv_available,
    parse_methods,
    render,
    run_method,
    run_scene,
    scene_masks,
    score,
    scores_table,
    to_json,
)

"""Many pairs from the outside of :func:`dcstereo.match`: folders, videos, tiles, Dask.

* :mod:`.folders`: a folder of pairs (``run_batch``), on Dask with a client;
* :mod:`.video`: stereo sequences and videos;
* :mod:`.tiling`: a large pair in bands of rows.

The names of :mod:`.folders` are re-exported here.
"""

from dcstereo.batch.folders import (  # noqa: F401
    ASSUMED_OPTIONS,
    CALIB_NAME,
    CLOUD_FOLDER,
    CONFIDENCE_FOLDER,
    DEPTH_FOLDER,
    DEPTH_FORMATS,
    FAILURES_FILE,
    MAX_NAME_BYTES,
    OPTIONS_FILE,
    PAIR_NAMES,
    BatchReport,
    FailureRow,
    Pair,
    PairOutcome,
    check_recorded_options,
    check_threads,
    cloud_path,
    companion_options,
    confidence_path,
    depth_path,
    find_pairs,
    make_output_folder,
    match_pair,
    numba_threads,
    output_path,
    read_failures,
    run_batch,
    write_companions,
    write_failures,
)

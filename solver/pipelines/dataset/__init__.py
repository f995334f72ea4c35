"""Datasets: many certified puzzles in shard folders, with a Parquet manifest; resumable.

- :mod:`.request`: what a dataset holds (generators, seeds, parameter sweeps, shard size);
- :mod:`.build`: making it, shard by shard, safe to interrupt at any moment (backends: local processes);
- :mod:`.manifest`: the manifest's columns, content and canonical hashes, the Parquet files and their
  strict reader (:func:`~.manifest.manifest_rows`);
- :mod:`.manifest_row`: a manifest row as a typed record (:class:`~.manifest_row.ManifestRow`);
- :mod:`.stats`: counts, distinct puzzles and difficulty histograms (``phyrogen dataset --stats``).

docs/datasets.md walks through a dataset from the command line.
"""

from solver.pipelines.dataset.build import (
    Backend,
    BuildResult,
    EntryOutcome,
    EntryTask,
    build_dataset,
    check_dataset_root,
    local_backend,
    ray_backend,
)
from solver.pipelines.dataset.manifest import (
    COLUMNS,
    MANIFEST_FILE,
    TIMING_COLUMNS,
    canonical_hash,
    content_hash,
    manifest_rows,
    read_manifest,
)
from solver.pipelines.dataset.manifest_row import ManifestRow
from solver.pipelines.dataset.request import (
    DEFAULT_SHARD_SIZE,
    MAX_ENTRIES,
    MAX_SHARD_SIZE,
    DatasetError,
    DatasetRequest,
    Entry,
    make_request,
)
from solver.pipelines.dataset.stats import dataset_stats, plot_stats

__all__ = [
    "COLUMNS", "DEFAULT_SHARD_SIZE", "MANIFEST_FILE", "MAX_ENTRIES", "MAX_SHARD_SIZE", "TIMING_COLUMNS", "Backend",
    "BuildResult", "DatasetError", "DatasetRequest", "Entry", "EntryOutcome", "EntryTask", "ManifestRow",
    "build_dataset", "canonical_hash", "check_dataset_root", "content_hash", "dataset_stats", "local_backend",
    "make_request", "manifest_rows", "plot_stats", "ray_backend", "read_manifest",
]

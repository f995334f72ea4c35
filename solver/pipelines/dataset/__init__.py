"""Datasets: many certified puzzles in shard folders, with a Parquet manifest; resumable.

- :mod:`.request`: what a dataset holds (generators, seeds, parameter sweeps, shard size);
- :mod:`.build`: making it, shard by shard, safe to interrupt at any moment (backends: local processes);
- :mod:`.manifest`: the manifest's columns, content and canonical hashes, the Parquet files and their
  strict reader (:func:`~.manifest.manifest_rows`);
- :mod:`.manifest_row`: a manifest row as a typed record (:class:`~.manifest_row.ManifestRow`);
- :mod:`.stats`: counts, distinct puzzles and difficulty histograms (``phyrogen dataset --stats``).

docs/datasets.md walks through a dataset from the command line.
"""

import importlib

_HOMES = {
    "build": ("Backend", "BuildResult", "EntryOutcome", "EntryTask", "build_dataset", "check_dataset_root",
              "local_backend", "ray_backend"),
    "manifest": ("COLUMNS", "MANIFEST_FILE", "TIMING_COLUMNS", "canonical_hash", "content_hash", "manifest_rows",
                 "read_manifest"),
    "manifest_row": ("ManifestRow",),
    "request": ("DEFAULT_SHARD_SIZE", "MAX_ENTRIES", "MAX_SHARD_SIZE", "DatasetError", "DatasetRequest", "Entry",
                "make_request"),
    "stats": ("dataset_stats", "plot_stats"),
}
"""Each submodule and the names this package exports from it. They are imported on first use (PEP 562):
the command's process reads an option's bound from :mod:`.request` without importing :mod:`.build`,
and with it the generation stack that only the workers' server needs."""
_HOME_OF = {name: module for module, names in _HOMES.items() for name in names}
__all__ = sorted(_HOME_OF)


def __getattr__(name: str):
    module = _HOME_OF.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})

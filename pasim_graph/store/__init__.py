"""The run product: a radar volume in the WMO FM-301 / CfRadial 2 layout, written to Zarr.

The root group holds the site and the run's provenance; ``sweep_0`` (``sweep_1``, ... for a
volume) holds the beams along ``azimuth`` with ``range``, as xradar models a sweep, so
``xarray.open_datatree(store, engine="zarr")`` opens it and xradar and Py-ART can use it.

The package, by what each module is about:

- :mod:`.format`: what makes a directory a store (its marker), how its arrays are encoded,
  the run's state (per-chunk done flags, completion), the beams' dimension;
- :mod:`.lock`: one writer per store, and who it is;
- :mod:`.directory`: taking a directory for a run, replacing or discarding a store's
  contents, never anything this program did not write;
- :mod:`.layout`: the volume laid out before any chunk runs, and arrays removed from it
  laid out again;
- :mod:`.writes`: a chunk written into its region, then flagged done;
- :mod:`.read`: a finished run read back, checked;
- :mod:`.check`: damage found in a written store (arrays gone, chunks failing their
  checksum, symbolic links planted);
- :mod:`.resume`: what must match for a store to be resumed, and which chunks to write again.

Everything the engine and the library use is imported from here.
"""

from ..scores import summarize as summarize  # re-exported: callers score a sweep from here
from .check import (
    ARRAYS,
    Damage,
    DamagedStoreError,
    MissingArraysError,
    NotAStoreError,
    array_list,
    arrays_on_disk,
    check_arrays,
    check_chunks,
    listed_arrays,
    missing_arrays,
    some,
    symbolic_links,
)
from .directory import (
    StoreExistsError,
    clear_store,
    discard_store,
    foreign_entries,
    open_store,
    replace_store,
    settle,
)
from .format import (
    COMPLETE,
    DONE,
    MARKER,
    beam_dimension,
    encoding,
    is_store,
    mark_complete,
    mark_incomplete,
    quiet_zarr_warnings,
    run_state,
)
from .layout import (
    RelayError,
    SweepLayout,
    create_root,
    create_sweep,
    create_volume,
    lay_out,
    relay_missing,
    split_volume,
    sweep_template,
    volume_sweeps,
)
from .lock import LOCK, StoreError, StoreLock, current_writer, describe_holder
from .read import (
    IncompleteStoreError,
    open_finished,
    open_sweep,
    open_volume,
    root_attrs,
    sweep_of,
)
from .resume import (
    ResumeError,
    damaged_chunks,
    file_digest,
    input_digests,
    input_paths,
    resume_mismatch,
    run_key,
)
from .writes import is_nan_fill, write_region, writes_raw

__all__ = [
    "ARRAYS",
    "COMPLETE",
    "DONE",
    "LOCK",
    "MARKER",
    "Damage",
    "DamagedStoreError",
    "IncompleteStoreError",
    "MissingArraysError",
    "NotAStoreError",
    "RelayError",
    "ResumeError",
    "StoreError",
    "StoreExistsError",
    "StoreLock",
    "SweepLayout",
    "array_list",
    "arrays_on_disk",
    "beam_dimension",
    "check_arrays",
    "check_chunks",
    "clear_store",
    "create_root",
    "create_sweep",
    "create_volume",
    "current_writer",
    "damaged_chunks",
    "describe_holder",
    "discard_store",
    "encoding",
    "file_digest",
    "foreign_entries",
    "input_digests",
    "input_paths",
    "is_nan_fill",
    "is_store",
    "lay_out",
    "listed_arrays",
    "mark_complete",
    "mark_incomplete",
    "missing_arrays",
    "open_finished",
    "open_store",
    "open_sweep",
    "open_volume",
    "quiet_zarr_warnings",
    "relay_missing",
    "replace_store",
    "resume_mismatch",
    "root_attrs",
    "run_key",
    "run_state",
    "settle",
    "some",
    "split_volume",
    "summarize",
    "sweep_of",
    "sweep_template",
    "symbolic_links",
    "volume_sweeps",
    "write_region",
    "writes_raw",
]

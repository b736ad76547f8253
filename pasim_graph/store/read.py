"""Reading a finished run back: its volume as an xarray DataTree, a sweep of it and its root
attributes, checked first (a run that did not finish, arrays gone, chunks damaged are refused,
naming them)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import xarray as xr

from ..fm301 import sweep_group, sweep_names
from .check import DamagedStoreError, NotAStoreError, check_arrays, check_chunks
from .format import COMPLETE, is_store, quiet_zarr_warnings, run_state
from .lock import current_writer, describe_holder


class IncompleteStoreError(RuntimeError):
    pass


def open_sweep(path: str | Path, index: int = 0) -> tuple[xr.Dataset, dict[str, Any]]:
    """A sweep of a finished run (``sweep_<index>``, the first by default) and its root
    attributes; :func:`open_finished` says what it refuses."""
    tree = open_finished(path)
    return sweep_of(tree, path, index), root_attrs(tree)


def root_attrs(tree: xr.DataTree) -> dict[str, Any]:
    """A volume's root attributes (the run's graph, seed, versions), by name."""
    return {str(k): v for k, v in tree.attrs.items()}


def open_finished(path: str | Path) -> xr.DataTree:
    """A finished run's whole volume, checked.

    Raises :class:`NotAStoreError` naming the path when it is missing, not a store, or a run
    that did not finish, :class:`MissingArraysError` naming the arrays its layout lists that
    are gone, and :class:`DamagedStoreError` naming each damaged array and chunk when its
    files were damaged after they were written (both kinds of it).
    """
    if not Path(path).exists():
        raise NotAStoreError(f"{path}: no such store")
    if is_store(path):
        check_arrays(path)
    state = run_state(path) if is_store(path) else None
    if state is not None and state[0].get(COMPLETE) == "true":
        damage = check_chunks(path)
        if damage:
            raise DamagedStoreError(path, damage)
    try:
        tree = open_volume(path)
    except IncompleteStoreError as exc:
        raise NotAStoreError(str(exc)) from None
    except (OSError, ValueError, KeyError) as exc:
        raise NotAStoreError(f"{path}: not a PASIM-graph store ({exc})") from None
    if sweep_group(0) not in tree.children:
        raise NotAStoreError(f"{path}: no sweep_0 group; is this a PASIM-graph store?")
    return tree


def sweep_of(tree: xr.DataTree, path: str | Path, index: int) -> xr.Dataset:
    """Sweep ``index`` of an opened volume; :class:`NotAStoreError` names the sweeps it holds."""
    group = sweep_group(index)
    if group not in tree.children:
        raise NotAStoreError(f"{path}: no sweep {index}; it holds {', '.join(sweep_names(tree))}")
    return tree[group].to_dataset()


def open_volume(path: str | Path) -> xr.DataTree:
    """Open a finished run's volume (refuses a run that was interrupted)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such store")
    state = run_state(path)
    if state is not None and state[0].get(COMPLETE) != "true":
        done = int(state[1].sum())
        writer = current_writer(path)
        if writer is not None:
            raise IncompleteStoreError(
                f"{path} is being written now ({done} of {state[1].size} chunks so far) by "
                f"{describe_holder(writer)}; wait for it to finish"
            )
        raise IncompleteStoreError(
            f"{path}: the run did not finish ({done} of {state[1].size} chunks written); "
            "complete it with `pasim run ... --resume`"
        )
    with quiet_zarr_warnings():
        return xr.open_datatree(path, engine="zarr")

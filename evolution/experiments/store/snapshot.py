"""Snapshot files: what an exact continuation of an online run needs, next to its database.

A checkpoint of an online run on an engine that restores exactly (MuJoCo) writes the state of
its world and loop to ``<database folder>/checkpoints/run<id>.b<births>.snapshot`` *before* the
checkpoint's transaction, and the checkpoint's ``engine_state`` references it
(:func:`reference`: file name, SHA-256, births). The file is written to a temporary name and
renamed, so a reader never sees half a file; once the checkpoint is committed, the run's older
snapshot files are deleted (:func:`prune`). A kill between the rename and the commit leaves a
newer file that no checkpoint references: the next commit point prunes it.

The format is a pickle of plain data only (dicts, lists, numbers, strings, NumPy arrays), read
back with an unpickler that refuses any other class: a damaged or foreign file is a
:class:`SnapshotError`, never code run. The file must lie inside the results folder (a symbolic
link is refused, not followed), and is read only as a regular file of at most
:data:`~evolution.experiments.store.results_folder.MAX_SNAPSHOT_BYTES`, checked before it is read
(:func:`~evolution.experiments.store.results_folder.read_file`).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import pickle
from pathlib import Path
from typing import Any

from evolution.experiments.loop.errors import SnapshotError, StoreError
from evolution.experiments.store.results_folder import MAX_SNAPSHOT_BYTES, inside, read_file

__all__ = ["FORMAT", "SnapshotError", "prune", "read", "reference", "snapshot_path", "write"]

FORMAT = 1
"""Version of the snapshot layout; a file of another version is not used (replay instead)."""

_ALLOWED = {
    ("builtins", "complex"), ("builtins", "set"), ("builtins", "frozenset"),
    ("numpy", "dtype"), ("numpy", "ndarray"),
    ("numpy.core.multiarray", "_reconstruct"), ("numpy._core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "scalar"), ("numpy._core.multiarray", "scalar"),
    ("numpy.core.numeric", "_frombuffer"), ("numpy._core.numeric", "_frombuffer"),
}


class _PlainUnpickler(pickle.Unpickler):
    """Unpickles plain data and NumPy arrays only."""

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) in _ALLOWED or (module.startswith("numpy") and name.endswith("DType")):
            return super().find_class(module, name)
        raise pickle.UnpicklingError(f"a snapshot holds only plain data, not {module}.{name}")


def snapshot_path(db_path: str | Path, run_id: int, births: int) -> Path:
    """Where the snapshot of run ``run_id`` at ``births`` births lives, beside the database.

    Raises:
        SnapshotError: that place leads outside the results folder (a symbolic link).
    """
    try:
        return inside(Path(db_path).parent, f"checkpoints/run{run_id}.b{births}.snapshot",
                      "snapshot file")
    except StoreError as error:
        raise SnapshotError(str(error)) from None


def write(path: Path, data: dict[str, Any]) -> str:
    """Write ``data`` atomically to ``path`` (a temporary file renamed); its SHA-256 (hex).

    Raises:
        OSError: the file cannot be written.
    """
    blob = pickle.dumps({"format": FORMAT, "data": data}, protocol=5)
    digest = hashlib.sha256(blob).hexdigest()
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        temporary.unlink(missing_ok=True)  # a link planted there is replaced, never followed
        with open(temporary, "xb") as f:
            f.write(blob)
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)
    return digest


def reference(path: Path, digest: str, births: int) -> dict[str, Any]:
    """What a checkpoint's ``engine_state`` holds to find and check a snapshot file."""
    return {"file": path.name, "sha256": digest, "births": births, "format": FORMAT}


def read(db_path: str | Path, run_id: int, ref: object, births: int) -> dict[str, Any]:
    """The data of the snapshot ``ref`` (a checkpoint's reference) of run ``run_id``.

    Raises:
        SnapshotError: a malformed reference, another run's or checkpoint's file, a missing
            file, a SHA-256 that does not match, another format, or unreadable contents.
    """
    if not isinstance(ref, dict) or not all(k in ref for k in ("file", "sha256", "births")):
        raise SnapshotError(f"malformed snapshot reference {ref!r}")
    expected = snapshot_path(db_path, run_id, births)
    if ref["file"] != expected.name or ref["births"] != births:
        raise SnapshotError(f"the checkpoint at {births} births references {ref['file']!r}, "
                            f"not {expected.name!r}")
    try:
        blob = read_file(expected.parent.parent, f"{expected.parent.name}/{expected.name}",
                         "snapshot file", MAX_SNAPSHOT_BYTES)
    except StoreError as e:  # missing, not a regular file, too large: replay instead
        raise SnapshotError(str(e)) from None
    if hashlib.sha256(blob).hexdigest() != ref["sha256"]:
        raise SnapshotError(f"{expected} does not match its checkpoint (SHA-256 differs)")
    try:
        content = _PlainUnpickler(io.BytesIO(blob)).load()
    except Exception as e:  # noqa: BLE001 (any unpickling failure means a damaged file)
        raise SnapshotError(f"{expected} is unreadable ({e})") from e
    if not isinstance(content, dict) or content.get("format") != FORMAT:
        raise SnapshotError(f"{expected} is not a format-{FORMAT} snapshot")
    data = content.get("data")
    if not isinstance(data, dict):
        raise SnapshotError(f"{expected} holds no snapshot data")
    return data


def prune(db_path: str | Path, run_id: int, keep: str | None) -> None:
    """Delete run ``run_id``'s snapshot files except ``keep`` (a file name), best effort."""
    try:
        folder = inside(Path(db_path).parent, "checkpoints", "snapshot folder")
    except StoreError:
        return  # a folder leading elsewhere: nothing of ours to delete there
    if not folder.is_dir():
        return
    for path in folder.glob(f"run{run_id}.b*.snapshot"):
        if path.name != keep:
            with contextlib.suppress(OSError):  # best effort: a leftover file only costs disk
                path.unlink()

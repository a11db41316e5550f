"""Files a results folder holds, and how they are read: inside it, regular, bounded, inert.

A results folder is something people share, so nothing in it may reach outside it, run code or
hang a command when it is opened. This module is the one home of that rule:

* every file the database refers to (a trained SB3 policy, an online snapshot) is found by
  :func:`inside`: a relative path without ``..`` whose parts are no symbolic links (a link is
  refused, never followed), resolved to a place inside the folder;
* every file a command reads from a folder (the database and SQLite's ``-wal``, ``-shm`` and
  ``-journal`` files beside it, snapshots, policies, a study's settings) is first checked by
  :func:`check_regular` or read by :func:`read_file`: a regular file (a FIFO, a device or a
  symbolic link in its place is refused: opening a FIFO would wait for a writer forever) no
  larger than its bound (:data:`MAX_DATABASE_BYTES`, :data:`MAX_SNAPSHOT_BYTES`,
  :data:`MAX_SETTINGS_BYTES`; a policy: :data:`evolution.learning.policy_file.MAX_BYTES`),
  checked before a byte is parsed;
* a folder a command writes into inside a results folder (``report/``) may hold no symbolic
  link (:func:`output_folder`): writing through one would reach outside;
* no name a folder stores is imported unless the user trusts it (:func:`check_task_code`), nor
  is a pickled policy loaded (:func:`refuse_pickled`).

Each refusal is a one-line :class:`~evolution.experiments.loop.errors.StoreError` naming the file
and the problem.

A learning record's ``policy`` column holds a :class:`PolicyReference` as JSON:
``{"file": "policies/run<r>_robot<id>.safetensors", "digest": ..., "sha256": ...}`` (the
parameters' digest and the file's SHA-256, :mod:`evolution.learning.policy_file`); databases
from before that format hold ``{"file": "policies/...pkl", "digest": ...}``, whose pickled
policies load only when the user trusts them (``trust_pickled``).
"""

from __future__ import annotations

import json
import os
import re
import stat
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import TYPE_CHECKING, Any, Protocol

from evolution.experiments.loop.errors import ConfigError, StoreError
from revolve_env.body.files import (
    FileTooLargeError,
    NotARegularFileError,
    file_kind,
    read_bounded,
)

if TYPE_CHECKING:
    from evolution.experiments.loop.config import ExperimentConfig
    from revolve_env.body.robot import Robot

__all__ = ["MAX_DATABASE_BYTES", "MAX_SETTINGS_BYTES", "MAX_SNAPSHOT_BYTES", "SQLITE_SIDECARS",
           "PolicyReference", "check_database", "check_regular", "check_task_code", "inside",
           "load_policy", "output_folder", "policy_path", "read_file", "read_settings",
           "refuse_pickled", "save_policy"]

_HEX = re.compile(r"[0-9a-f]{64}")

MAX_DATABASE_BYTES = 16 * 2**30
"""The largest results database (and SQLite file beside it) a command opens. Bytes.

A study of the paper's size is a few megabytes; a long online run stays well under a gigabyte.
"""

MAX_SNAPSHOT_BYTES = 512 * 2**20
"""The largest online snapshot file read (one world's state and its loop's: far less). Bytes."""

MAX_SETTINGS_BYTES = 2**20
"""The largest settings file read (a study's ``study.json``). Bytes."""

SQLITE_SIDECARS = ("-wal", "-shm", "-journal")
"""Suffixes of the files SQLite keeps beside a database, which it opens by itself."""

class _Queries(Protocol):
    """What :func:`refuse_pickled` needs of a store.

    A :class:`~evolution.experiments.store.database.Store` has it.
    """

    path: Path

    def query(self, sql: str, params: Sequence[Any] = ...) -> list[tuple[Any, ...]]: ...


def _not_regular(path: Path, what: str, kind: str) -> StoreError:
    return StoreError(f"the {what} {path} is {kind}, not a regular file; a results folder's "
                      "files are read only as regular files inside it")


def _too_large(path: Path, what: str, size: int | None, max_bytes: int) -> StoreError:
    """``size`` ``None``: the file grew past the bound while it was read."""
    if size is None:
        return StoreError(f"the {what} {path} is larger than the {max_bytes} bytes a {what} may "
                          "be; refused")
    return StoreError(f"the {what} {path} is {size} bytes, larger than the {max_bytes} bytes a "
                      f"{what} may be; refused unread")


def _check_stat(path: Path, what: str, st: os.stat_result, max_bytes: int) -> None:
    if not stat.S_ISREG(st.st_mode):
        raise _not_regular(path, what, file_kind(st.st_mode))
    if st.st_size > max_bytes:
        raise _too_large(path, what, st.st_size, max_bytes)


def check_regular(path: Path, what: str, max_bytes: int) -> None:
    """Refuse ``path`` unless it is a regular file (not a symbolic link) of at most ``max_bytes``.

    For files another library opens by itself (SQLite): the check is on the directory entry
    (``lstat``), before anything opens it.

    Raises:
        StoreError: missing, a symbolic link, a FIFO or other non-regular file, or too large
            (one line naming the file).
    """
    try:
        st = os.lstat(path)
    except OSError as error:
        raise StoreError(f"cannot read the {what} {path}: {error.strerror or error}") from None
    _check_stat(path, what, st, max_bytes)


def check_database(path: Path) -> None:
    """Refuse a results database, or a SQLite file beside it, that is not regular and bounded.

    SQLite opens ``<db>-wal``, ``<db>-shm`` and ``<db>-journal`` itself when they exist; a FIFO
    in the place of any of them would hang it, a symbolic link lead elsewhere.

    Raises:
        StoreError: as :func:`check_regular`, for the database or one of those files.
    """
    check_regular(path, "results database", MAX_DATABASE_BYTES)
    for suffix in SQLITE_SIDECARS:
        sidecar = Path(f"{path}{suffix}")
        if os.path.lexists(sidecar):
            check_regular(sidecar, "SQLite file", MAX_DATABASE_BYTES)


def read_file(folder: Path, relative: str, what: str, max_bytes: int) -> bytes:
    """The bytes of ``folder / relative``: a regular file inside it, at most ``max_bytes``.

    The file is read by :func:`revolve_env.body.files.read_bounded`, without following a
    symbolic link: opened without waiting (a FIFO opens at once and is then refused), its kind
    and size are checked on the open file before a byte is read, and no more than ``max_bytes``
    are read.

    Raises:
        StoreError: as :func:`inside`, or missing or unreadable, or not a regular file, or
            larger than ``max_bytes`` (one line naming the file).
    """
    path = inside(folder, relative, what)
    try:
        return read_bounded(path, max_bytes, follow_links=False)
    except NotARegularFileError as error:
        raise _not_regular(path, what, error.kind) from None
    except FileTooLargeError as error:
        raise _too_large(path, what, error.size, max_bytes) from None
    except OSError as error:
        raise StoreError(f"cannot read the {what} {path}: {error.strerror or error}") from None


def output_folder(folder: Path, relative: str) -> Path:
    """``folder / relative``, a folder that a command writes into inside a results folder.

    A received folder may already hold it (a report of its author's): writing through a
    symbolic link in it (``report/summary.md`` linked to a file of the user's, opened to append)
    would reach outside, so any link in it, or a non-folder in its place, is refused.

    Raises:
        StoreError: as :func:`inside`, or a symbolic link (or a non-folder) in its place or
            below it (one line naming it).
    """
    path = inside(folder, relative, "output folder")
    if not os.path.lexists(path):
        return path
    if not stat.S_ISDIR(os.lstat(path).st_mode):
        raise StoreError(f"the output folder {path} is {file_kind(os.lstat(path).st_mode)}, not "
                         "a folder; remove it or write elsewhere")
    for parent, dirs, files in os.walk(path):
        for name in (*dirs, *files):
            entry = Path(parent) / name
            if os.path.islink(entry):
                raise StoreError(f"the output folder {path} holds the symbolic link {entry}, "
                                 "through which writing could reach outside the results "
                                 "folder; remove it or write elsewhere")
    return path


def read_settings(folder: Path, relative: str) -> Any:
    """The JSON a settings file of the folder holds (a study's ``study.json``).

    Raises:
        StoreError: as :func:`read_file` (bound :data:`MAX_SETTINGS_BYTES`), or not UTF-8 JSON.
    """
    blob = read_file(folder, relative, "settings file", MAX_SETTINGS_BYTES)
    try:
        return json.loads(blob.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as error:
        raise StoreError(f"the settings file {folder / relative} is not JSON ({error})") from None


def check_task_code(db_path: Path, config: ExperimentConfig, trust: bool) -> None:
    """Refuse to import the module of a task class a stored configuration names, unless trusted.

    A results folder holds no code, but its ``[task]`` may name a class of the user's own by
    dotted path; running it imports that module from this machine's Python path, which runs the
    module's code (as unpickling would): only for a folder whose author the user trusts.

    Raises:
        StoreError: the task is a class of the user's own and ``trust`` is false (one line
            naming it and the way to allow it).
    """
    try:
        config.fitness_task(allow_import=trust)
    except ConfigError as error:
        if trust:
            raise
        raise StoreError(
            f"{db_path}: {error}; to run it, revolve imports the module it names from your "
            "Python path: pass --trust-task-code (Python: trust_task_code=True) for a results "
            "folder whose author you trust") from None


def inside(folder: Path, relative: str, what: str = "file") -> Path:
    """``folder / relative``, refused unless it stays inside ``folder``.

    Args:
        folder: The results folder.
        relative: A path relative to it, with ``/`` between its parts.
        what: What the path is, for the message.

    Raises:
        StoreError: an absolute path, a ``..`` part, a backslash or control character, a part
            that is a symbolic link (refused, not followed: it could lead outside the folder),
            or a path whose resolved place is outside ``folder``.
    """
    parts = PurePosixPath(relative).parts
    if (not relative or relative.startswith("/") or "\\" in relative or ".." in parts
            or not relative.isprintable()):
        raise StoreError(f"the {what} {relative!r} is not a path inside the results folder")
    path = folder / relative
    step = folder
    for part in parts:
        step = step / part
        if step.is_symlink():
            raise StoreError(f"the {what} {relative!r} goes through the symbolic link {step}, "
                             "which could lead outside the results folder; refused, not "
                             "followed")
    try:
        resolved = path.resolve()
        root = folder.resolve()
    except (OSError, RuntimeError) as error:  # a loop of symbolic links
        raise StoreError(f"the {what} {relative!r} cannot be resolved ({error})") from None
    if not resolved.is_relative_to(root):
        raise StoreError(f"the {what} {relative!r} leads outside the results folder (to "
                         f"{resolved})")
    return path


@dataclass(frozen=True, slots=True)
class PolicyReference:
    """Where a learning record's policy is and what it must be.

    Attributes:
        file: Path relative to the results folder.
        digest: SHA-256 of the policy's parameters (hexadecimal).
        sha256: SHA-256 of the file (hexadecimal); ``None`` in an older, pickled reference.
    """

    file: str
    digest: str
    sha256: str | None = None

    @classmethod
    def parse(cls, text: str) -> PolicyReference:
        """The reference stored as JSON ``text``.

        Raises:
            StoreError: not a JSON object with a text ``file`` and hexadecimal digests.
        """
        try:
            data: Any = json.loads(text)
        except (ValueError, RecursionError):
            data = None
        if not isinstance(data, dict):
            raise StoreError(f"malformed policy reference {text!r}")
        file, digest, sha256 = data.get("file"), data.get("digest"), data.get("sha256")
        if (not isinstance(file, str) or not isinstance(digest, str)
                or not (sha256 is None or (isinstance(sha256, str) and _HEX.fullmatch(sha256)))):
            raise StoreError(f"malformed policy reference {text!r}")
        return cls(file, digest, sha256)

    def to_json(self) -> str:
        """The stored form."""
        data = {"file": self.file, "digest": self.digest}
        if self.sha256 is not None:
            data["sha256"] = self.sha256
        return json.dumps(data, sort_keys=True)

    @property
    def pickled(self) -> bool:
        """Whether the file is an older pickled policy (which only loads when trusted)."""
        from evolution.learning.policy_file import PICKLED_SUFFIX

        return self.file.endswith(PICKLED_SUFFIX)

    def check(self, folder: Path) -> Path:
        """The policy file's path, refused unless it is inside ``folder``.

        Raises:
            StoreError: as :func:`inside`.
        """
        return inside(folder, self.file, "policy file")


def refuse_pickled(store: _Queries, run_ids: Collection[int], trust_pickled: bool) -> None:
    """Refuse, before anything runs, pickled policies that runs ``run_ids`` would load.

    Raises:
        StoreError: one of their learning records references an older pickled policy and
            ``trust_pickled`` is false (one line: the file, and what to do).
    """
    if trust_pickled:
        return
    from evolution.learning.policy_file import refused_pickle

    for run_id, text in store.query(
            "SELECT run_id, policy FROM learning WHERE policy IS NOT NULL ORDER BY run_id, "
            "robot_id"):
        ref = PolicyReference.parse(text)
        if run_id in run_ids and ref.pickled:
            raise StoreError(f"run {run_id}: "
                             + refused_pickle(str(store.path.parent / ref.file)))


def policy_path(run_id: int, robot_id: int) -> str:
    """Where a run's robot keeps its policy, relative to the results folder."""
    from evolution.learning.policy_file import SUFFIX

    return f"policies/run{run_id}_robot{robot_id}{SUFFIX}"


def save_policy(folder: Path, run_id: int, robot_id: int, policy: Any) -> str:
    """Write ``policy`` into the results folder; the learning record's reference (JSON).

    Raises:
        StoreError: the ``policies`` folder leads outside the results folder.
        OSError: the file cannot be written.
    """
    from evolution.learning.policy_file import save_policy as write

    relative = policy_path(run_id, robot_id)
    digest, sha256 = write(policy, inside(folder, relative, "policy file"))
    return PolicyReference(relative, digest, sha256).to_json()


def load_policy(folder: Path, run_id: int, robot: Robot, reference: str,
                trust_pickled: bool = False) -> Any:
    """The policy ``reference`` names in the results folder, checked against ``robot``.

    Raises:
        StoreError: one line naming the run and the file: a malformed reference, a file outside
            the folder, a missing, damaged or foreign file, or an older pickled policy without
            ``trust_pickled``.
    """
    from evolution.learning.policy_file import MAX_BYTES, PolicyFileError, policy_from_bytes

    try:
        ref = PolicyReference.parse(reference)
        name = str(ref.check(folder))
        # Refused before it is read: a pickled policy not trusted (policy_from_bytes says so).
        blob = b"" if ref.pickled and not trust_pickled else read_file(
            folder, ref.file, "policy file", MAX_BYTES)
        return policy_from_bytes(name, blob, robot, ref.digest, sha256=ref.sha256,
                                 trust_pickled=trust_pickled)
    except (StoreError, PolicyFileError) as error:
        raise StoreError(f"run {run_id}: {error}") from None

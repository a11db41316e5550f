"""Files a results folder holds beside its database, and how they are found: inside it only.

A results folder is something people share, so nothing in it may reach outside it or run code
when it is opened. Every file the database refers to (a trained SB3 policy, an online snapshot)
is found by :func:`inside`: a relative path without ``..``, resolved (symbolic links followed)
to a place inside the folder, or a one-line :class:`~evolution.experiments.store.StoreError`.

A learning record's ``policy`` column holds a :class:`PolicyReference` as JSON:
``{"file": "policies/run<r>_robot<id>.safetensors", "digest": ..., "sha256": ...}`` (the
parameters' digest and the file's SHA-256, :mod:`evolution.learning.policy_file`); databases
from before that format hold ``{"file": "policies/...pkl", "digest": ...}``, whose pickled
policies load only when the user trusts them (``trust_pickled``).
"""

from __future__ import annotations

import json
import re
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import Any

from evolution.experiments.errors import StoreError
from evolution.experiments.store import Store
from revolve_env.body.robot import Robot

__all__ = ["PolicyReference", "inside", "load_policy", "policy_path", "refuse_pickled",
           "save_policy"]

_HEX = re.compile(r"[0-9a-f]{64}")


def inside(folder: Path, relative: str, what: str = "file") -> Path:
    """``folder / relative``, refused unless it stays inside ``folder``.

    Args:
        folder: The results folder.
        relative: A path relative to it, with ``/`` between its parts.
        what: What the path is, for the message.

    Raises:
        StoreError: an absolute path, a ``..`` part, a backslash or control character, or a
            path whose resolved place (symbolic links followed) is outside ``folder``.
    """
    parts = PurePosixPath(relative).parts
    if (not relative or relative.startswith("/") or "\\" in relative or ".." in parts
            or not relative.isprintable()):
        raise StoreError(f"the {what} {relative!r} is not a path inside the results folder")
    path = folder / relative
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


def refuse_pickled(store: Store, run_ids: Collection[int], trust_pickled: bool) -> None:
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
    from evolution.learning.policy_file import PolicyFileError
    from evolution.learning.policy_file import load_policy as read

    try:
        ref = PolicyReference.parse(reference)
        path = ref.check(folder)
        return read(path, robot, ref.digest, sha256=ref.sha256, trust_pickled=trust_pickled)
    except (StoreError, PolicyFileError) as error:
        raise StoreError(f"run {run_id}: {error}") from None

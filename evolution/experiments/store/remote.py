"""Where a run keeps its results: its database and the files beside it, here or over Ray.

A run reads and writes its results through a :class:`RunStore`: its records (the
:class:`~evolution.experiments.store.database.Store`'s methods) and the files beside the database
(online snapshots, :mod:`~evolution.experiments.store.snapshot`; trained SB3 policies,
``<results>/policies/``). Where the run executes beside its database (in this process, or in
a local worker process) that is a :class:`LocalRunStore`; where it executes as a Ray task,
possibly on another machine, a :class:`RemoteStore`, every call of which goes to a
:class:`StoreHost` Ray actor that the driver starts on its own node (:func:`host_store`, used
by :meth:`~evolution.experiments.store.observer.RunJob.for_remote_worker`). The host alone opens the
SQLite file and writes the files. So a multi-node cluster needs no shared filesystem: workers
send their commit points (robots, fitness, transitions, checkpoints), snapshots and policies
to the driver's node and read what a resume needs from there.

The commit point stays one transaction: the host writes the batch and the checkpoint with
:meth:`Store.commit <evolution.experiments.store.database.Store.commit>` before the call
returns, so a run killed anywhere loses at most the work since its last commit, as locally.
"""

from __future__ import annotations

import pickle
from collections.abc import Iterator, Sequence
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any, Protocol

from evolution.experiments.loop.run import StoredRun
from evolution.experiments.store import results_folder, snapshot
from evolution.experiments.store.database import (
    Batch,
    Checkpoint,
    LearningRecord,
    RobotRecord,
    Store,
)
from revolve_env.body.robot import Robot

__all__ = ["LocalRunStore", "RemoteStore", "RunStore", "StoreHost", "host_store"]


class RunStore(StoredRun, Protocol):
    """What a run reads and writes: its records (see :class:`Store`) and files beside them.

    What a resume reads is the loop's :class:`~evolution.experiments.loop.run.StoredRun`; the
    store observer also writes.
    """

    def set_status(self, run_id: int, status: str) -> None:
        """Set a run's status (``pending``, ``running``, ``interrupted``, ``finished``)."""

    def commit(self, run_id: int, batch: Batch, checkpoint: Checkpoint) -> None:
        """Write one commit point atomically."""

    def checkpoint(self, run_id: int) -> Checkpoint | None:
        """The latest commit point of a run, ``None`` before the first."""

    def write_snapshot(self, run_id: int, births: int, data: dict[str, Any]) -> dict[str, Any]:
        """Write a snapshot file (:func:`snapshot.write`); the checkpoint's reference to it.

        Raises:
            OSError: the file cannot be written.
        """

    def prune_snapshots(self, run_id: int, keep: str | None) -> None:
        """Delete the run's snapshot files but ``keep`` (:func:`snapshot.prune`)."""

    def save_policy(self, run_id: int, robot_id: int, policy: Any) -> str:
        """Write an SB3 policy (reset first) before the commit that references it.

        Returns:
            The learning record's reference: JSON ``{"file": ..., "digest": ..., "sha256": ...}``.
        """

    def close(self) -> None:
        """Release the store (for a remote one: nothing; the driver owns the database)."""


class LocalRunStore:
    """A :class:`RunStore` on this machine: an open :class:`Store` and its results folder.

    Args:
        store: The open database; its folder holds the files.
    """

    def __init__(self, store: Store) -> None:
        self.store = store
        self.folder = store.path.parent

    @classmethod
    def open(cls, db_path: str | Path) -> LocalRunStore:
        """Open the database at ``db_path`` (as :meth:`Store.open`, raising its errors)."""
        return cls(Store.open(db_path))

    def set_status(self, run_id: int, status: str) -> None:
        """As :meth:`Store.set_status`."""
        self.store.set_status(run_id, status)

    def commit(self, run_id: int, batch: Batch, checkpoint: Checkpoint) -> None:
        """As :meth:`Store.commit`."""
        self.store.commit(run_id, batch, checkpoint)

    def checkpoint(self, run_id: int) -> Checkpoint | None:
        """As :meth:`Store.checkpoint`."""
        return self.store.checkpoint(run_id)

    def robots(self, run_id: int, ids: Sequence[int] | None = None) -> list[RobotRecord]:
        """As :meth:`Store.robots`."""
        return self.store.robots(run_id, ids)

    def learning(self, run_id: int, ids: Sequence[int] | None = None) -> list[LearningRecord]:
        """As :meth:`Store.learning`."""
        return self.store.learning(run_id, ids)

    def write_snapshot(self, run_id: int, births: int, data: dict[str, Any]) -> dict[str, Any]:
        """Write ``<results>/checkpoints/run<id>.b<births>.snapshot``; its reference."""
        path = snapshot.snapshot_path(self.store.path, run_id, births)
        return snapshot.reference(path, snapshot.write(path, data), births)

    def read_snapshot(self, run_id: int, ref: object, births: int) -> dict[str, Any]:
        """As :func:`snapshot.read` in the results folder."""
        return snapshot.read(self.store.path, run_id, ref, births)

    def prune_snapshots(self, run_id: int, keep: str | None) -> None:
        """As :func:`snapshot.prune` in the results folder."""
        snapshot.prune(self.store.path, run_id, keep)

    def save_policy(self, run_id: int, robot_id: int, policy: Any) -> str:
        """Write ``<results>/policies/run<r>_robot<id>.safetensors``; the record's reference."""
        return results_folder.save_policy(self.folder, run_id, robot_id, policy)

    def load_policy(self, run_id: int, robot: Robot, reference: str,
                    trust_pickled: bool = False) -> Any:
        """The policy file ``reference`` names inside the results folder, checked."""
        return results_folder.load_policy(self.folder, run_id, robot, reference, trust_pickled)

    def close(self) -> None:
        """Close the database."""
        self.store.close()


_HOSTED = frozenset({
    "set_status", "commit", "checkpoint", "robots", "learning", "write_snapshot",
    "read_snapshot", "prune_snapshots", "save_policy", "load_policy",
})
"""The :class:`RunStore` methods a :class:`StoreHost` serves."""


class StoreHost:
    """The driver-side end of a :class:`RemoteStore`: a Ray actor owning one results folder.

    Args:
        db_path: The database, on the node the actor runs on (the driver's).
    """

    def __init__(self, db_path: str) -> None:
        self._store = LocalRunStore.open(db_path)

    def call(self, request: bytes) -> bytes:
        """Serve one pickled ``(method, args)`` :class:`RunStore` call; its pickled result.

        Both ways are pickles, not Ray's own transfer of the objects: that gives zero-copy
        NumPy arrays, read-only, which would be pickled differently into a policy or snapshot
        file than on the worker, and a loaded policy could not run.
        """
        method, args = pickle.loads(request)  # noqa: S301 - from this experiment's own runs
        if method not in _HOSTED:
            raise AttributeError(f"a store host serves no {method!r}")
        return pickle.dumps(getattr(self._store, method)(*args), protocol=5)

    def close(self) -> None:
        """Close the database."""
        self._store.close()


class RemoteStore:
    """A :class:`RunStore` whose folder is on the driver's machine, behind a :class:`StoreHost`.

    Picklable (it holds the actor's handle), so it travels with the job to any node. Errors
    raised by the host (a :class:`~evolution.experiments.loop.errors.StoreError`, an ``OSError``, a
    :class:`~evolution.experiments.store.snapshot.SnapshotError`) are raised here as instances of
    the same type.
    """

    def __init__(self, host: Any) -> None:
        self._host = host

    def _call(self, method: str, *args: Any) -> Any:
        import ray

        # ray.get raises the host's own exception types (see StoreHost.call on the pickles).
        request = pickle.dumps((method, args), protocol=5)
        return pickle.loads(ray.get(self._host.call.remote(request)))  # noqa: S301

    def set_status(self, run_id: int, status: str) -> None:
        """Set a run's status in the driver's database."""
        self._call("set_status", run_id, status)

    def commit(self, run_id: int, batch: Batch, checkpoint: Checkpoint) -> None:
        """Write one commit point in the driver's database (one transaction there)."""
        self._call("commit", run_id, batch, checkpoint)

    def checkpoint(self, run_id: int) -> Checkpoint | None:
        """The run's latest commit point, from the driver's database."""
        result: Checkpoint | None = self._call("checkpoint", run_id)
        return result

    def robots(self, run_id: int, ids: Sequence[int] | None = None) -> list[RobotRecord]:
        """The run's robots, from the driver's database."""
        result: list[RobotRecord] = self._call("robots", run_id, ids)
        return result

    def learning(self, run_id: int, ids: Sequence[int] | None = None) -> list[LearningRecord]:
        """The run's learning records, from the driver's database."""
        result: list[LearningRecord] = self._call("learning", run_id, ids)
        return result

    def write_snapshot(self, run_id: int, births: int, data: dict[str, Any]) -> dict[str, Any]:
        """Write the snapshot file in the driver's results folder; its reference."""
        result: dict[str, Any] = self._call("write_snapshot", run_id, births, data)
        return result

    def read_snapshot(self, run_id: int, ref: object, births: int) -> dict[str, Any]:
        """A snapshot from the driver's results folder."""
        result: dict[str, Any] = self._call("read_snapshot", run_id, ref, births)
        return result

    def prune_snapshots(self, run_id: int, keep: str | None) -> None:
        """Delete the run's older snapshots in the driver's results folder."""
        self._call("prune_snapshots", run_id, keep)

    def save_policy(self, run_id: int, robot_id: int, policy: Any) -> str:
        """Write the policy in the driver's results folder; the learning record's reference.

        The policy here is reset as a local save resets it (it drives the robot next).
        """
        policy.reset()
        result: str = self._call("save_policy", run_id, robot_id, policy)
        return result

    def load_policy(self, run_id: int, robot: Robot, reference: str,
                    trust_pickled: bool = False) -> Any:
        """A policy from the driver's results folder, checked there."""
        return self._call("load_policy", run_id, robot, reference, trust_pickled)

    def close(self) -> None:
        """Nothing to release here: the driver closes the database (:func:`host_store`)."""


@contextmanager
def host_store(db_path: str) -> Iterator[RemoteStore]:
    """The :class:`StoreHost` of ``db_path`` on this node (started if need be); its handle.

    Must be called in the driver (Ray initialised). The actor needs no CPU of the cluster and
    is pinned to this node, whose filesystem holds the database. Runs of one database share
    one host (a named actor of this driver's namespace), which serves them one call at a time;
    it is closed and ended when the first of their contexts exits (all of a
    :meth:`~evolution.evaluation.RayEvaluator.run_jobs` exit together, after the runs).

    Raises:
        StoreError: the database cannot be opened (as :meth:`Store.open`).
    """
    import ray
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    # Opened here first (the driver's node is the actor's): a database that cannot be opened is
    # a StoreError now, not an actor that died in its constructor (RayActorError).
    Store.open(db_path).close()
    here = NodeAffinitySchedulingStrategy(ray.get_runtime_context().get_node_id(), soft=False)
    remote_class: Any = ray.remote(StoreHost)
    actor = remote_class.options(
        num_cpus=0, scheduling_strategy=here, get_if_exists=True,
        name=f"revolve-store:{Path(db_path).resolve()}").remote(db_path)
    store = RemoteStore(actor)
    try:
        store.checkpoint(-1)  # waits for the actor, raising its StoreError if it cannot open
        yield store
    finally:
        with suppress(Exception):  # the actor may already be gone (closed, a dead node)
            ray.get(actor.close.remote())
            ray.kill(actor)

"""A run's store on another machine: the driver owns the database, workers call it over Ray.

A run reads and writes its results through a :class:`RunStore`: the
:class:`~evolution.experiments.store.Store` itself where the run executes beside its database
(in this process, or in a local worker process), or a :class:`RemoteStore` where it executes as
a Ray task, possibly on another machine. Every call of a :class:`RemoteStore` goes to a
:class:`StoreHost` Ray actor that the driver starts on its own node
(:func:`host_store`, used by :meth:`~evolution.experiments.run.RunJob.for_remote_worker`) and
that alone opens the SQLite file. So a multi-node cluster needs no shared filesystem: workers
send their commit points (robots, fitness, transitions, checkpoints) to the driver's node and
read what a resume needs from there.

The commit point stays one transaction: the host writes the batch and the checkpoint with
:meth:`Store.commit <evolution.experiments.store.Store.commit>` before the call returns, so a
run killed anywhere loses at most the work since its last commit, as locally.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager, suppress
from typing import Any, Protocol

from evolution.experiments.store import Batch, Checkpoint, LearningRecord, RobotRecord, Store

__all__ = ["RemoteStore", "RunStore", "StoreHost", "host_store"]


class RunStore(Protocol):
    """What a run reads and writes in its experiment's database (see :class:`Store`)."""

    def set_status(self, run_id: int, status: str) -> None:
        """Set a run's status (``pending``, ``running``, ``interrupted``, ``finished``)."""

    def commit(self, run_id: int, batch: Batch, checkpoint: Checkpoint) -> None:
        """Write one commit point atomically, then clear ``batch``."""

    def checkpoint(self, run_id: int) -> Checkpoint | None:
        """The latest commit point of a run, ``None`` before the first."""

    def robots(self, run_id: int, ids: Sequence[int] | None = None) -> list[RobotRecord]:
        """The robots of a run in birth order (only ``ids`` if given)."""

    def learning(self, run_id: int, ids: Sequence[int] | None = None) -> list[LearningRecord]:
        """Infancy learning records of a run (only of ``ids`` if given), in birth order."""

    def close(self) -> None:
        """Release the store (for a remote one: nothing; the driver owns the database)."""


class StoreHost:
    """The driver-side end of a :class:`RemoteStore`: a Ray actor owning one open database.

    Args:
        db_path: The database, on the node the actor runs on (the driver's).
    """

    def __init__(self, db_path: str) -> None:
        self._store = Store.open(db_path)

    def set_status(self, run_id: int, status: str) -> None:
        """As :meth:`Store.set_status`."""
        self._store.set_status(run_id, status)

    def commit(self, run_id: int, batch: Batch, checkpoint: Checkpoint) -> None:
        """As :meth:`Store.commit` (of the worker's batch, received as a copy)."""
        self._store.commit(run_id, batch, checkpoint)

    def checkpoint(self, run_id: int) -> Checkpoint | None:
        """As :meth:`Store.checkpoint`."""
        return self._store.checkpoint(run_id)

    def robots(self, run_id: int, ids: Sequence[int] | None = None) -> list[RobotRecord]:
        """As :meth:`Store.robots`."""
        return self._store.robots(run_id, ids)

    def learning(self, run_id: int, ids: Sequence[int] | None = None) -> list[LearningRecord]:
        """As :meth:`Store.learning`."""
        return self._store.learning(run_id, ids)

    def close(self) -> None:
        """Close the database."""
        self._store.close()


class RemoteStore:
    """A :class:`RunStore` whose database is on the driver's machine, behind a :class:`StoreHost`.

    Picklable (it holds the actor's handle), so it travels with the job to any node. Errors
    raised by the host (a :class:`~evolution.experiments.store.StoreError`, say) are raised
    here as the same exception type.
    """

    def __init__(self, host: Any) -> None:
        self._host = host

    def _call(self, method: str, *args: Any) -> Any:
        import ray

        # ray.get raises the host's own exception type (StoreError, ...), wrapped by Ray.
        return ray.get(getattr(self._host, method).remote(*args))

    def set_status(self, run_id: int, status: str) -> None:
        """Set a run's status in the driver's database."""
        self._call("set_status", run_id, status)

    def commit(self, run_id: int, batch: Batch, checkpoint: Checkpoint) -> None:
        """Write one commit point in the driver's database (one transaction there).

        Then clear ``batch``, as :meth:`Store.commit` does.
        """
        self._call("commit", run_id, batch, checkpoint)
        batch.clear()

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

    def close(self) -> None:
        """Nothing to release here: the driver closes the database (:func:`host_store`)."""


@contextmanager
def host_store(db_path: str) -> Iterator[RemoteStore]:
    """Open ``db_path`` in a :class:`StoreHost` actor on this node; its remote handle.

    Must be called in the driver (Ray initialised). The actor needs no CPU of the cluster and
    is pinned to this node, whose filesystem holds the database; it is closed and ended when
    the context exits.

    Raises:
        StoreError: the database cannot be opened (as :meth:`Store.open`).
    """
    import ray
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    here = NodeAffinitySchedulingStrategy(ray.get_runtime_context().get_node_id(), soft=False)
    remote_class: Any = ray.remote(StoreHost)
    actor = remote_class.options(num_cpus=0, scheduling_strategy=here).remote(db_path)
    store = RemoteStore(actor)
    try:
        store.checkpoint(-1)  # waits for the actor, raising its StoreError if it cannot open
        yield store
    finally:
        with suppress(Exception):  # the actor may already be gone (a dead node, a shutdown)
            ray.get(actor.close.remote())
        ray.kill(actor)

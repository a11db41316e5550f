"""The results store as an observer of the loop, and one run of an experiment in its folder.

:class:`StoreObserver` writes a run to its results database as the loop steps: it resumes the
run from its last checkpoint when the loop starts, writes each step's records and checkpoint
in one transaction (with the snapshot file an exact online resume needs, and every learned
SB3 policy when its robot is born), and sets the run's status. So a killed run loses at most
the work since its last commit point. :func:`execute_run` is what :func:`evolution.run`,
``revolve run`` and ``revolve resume`` do for each run (a :class:`RunJob`, here or on a Ray
worker): the loop, this observer and a progress observer, to the end.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import Any

from evolution.evaluation import Evaluator
from evolution.experiments.loop.config import ExperimentConfig
from evolution.experiments.loop.evolve import Evolution, Observer, ProgressObserver, Status
from evolution.experiments.loop.run import (
    Member,
    OnlineWorld,
    ProgressEvent,
    RunSummary,
    Step,
    WorldFactory,
    run_seed,
    world_seed,
)
from evolution.experiments.store import snapshot
from evolution.experiments.store.remote import LocalRunStore, RunStore, host_store
from evolution.lifecycle import InfancyHook

__all__ = ["RunJob", "StoreObserver", "execute_run"]

_log = logging.getLogger(__name__)


class StoreObserver(Observer):
    """Writes one run of the loop to its results database (see the module doc).

    Args:
        store: The run's store (:class:`~evolution.experiments.store.remote.LocalRunStore`,
            or a remote one under Ray); the run must be registered in it.
        db_path: The database's path, for messages.
        trust_pickled_policies: A resumed run may load SB3 policies saved as pickles by older
            versions (unpickling can run code: only for a results folder whose author is
            trusted).
    """

    def __init__(self, store: RunStore, db_path: str = "the results database",
                 trust_pickled_policies: bool = False) -> None:
        self.store = store
        self.db_path = db_path
        self.trust_pickled_policies = trust_pickled_policies
        self.commits = 0

    def started(self, evolution: Evolution) -> None:
        """Mark the run running; continue it from its checkpoint, if it has one."""
        self.store.set_status(evolution.run_id, "running")
        checkpoint = self.store.checkpoint(evolution.run_id)
        if checkpoint is not None:
            evolution.resume_from(checkpoint, self.store, self.trust_pickled_policies)

    def born(self, evolution: Evolution, member: Member) -> None:
        """Write a learned policy now, before it drives the robot (saving resets it)."""
        if member.policy is not None and member.policy_ref is None:
            member.policy_ref = self.store.save_policy(evolution.run_id, member.robot_id,
                                                       member.policy)

    def stepped(self, evolution: Evolution, step: Step) -> None:
        """Write the step's records and checkpoint in one transaction (a replayed one: not)."""
        if step.replayed:
            return
        written = self.write_snapshot(evolution)
        checkpoint = step.checkpoint
        if written is not None:
            checkpoint = replace(checkpoint,
                                 engine_state={**checkpoint.engine_state, "snapshot": written})
        self.store.commit(evolution.run_id, step.records, checkpoint)
        if written is not None:  # the older snapshot files are not needed any more
            self.store.prune_snapshots(evolution.run_id, keep=str(written["file"]))
        self.commits += 1

    def stopped(self, evolution: Evolution, status: Status) -> None:
        """Set the run's status; a finished run needs no snapshot file any more."""
        if status == "finished":
            self.store.prune_snapshots(evolution.run_id, keep=None)
        self.store.set_status(evolution.run_id, status)

    def write_snapshot(self, evolution: Evolution) -> dict[str, Any] | None:
        """The loop's snapshot written beside the database; its reference (``None``: none)."""
        data = evolution.snapshot()
        if data is None:
            return None
        try:
            return self.store.write_snapshot(evolution.run_id, evolution.births, data)
        except OSError as e:
            # The results matter more than a fast resume: commit without a snapshot.
            path = snapshot.snapshot_path(self.db_path, evolution.run_id, evolution.births)
            _log.warning("run %d: cannot write the snapshot %s (%s); a resume from this "
                         "checkpoint will replay", evolution.run_id, path, e.strerror or e)
            return None


@dataclass(frozen=True, slots=True)
class RunJob:
    """Everything a worker needs to execute (or continue) one run.

    ``store``: where the run reads and writes its records; ``None``: it opens ``db_path``
    itself. A job sent to another machine carries a remote one (:meth:`for_remote_worker`).
    ``trust_pickled_policies``: a resumed run may load SB3 policies saved as pickles by older
    versions (unpickling can run code: only for a results folder whose author is trusted).
    """

    db_path: str
    run_id: int
    config: ExperimentConfig
    world_factory: WorldFactory | None = None
    infancy: InfancyHook | None = None
    stop_after_commits: int | None = None
    store: RunStore | None = None
    trust_pickled_policies: bool = False

    @contextmanager
    def for_remote_worker(self) -> Iterator[RunJob]:
        """This job for a Ray worker on any node: the database stays on this one.

        Call in the Ray driver; the copy's store is a
        :class:`~evolution.experiments.store.remote.RemoteStore` of this node's database,
        valid until the context exits.
        """
        with host_store(self.db_path) as store:
            yield replace(self, store=store)



def execute_run(job: RunJob, evaluator: Evaluator,
                emit: Callable[[ProgressEvent], None]) -> RunSummary:
    """Execute (or continue) one run to its end, writing to ``job.db_path``.

    The loop (:class:`~evolution.experiments.loop.evolve.Evolution`) with a :class:`StoreObserver`
    and a progress observer sending its events to ``emit``. The run writes through
    ``job.store`` when the job has one (a Ray worker: the driver's database,
    :mod:`~evolution.experiments.store.remote`), else it opens ``job.db_path``. A
    KeyboardInterrupt (or any error) stops the run after the last commit point; the run's
    status becomes ``interrupted`` and the exception propagates. ``job.stop_after_commits``
    stops it (``interrupted``) after that many commit points.
    """
    store: RunStore = job.store if job.store is not None else LocalRunStore.open(job.db_path)
    world: OnlineWorld | None = None
    try:
        if job.config.mode == "online" and job.world_factory is not None:
            world = job.world_factory(job.config, world_seed(run_seed(job.config.seed,
                                                                      job.run_id)))
        recorder = StoreObserver(store, job.db_path, job.trust_pickled_policies)
        with Evolution(job.config, run_id=job.run_id, evaluator=evaluator, world=world,
                       infancy=job.infancy,
                       observers=[recorder, ProgressObserver(emit)]) as evolution:
            evolution.start()
            limit = job.stop_after_commits
            while not evolution.done:
                evolution.step()
                if limit is not None and recorder.commits >= limit:
                    evolution.close()
                    return evolution.summary("interrupted")
            return evolution.summary("finished")
    except BaseException:
        # Best effort: the original error, re-raised below, matters more than a failed status
        # update (whatever its type: a closed or broken database).
        with contextlib.suppress(Exception):
            store.set_status(job.run_id, "interrupted")
        raise
    finally:
        if world is not None:
            world.close()
        store.close()

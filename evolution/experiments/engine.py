"""One evolution engine; the scenarios are configurations of it.

The modules of this package, bottom up: :mod:`~evolution.experiments.run` (a run's state and
records, shared by both engines), :mod:`~evolution.experiments.offline` and
:mod:`~evolution.experiments.online` (the two engines), this module (one run from start or
checkpoint to its end), :mod:`~evolution.experiments.api` (``run``/``resume`` of whole
experiments).

A run is a loop of *commit points*. Between two commit points the engine conceives robots
(two tournament parents, or at random), delivers them, lets them live (evaluated alone, offline,
or together in one world, online), selects survivors, and collects every record in a
:class:`~evolution.experiments.store.Batch`; at the commit point the batch and a checkpoint
are written in one transaction.

Offline (``mode = "offline"``)
    Generation 0 is ``population_size`` random robots. Each later generation conceives
    ``offspring_size`` children (the last one fewer, to stop at exactly ``births``), evaluates
    them in parallel (each alone at the origin, ``insertion`` + ``evaluation_time`` seconds), and
    keeps ``population_size`` of parents + children (fitness: the fittest; random: uniformly).
    The simulated clock advances by one evaluation per child, as if the robots were evaluated
    one after another as in the paper. A commit point is one generation. Resume reloads the
    population from the store and the generator's state from the checkpoint.

Online (``mode = "online"``)
    ``population_size`` random robots are born at time 0 at random free positions. Every
    ``conception_interval`` seconds of simulated time: robots that died in the world (blow-ups)
    are recorded; survivor selection applies the online rule to the *mature* robots (infants
    have no full fitness window yet; the population never drops below ``min_alive`` through
    selection and is culled when it reaches ``max_alive``); then one robot is conceived from two
    mature parents chosen by tournament on their current sliding-window fitness and born at a
    random free position within ``birth_radius`` of the origin. If blow-ups leave fewer than
    ``min_alive`` robots, extra robots are conceived at once. A commit point is every
    ``checkpoint_interval`` births.

    Resume of an online run continues from its last checkpoint where the physics engine can
    restore its state exactly (MuJoCo): each checkpoint but the last writes a snapshot file of
    the world (physics state, controllers, generator, fitness windows) and of the engine's
    population beside the database (``checkpoints/run<id>.b<births>.snapshot``, referenced
    with its SHA-256 from the checkpoint's ``engine_state``), and resume restores it; the cost
    is the work since the checkpoint. Elsewhere (pybullet, whose saved state does not continue
    exactly; a database from before snapshots; a missing or damaged file) resume is by
    **deterministic replay**: the engine re-runs the run from its start with the same seed,
    checking every replayed robot against the stored one and the generator's state against the
    checkpoint, and writes nothing until it has passed the last commit point. Either way the
    stored results are never touched and the resumed run is bit-identical to an uninterrupted
    one.

Evaluation seeds are :func:`~evolution.evaluation.evaluation_seed` (run seed, robot id), so
offline results do not depend on the number of workers.

Infancy learning (the Training Center, ``RunJob.infancy``)
    Every newborn goes to the Training Center right after delivery, before it enters a world:
    offline, the evaluator calls the hook in the worker before the robot's evaluation (so the
    fitness is that of the learned controller); online, the engine calls it before
    ``world.add``, and the learned controller drives the robot in the shared world. The Training
    Center is a *separate* simulation: the learner's simulated seconds are recorded
    (``learning.sim_seconds``) but do not advance the run's clock, and a robot still matures
    ``fertile_age`` seconds after its birth, as without learning. So learning changes what a
    robot does during its life, not how long the life stages last, and runs with and without
    learning compare at equal simulated time and births.

    The learner's generator is seeded from the robot's evaluation seed
    (:func:`~evolution.evaluation.pool.infancy_seed`), never from the run's generator, so a learner
    cannot change the run's other random choices. A hook that raises (a
    :class:`~evolution.learning.LearnerError`, or any error of a plain hook) keeps the inborn
    controller; the failure is recorded (kind ``"learner"``) and the run goes on.

    Inheritance: the ``robots`` table holds the inborn genome as conceived; a successful
    learning is recorded in the ``learning`` table (learned genome, the learner's inborn and
    learned fitness, evaluations, simulated seconds). With a Lamarckian
    :class:`~evolution.learning.TrainingCenter` (``center.lamarckian``) the genome the robot
    passes to its children is the learned one; otherwise (Darwinian, or a plain hook) it is
    the inborn one.

    A learner that trains a policy outside the genome (stable-baselines3; Darwinian only) gives
    the robot a policy instead of a network: the engine writes it to
    ``<results>/policies/run<r>_robot<id>.safetensors`` before the commit that references it (the
    learning record's ``policy`` column: file, its SHA-256 and the parameters' digest; the file
    loads without running code, :mod:`evolution.learning.policy_file`), and the policy drives the
    robot: its offline evaluation (same seed and window), or its online life as an
    agent-controlled robot of the shared world. An online run resumed by replay reloads the
    policies from their files (a missing, damaged or foreign file is a one-line
    :class:`~evolution.experiments.store.StoreError` naming it, before anything is written);
    a MuJoCo snapshot keeps the policies' references and network states.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable

from evolution.evaluation import Evaluator
from evolution.experiments.config import ExperimentConfig
from evolution.experiments.offline import OfflineRun
from evolution.experiments.online import OnlineRun
from evolution.experiments.online_world import PopulationWorld
from evolution.experiments.remote_store import LocalRunStore, RunStore
from evolution.experiments.run import (
    OnlineWorld,
    ProgressEvent,
    RunJob,
    RunState,
    RunSummary,
    StopRun,
    run_seed,
    world_seed,
)

__all__ = ["default_world", "execute_run"]


def execute_run(job: RunJob, evaluator: Evaluator,
                emit: Callable[[ProgressEvent], None]) -> RunSummary:
    """Execute (or continue) one run to its end, writing to ``job.db_path``.

    The run writes through ``job.store`` when the job has one (a Ray worker: the driver's
    database, :mod:`~evolution.experiments.remote_store`), else it opens ``job.db_path``.
    A KeyboardInterrupt (or any error) stops the run after the last commit point; the run's
    status becomes ``interrupted`` and the exception propagates.
    """
    store: RunStore = job.store if job.store is not None else LocalRunStore.open(job.db_path)
    run: RunState | None = None
    world: OnlineWorld | None = None
    try:
        store.set_status(job.run_id, "running")
        if job.config.mode == "offline":
            run = OfflineRun(job, store, emit, evaluator)
        else:
            factory = job.world_factory or default_world
            world = factory(job.config, world_seed(run_seed(job.config.seed, job.run_id)))
            run = OnlineRun(job, store, emit, world)
        try:
            run.run()
        except StopRun:
            store.set_status(job.run_id, "interrupted")
            return run.summary("interrupted")
        store.set_status(job.run_id, "finished")
        emit(run.event(finished=True))
        return run.summary("finished")
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


def default_world(config: ExperimentConfig, seed: int) -> OnlineWorld:
    """The population environment of :mod:`revolve_env.envs.population` as an online world."""
    return PopulationWorld(config, seed)

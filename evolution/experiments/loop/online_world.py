"""The online world of the loop over the PettingZoo population environment (issue 4).

Adapts :class:`revolve_env.envs.population.PopulationEnv` to
:class:`evolution.experiments.loop.run.OnlineWorld`: a robot enters under the engine's own robot id
(``add_robot(robot, robot_id=...)``: one id from the world to the store), driven by its own
brain, or ``controlled_by="agent"`` for a robot with a learned policy (an SB3 infancy: ``step``
gets ``policy.act(observe(robot))`` for each of them every control step); it leaves with
``remove_robot``. What the engine learns of its robots is their typed
:class:`~revolve_env.status.RobotStatus` (the task's fitness with its terms, core position,
maturity on the env's clock, the reason a robot was lost). Imported lazily: ``evolution``
itself never imports the physics.

It is a :class:`~evolution.experiments.loop.run.RestorableWorld`: :meth:`PopulationWorld.snapshot`
holds the env's whole state (:meth:`PopulationEnv.snapshot`); restoring it is exact on MuJoCo
(``exact_restore``), not on pybullet.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from evolution.experiments.loop.config import ExperimentConfig
from evolution.experiments.loop.run import Birth
from evolution.learning.config import policies_observe_hinges
from revolve_env.body.robot import Robot
from revolve_env.status import RobotStatus, agent_name

if TYPE_CHECKING:
    from revolve_env.envs.population import PopulationEnv

__all__ = ["PopulationWorld"]

_IDS = "robot_ids"
"""Marks a snapshot whose env robots carry the engine's robot ids (older ones counted their own
births, which differ from the engine's after a robot born dead: those are refused, and the
engine replays instead)."""


class PopulationWorld:
    """One population environment holding a run's whole population.

    Args:
        config: The experiment (timing, birth disc, robot limits).
        seed: Seeds the env's generator (birth positions and headings) and its noise generator
            (``config.evaluation``'s sensor and actuator noise); the loop spawns it from the
            run's seed sequence, independent of the loop's own generator.
    """

    def __init__(self, config: ExperimentConfig, seed: int) -> None:
        # Imported here: it loads the physics engine, which offline runs never need.
        from revolve_env.envs.population import PopulationEnv

        # The run's own robots only (no default initial robots); the loop never adds more
        # robots than ``config.births``. No trajectories: the loop reads none, and a robot's
        # whole-life trajectory grows with its age (an elite living 1000 births of 15 s held
        # 21 MB, and every snapshot file pickled it).
        self._env: PopulationEnv = PopulationEnv(
            max_births=max(config.births, 1), initial_robots=(), insertion_time=config.insertion,
            maturity_age=config.fertile_age, fitness_window=config.evaluation_time,
            birth_radius=config.birth_radius, birth_clearance=config.birth_clearance,
            limits=config.evolution.limits, engine=config.world.engine,
            conditions=config.evaluation, task=config.fitness_task(),
            terrain=config.world.terrain_spec,
            proprioception=policies_observe_hinges(config.learning), trajectory_length=0)
        self._seed = seed
        self._env.reset(seed=seed)
        self._policies: dict[int, Any] = {}  # robot id -> PolicyAgent of agent-controlled robots

    @property
    def time(self) -> float:
        """Simulated time. Seconds."""
        return float(self._env.time)

    def add(self, robot: Robot, robot_id: int, policy: Any = None) -> Birth:
        """Drop robot ``robot_id`` where the env's placement rule puts it.

        Its own network drives it, or ``policy`` (agent-controlled: the policy's action for the
        robot's observation every control step).
        """
        self._env.add_robot(robot, None, controlled_by="brain" if policy is None else "agent",
                            robot_id=robot_id)
        if policy is not None:
            self._policies[robot_id] = policy
        status = self._env.status(robot_id)
        x, y = status.birth_position
        return Birth(robot_id, (float(x), float(y)), bool(status.born_inside))

    def remove(self, robot_id: int) -> None:
        """Take a robot out of the world."""
        self._env.remove_robot(robot_id)
        self._policies.pop(robot_id, None)

    def advance_to(self, t: float) -> dict[int, RobotStatus]:
        """Simulate until time ``t``; the status of every robot alive before the call.

        A robot the world lost on the way (a blow-up) is reported with its death.
        """
        env = self._env
        before = env.robot_ids
        lost: dict[int, RobotStatus] = {}
        # Half a control period of tolerance: ticks land on whole control steps.
        period = env.config.control_period
        end = t - 0.5 * float(period)
        while self.time < end:
            if self._policies:
                # Deterministic policies on the current observations: a replay repeats them.
                actions = {agent_name(rid): policy.act(env.observe(rid))
                           for rid, policy in self._policies.items()}
                # advance: the step without PettingZoo's dicts (the loop reads statuses only)
                ended = env.advance(actions)
            else:  # brains only: the periods up to t at once (the same steps)
                steps = env.steps
                n = 1
                while float((steps + n) * period) < end:
                    n += 1
                ended = env.advance_periods(n)
            for rid, status in ended.items():
                if status.death is not None and rid not in lost:
                    lost[rid] = status
                    self._policies.pop(rid, None)
        return {rid: lost[rid] if rid in lost else env.status(rid) for rid in before}

    @property
    def exact_restore(self) -> bool:
        """Whether :meth:`restore` continues a :meth:`snapshot` bit for bit (MuJoCo: yes)."""
        return self._env.exact_restore

    def snapshot(self) -> dict[str, Any]:
        """The env's whole state, as plain data.

        Raises:
            NotImplementedError: the engine cannot restore its state exactly (pybullet).
        """
        return {"env": self._env.snapshot(), _IDS: True}

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Continue from a :meth:`snapshot`; on failure the world is as new (reset, empty).

        Raises:
            ValueError: the snapshot does not fit (``SnapshotMismatchError``), or it is from
                before the env's robots carried the engine's ids.
            NotImplementedError: the engine cannot restore its state exactly (pybullet).
        """
        try:
            if not snapshot.get(_IDS):
                raise ValueError("a world snapshot from before the env's robots carried the "
                                 "run's robot ids")
            self._env.restore(snapshot["env"])
        except BaseException:
            self._env.reset(seed=self._seed)
            raise
        self._policies = {}

    def drive(self, robot_id: int, policy: Any) -> None:
        """After :meth:`restore`: ``policy`` drives the agent-controlled robot ``robot_id``."""
        self._env.observe(robot_id)  # KeyError naming it if it is not alive
        self._policies[robot_id] = policy

    def close(self) -> None:
        """Release the physics."""
        self._env.close()

"""The online world of the loop over the PettingZoo population environment (issue 4).

Adapts :class:`revolve_env.envs.population.PopulationEnv` to
:class:`evolution.experiments.run.OnlineWorld`: robots are added with ``add_robot(robot, position,
controlled_by="brain")`` (their own brains drive them), or ``controlled_by="agent"`` for a robot
with a learned policy (an SB3 infancy: ``step`` gets ``policy.act(observe(agent))`` for each of
them every control step), removed
with ``remove_robot``, and the per-agent ``infos`` give the sliding-window fitness, the core
position and the reason a robot was removed (blow-up). Imported lazily: ``evolution`` itself
never imports the physics.

It is a :class:`~evolution.experiments.run.RestorableWorld`: :meth:`PopulationWorld.snapshot`
holds the env's whole state (:meth:`PopulationEnv.snapshot`) and the last infos the world
reported; restoring it is exact on MuJoCo (``exact_restore``), not on pybullet.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from evolution.experiments.config import ExperimentConfig
from evolution.experiments.run import AgentStatus, Birth
from revolve_env.body.robot import Robot

if TYPE_CHECKING:
    from revolve_env.envs.population import PopulationEnv

__all__ = ["PopulationWorld"]

# What advance_to reads from an info (a snapshot keeps only these).
_LAST_KEYS = ("position", "fitness", "fitness_v", "fitness_s", "blow_up", "death")


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
        # robots than ``config.births``.
        self._env: PopulationEnv = PopulationEnv(
            max_births=max(config.births, 1), initial_robots=(), insertion_time=config.insertion,
            maturity_age=config.fertile_age, fitness_window=config.evaluation_time,
            birth_radius=config.birth_radius, birth_clearance=config.birth_clearance,
            limits=config.evolution.limits, engine=config.world.engine,
            conditions=config.evaluation)
        self._seed = seed
        self._env.reset(seed=seed)
        self._last: dict[str, dict[str, Any]] = {}
        self._policies: dict[str, Any] = {}  # agent -> PolicyAgent of agent-controlled robots

    @property
    def time(self) -> float:
        """Simulated time. Seconds."""
        return float(self._env.time)

    def add(self, robot: Robot, policy: Any = None) -> Birth:
        """Drop a robot where the env's placement rule puts it.

        Its own network drives it, or ``policy`` (agent-controlled: the policy's action for the
        robot's observation every control step).
        """
        agent = self._env.add_robot(robot, None,
                                    controlled_by="brain" if policy is None else "agent")
        if policy is not None:
            self._policies[agent] = policy
        info = self._env.agent_info(agent)
        x, y = info["birth_position"]
        self._last[agent] = {"position": (x, y), "fitness": 0.0}
        return Birth(agent, (float(x), float(y)), bool(info["born_inside_disc"]))

    def remove(self, agent: str) -> None:
        """Take a robot out of the world."""
        self._env.remove_robot(agent)
        self._last.pop(agent, None)
        self._policies.pop(agent, None)

    def advance_to(self, t: float) -> dict[str, AgentStatus]:
        """Simulate until time ``t``; the status of every robot alive before the call."""
        before = set(self._env.agents)
        removed: dict[str, str] = {}
        # Half a control period of tolerance: ticks land on whole control steps.
        while self.time < t - 0.5 * float(self._env.config.control_period):
            # Deterministic policies on the current observations: a replay repeats the actions.
            actions = {agent: policy.act(self._env.observe(agent))
                       for agent, policy in self._policies.items()}
            _, _, terminations, truncations, infos = self._env.step(actions)
            for agent, info in infos.items():
                # A robot the loop removed before this call gets one last report; keeping
                # it would hold every dead robot's info for the rest of the run.
                if agent in before:
                    self._last[agent] = info
            for agent in before:
                if (terminations.get(agent) or truncations.get(agent)) and agent not in removed:
                    info = self._last.get(agent, {})
                    removed[agent] = str(info.get("blow_up") or info.get("death") or "removed")
        out: dict[str, AgentStatus] = {}
        for agent in before:
            info = self._last.get(agent, {})
            x, y = tuple(info.get("position", (0.0, 0.0)))[:2]
            out[agent] = AgentStatus(float(info.get("fitness", 0.0)), info.get("fitness_v"),
                                     info.get("fitness_s"), (float(x), float(y)),
                                     removed.get(agent))
            if agent in removed:
                self._last.pop(agent, None)
                self._policies.pop(agent, None)
        return out

    @property
    def exact_restore(self) -> bool:
        """Whether :meth:`restore` continues a :meth:`snapshot` bit for bit (MuJoCo: yes)."""
        return self._env.exact_restore

    def snapshot(self) -> dict[str, Any]:
        """The env's whole state and the last reported infos, as plain data.

        Raises:
            NotImplementedError: the engine cannot restore its state exactly (pybullet).
        """
        last = {agent: {k: info[k] for k in _LAST_KEYS if k in info}
                for agent, info in self._last.items()}
        return {"env": self._env.snapshot(), "last": last}

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Continue from a :meth:`snapshot`; on failure the world is as new (reset, empty).

        Raises:
            ValueError: the snapshot does not fit (``SnapshotMismatchError``).
            NotImplementedError: the engine cannot restore its state exactly (pybullet).
        """
        try:
            last = {str(agent): dict(info) for agent, info in snapshot["last"].items()}
            self._env.restore(snapshot["env"])
        except BaseException:
            self._env.reset(seed=self._seed)
            self._last = {}
            raise
        self._last = last
        self._policies = {}

    def drive(self, agent: str, policy: Any) -> None:
        """After :meth:`restore`: ``policy`` drives the agent-controlled robot ``agent`` again."""
        self._env.observe(agent)  # KeyError naming it if it is not alive
        self._policies[agent] = policy

    def close(self) -> None:
        """Release the physics."""
        self._env.close()

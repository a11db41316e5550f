"""The population env's snapshots as plain data: its robots' bookkeeping out and back in.

:meth:`revolve_env.envs.population.PopulationEnv.snapshot` writes, and ``restore`` reads, what is
here: one dict per robot (positions in metres, ages in control periods) and the reading of a
whole snapshot into a fresh world, refused with :class:`SnapshotMismatchError` when damaged.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.robot import Robot
from revolve_env.body.serialize import from_json, to_json
from revolve_env.brain import BatchController
from revolve_env.brain.spec import NetworkSpec
from revolve_env.envs.agent_spaces import Masks
from revolve_env.envs.members import Controller, Final, LifeClock, Member, sensor_bounds
from revolve_env.status import Death, robot_id
from revolve_env.world import World, WorldConfig
from revolve_env.world.backend import SnapshotMismatchError

__all__ = ["Restored", "member_restore", "member_snapshot", "read_snapshot"]


def member_snapshot(m: Member, state: Final, brain: BatchController | None,
                    with_robot: bool) -> dict[str, Any]:
    # Keyed by the agent name, the robot id's one spelling in snapshots of every version.
    """One robot's bookkeeping and its state (and its controller's; its body too ``with_robot``)."""
    out: dict[str, Any] = {
        "agent": m.agent, "controlled_by": m.controlled_by, "handle": m.handle,
        "birth_step": m.birth_step, "birth_position": list(m.birth_position),
        "born_inside": m.born_inside, "yaw": m.yaw, "radius": m.radius, "obs": state.obs,
        "position": state.position, "fitness": state.fitness,
        "terms": list(state.terms), "age_steps": state.age_steps,
        "trajectory": state.trajectory, "trajectory_capacity": state.trajectory_room,
        "blow_up": m.blow_up, "n_outputs": m.n_outputs, "padded": m.padded, "view": state.view,
        "brain": None,
    }
    if with_robot:
        out["robot"] = to_json(m.robot, indent=None)
    if brain is not None and m.brain is not None:
        out["brain"] = (brain.get_state(m.brain), brain.time(m.brain))
    return out


def member_restore(e: dict[str, Any], robot: Robot, brain: BatchController | None,
                   clock: LifeClock) -> Member:
    """A robot's bookkeeping back from :func:`member_snapshot` (its network added to ``brain``).

    Its per-step state is read into the env's arrays from the same entry
    (:meth:`~revolve_env.envs.living.Living.restore`); a dead robot's is its ``final`` here.
    """
    handle: int | None = None
    if e["brain"] is not None:
        assert brain is not None
        values, time = e["brain"]
        handle = brain.add(NetworkSpec.from_robot(robot))
        brain.set_state(handle, values, float(time))
    x, y = (float(c) for c in e["birth_position"])
    controlled_by: Controller = "brain" if e["controlled_by"] == "brain" else "agent"
    low, high = sensor_bounds(robot)
    birth_step = int(e["birth_step"])
    agent = str(e["agent"])
    member = Member(
        robot_id=robot_id(agent), agent=agent, robot=robot, controlled_by=controlled_by,
        handle=int(e["handle"]), brain=handle, birth_step=birth_step,
        birth_time=birth_step * clock.dt, birth_position=(x, y),
        born_inside=bool(e["born_inside"]),
        yaw=float(e["yaw"]), radius=float(e["radius"]), blow_up=e["blow_up"],
        n_outputs=int(e["n_outputs"]), padded=bool(e["padded"]), sensor_low=low,
        sensor_high=high,
    )
    trajectory = np.asarray(e["trajectory"], dtype=np.float64).reshape(-1, 3)
    member.final = Final(
        obs=np.array(e["obs"], dtype=np.float64), view=np.array(e["view"], dtype=np.float64),
        position=np.array(e["position"], dtype=np.float64).reshape(3),
        terms=tuple(float(x) for x in e["terms"]),  # type: ignore[arg-type]
        age_steps=int(e["age_steps"]), trajectory=trajectory,
        trajectory_room=max(int(e["trajectory_capacity"]), len(trajectory), 1),
        fitness=dict(e["fitness"]))
    return member


def _death(death: object) -> Death:
    if death not in ("removed", "blow_up"):
        raise ValueError(f"unknown death {death!r}")
    return "removed" if death == "removed" else "blow_up"


@dataclass
class Restored:
    """A population snapshot read back, in a fresh world, ready for the env to take over."""

    world: World
    brain: BatchController
    members: list[Member]
    rows: list[dict[str, Any]]  # the living members' entries (their per-step state)
    dead: list[tuple[Member, Death]]
    rng: np.random.Generator
    noise: np.random.Generator | None  # None: a snapshot from before the noise generator
    masks: dict[str, Masks]
    spaces: dict[str, tuple[NDArray[np.float64], NDArray[np.float64], int]]
    births: int
    steps: int
    uniform: list[str]
    born: bytes | None = None  # which agents were born (None: a snapshot from before it)


def read_snapshot(snapshot: dict[str, Any], config: WorldConfig, clock: LifeClock) -> Restored:
    """Rebuild a snapshot's world and robots (a damaged one: :class:`SnapshotMismatchError`).

    Raises:
        SnapshotMismatchError: the snapshot does not fit; nothing is left open then.
        NotImplementedError: the engine cannot restore its state exactly (pybullet).
    """
    world = World(config)
    try:
        world.restore(snapshot["world"])
        brain = BatchController(config.control_period)
        rows = list(snapshot["members"])
        members = [member_restore(e, world.robot(int(e["handle"])), brain, clock)
                   for e in rows]
        dead = [(member_restore(e, from_json(e["robot"]), None, clock), _death(death))
                for e, death in snapshot["dead"]]
        rng = np.random.Generator(np.random.PCG64())
        rng.bit_generator.state = snapshot["rng"]
        noise: np.random.Generator | None = None
        if snapshot.get("noise_rng") is not None:
            noise = np.random.Generator(np.random.PCG64())
            noise.bit_generator.state = snapshot["noise_rng"]
        masks = {str(a): (np.array(o, dtype=bool), np.array(act, dtype=bool))
                 for a, (o, act) in snapshot["masks"].items()}
        spaces_ = {str(a): (np.array(low, dtype=np.float64), np.array(high, dtype=np.float64),
                            int(n)) for a, (low, high, n) in snapshot["spaces"].items()}
        births, steps = int(snapshot["births"]), int(snapshot["steps"])
        uniform = [str(a) for a in snapshot["uniform"]]
        born = snapshot.get("born")
        if born is not None and not isinstance(born, bytes):
            raise TypeError(f"the snapshot's births are {type(born).__name__}, not bytes")
    except BaseException as e:
        world.close()
        if isinstance(e, (SnapshotMismatchError, NotImplementedError)):
            raise
        if isinstance(e, (KeyError, TypeError, ValueError, IndexError)):
            raise SnapshotMismatchError(f"damaged population snapshot: {e!r}") from e
        raise
    return Restored(world, brain, members, rows, dead, rng, noise, masks, spaces_, births, steps,
                    uniform, born)

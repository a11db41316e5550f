"""A long population episode keeps the state of its living robots only (issue 28, item 4).

After many births and deaths, every per-robot container of the env (spaces, masks, members,
per-step arrays, trajectories, fitness windows, brains, the world's and the engine's robots)
holds the living robots and, until the next step, the ones the last step reported dead.
"""

from __future__ import annotations

import pytest

from revolve_env.body.examples import gecko, snake
from revolve_env.envs.population import PopulationEnv
from revolve_env.status import agent_name


def _churn(env: PopulationEnv, step: int) -> None:
    """A birth every 2 steps, the oldest robot's death every 2 steps (offset): ~3 alive."""
    if step % 2 == 0 and env.births < env.max_births:
        env.add_robot(snake(2) if step % 4 else gecko())
    if step % 2 == 1 and len(env.robot_ids) > 2:
        env.remove_robot(env.robot_ids[0])


def engine_name(backend: object) -> str:
    return "mujoco" if type(backend).__name__ == "MujocoBackend" else "pybullet"


def _held(env: PopulationEnv) -> dict[str, set[str]]:
    """The agents every per-robot container of ``env`` holds."""
    roster, spaces = env._roster, env._spaces
    living, world = roster.living, env.world
    by_handle = {m.handle: m.agent for m in roster.members.values()}
    by_brain = {m.brain: m.agent for m in roster.members.values() if m.brain is not None}
    alive = [m.agent for m in roster.members.values()]
    backend = world.backend  # its robots, by its own keys
    engine = backend._robots if engine_name(backend) == "mujoco" else backend._bodies
    return {
        "observation spaces": set(spaces.obs_spaces), "action spaces": set(spaces.act_spaces),
        "masks": set(spaces.masks), "members": {agent_name(r) for r in roster.members},
        "rows": set(roster.agents), "arrays": {m.agent for m in living.members},
        "trajectories": set(roster.agents[:len(living.trajectories)]),
        "windows": set(roster.agents[:len(living.windows)]),
        "world": {by_handle.get(h, f"handle {h}") for h in world.handles},
        # as many robots as the living (their keys are the engine's own)
        "engine": set(alive) if len(engine) == len(alive) else {f"{len(engine)} robots"},
        "brains": {by_brain.get(h, f"brain {h}") for h in roster.brain.handles},  # type: ignore[union-attr]
    }


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_after_many_births_and_deaths_only_the_living_robots_are_held(engine: str) -> None:
    env = PopulationEnv(max_births=60, initial_robots=[snake(2)], lifecycle=_churn,
                        birth_radius=3.0, engine=engine, trajectory_length=30)
    env.reset(seed=0)
    for _ in range(100):
        *_, terminations, truncations, infos = env.step({})
        dead = {a for a, ended in terminations.items() if ended}
        alive = {agent_name(r) for r in env.robot_ids}
        for what, agents in _held(env).items():
            if what in ("observation spaces", "action spaces", "masks"):
                # the dead ones of this step's report stay until the next step starts
                assert agents == alive | dead, what
            else:
                assert agents == alive, what
        for agent in alive:
            assert len(infos[agent]["trajectory"]) <= 30
    assert env.births == 51 and len(env.robot_ids) <= 3  # 48 deaths went through
    gone = agent_name(0)
    with pytest.raises(KeyError, match=f"'{gone}' is dead"):
        env.observation_space(gone)
    with pytest.raises(KeyError, match=f"'{gone}' is dead"):
        env.action_mask(gone)
    env.close()


def test_a_snapshot_from_before_the_births_were_kept_restores_and_releases_its_dead() -> None:
    def make() -> PopulationEnv:
        return PopulationEnv(max_births=60, initial_robots=[snake(2)], lifecycle=_churn,
                             birth_radius=3.0, engine="mujoco")

    env = make()
    env.reset(seed=0)
    for _ in range(12):
        env.step({})
    snapshot = env.snapshot()
    # Older snapshots kept the masks of every robot born in the episode and no "born".
    old = dict(snapshot)
    del old["born"]
    masks = dict(old["masks"])
    some = next(iter(masks.values()))
    dead = [agent_name(r) for r in range(env.births) if r not in env.robot_ids]
    masks.update({a: some for a in dead})
    old["masks"] = masks
    again = make()
    again.reset(seed=1)
    again.restore(old)
    with pytest.raises(KeyError, match=f"'{dead[0]}' is dead"):
        again.observe(dead[0])
    for _ in range(3):
        expected, got = env.step({}), again.step({})
        assert got[4].keys() == expected[4].keys()
        for agent, info in expected[4].items():
            assert got[4][agent]["fitness"] == info["fitness"]
    assert not set(dead) & set(again._spaces.masks)  # released at the first step
    env.close()
    again.close()


@pytest.mark.parametrize("bad", [-1, 2.5, True])
def test_a_bad_trajectory_length_is_refused_by_name(bad: object) -> None:
    with pytest.raises(ValueError, match="trajectory_length must be an integer >= 0 or None"):
        PopulationEnv(trajectory_length=bad)  # type: ignore[arg-type]

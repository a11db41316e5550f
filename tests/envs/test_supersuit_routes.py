"""SuperSuit's routes over a population with births and deaths (docs/rl_routes.md).

SuperSuit's vec-env route (``pettingzoo_env_to_vec_env_v1`` + ``concat_vec_envs_v1``) needs the
same agents at every step; SuperSuit's own ``black_death_v3`` copies ``agents`` at ``reset`` and
fails at the first birth. The project's :class:`~revolve_env.envs.black_death.BlackDeath` gives
it fixed slots (tests/envs/test_black_death.py); here the whole route runs over it, with
SuperSuit's per-agent wrappers around it and stable-baselines3's PPO at the end.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

ss = pytest.importorskip("supersuit", reason="needs supersuit (the test extra)")
sb3 = pytest.importorskip("stable_baselines3", reason="needs stable-baselines3 (the test extra)")

from world_views import hinge_targets  # noqa: E402

from revolve_env.body.examples import gecko, snake, spider  # noqa: E402
from revolve_env.envs.black_death import BlackDeath  # noqa: E402
from revolve_env.envs.checks import BirthsAndDeaths  # noqa: E402
from revolve_env.envs.population import population_env  # noqa: E402

# Agent-driven robots; a newborn every 5 steps (up to max_births), the oldest removed every 7.
LIFE = BirthsAndDeaths(birth_every=5, death_every=7, newborns=((snake(3), "agent"),
                                                                (spider(), "agent")))


def _slots(slots: int | None = 3, **kwargs: Any) -> BlackDeath:
    args: dict[str, Any] = {"space_mode": "uniform", "max_births": 8, "birth_radius": 3.0,
                            "insertion_time": 0.05, "proprioception": True, "lifecycle": LIFE,
                            **kwargs}
    env = population_env(initial_robots=[{"robot": gecko(), "controlled_by": "agent"},
                                         {"robot": snake(2), "controlled_by": "agent"}], **args)
    return BlackDeath(env, slots=slots)


def _vec(par_env: Any) -> Any:
    return ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(par_env), 1, num_cpus=0,
                                 base_class="stable_baselines3")


def test_the_vec_env_route_runs_over_births_deaths_and_a_new_episode() -> None:
    vec = _vec(_slots(3))
    n_obs = vec.observation_space.shape[0]
    obs = vec.reset()
    assert obs.shape == (3, n_obs) and obs[:2].any(axis=1).all() and not obs[2].any()
    par = vec.venv.vec_envs[0].par_env  # SuperSuit's copy of our wrapper
    occupants: list[list[str | None]] = []
    ended_at: list[int] = []
    rng = np.random.default_rng(0)
    for k in range(1, 61):
        obs, rewards, dones, infos = vec.step(rng.uniform(-1, 1, (3, 10)).astype(np.float32))
        occupants.append([info.get("agent") for info in infos])
        for i, info in enumerate(infos):
            if info.get("agent") is None and not dones[i]:
                assert not obs[i].any() and rewards[i] == 0.0  # an empty slot is black
        if dones.all():
            ended_at.append(k)
            assert obs[:2].any(axis=1).all()  # SuperSuit reset: the initial robots again
    # Newborns took slots freed by deaths; robot_5, born in step 20 with every slot taken, was
    # not (it lived undriven); robot_7, the last birth allowed, was.
    seen = {a for row in occupants for a in row if a is not None}
    assert seen == {f"robot_{k}" for k in range(8)} - {"robot_5"}
    assert occupants[19] == ["robot_3", "robot_4", "robot_2"]
    assert occupants[4] == ["robot_0", "robot_1", "robot_2"]  # robot_2 born in step 5
    assert occupants[7] == [None, "robot_1", "robot_2"]  # robot_0 removed in step 7
    assert occupants[9][0] == "robot_3"  # born in step 10, into robot_0's freed slot
    # The births stop at max_births = 8 and the deaths go on: the population dies out, SuperSuit
    # resets it, and the slots fill again.
    assert ended_at == [56] and par.agents == par.possible_agents  # robot_7 removed in step 56
    vec.close()


def test_a_birth_between_steps_reaches_the_vec_env() -> None:
    vec = _vec(_slots(3, lifecycle=None))
    vec.reset()
    population = vec.venv.vec_envs[0].par_env.unwrapped
    population.add_robot(spider(), controlled_by="agent")
    obs, _, dones, infos = vec.step(np.zeros((3, 10), np.float32))
    assert [i["agent"] for i in infos] == ["robot_0", "robot_1", "robot_2"]
    assert obs[2].any() and not dones.any()
    vec.close()


def test_supersuits_own_wrappers_work_around_it() -> None:
    env = _slots(None)  # one slot per possible robot: robot_0 .. robot_7
    wrapped = ss.normalize_obs_v0(ss.clip_actions_v0(ss.pad_action_space_v0(
        ss.pad_observations_v0(env))))
    vec = _vec(wrapped)
    assert vec.num_envs == 8
    obs = vec.reset()
    assert obs.min() >= 0.0 and obs.max() <= 1.0  # normalize_obs_v0 maps the bounds to [0, 1]
    lived: set[int] = set()
    for _ in range(12):
        # clip_actions_v0: actions out of [-1, 1] are clipped before they reach the robots
        obs, rewards, _, infos = vec.step(np.full((8, 10), 5.0, np.float32))
        assert obs.min() >= 0.0 and obs.max() <= 1.0
        lived |= {i for i, info in enumerate(infos) if info.get("agent") is not None}
    assert lived == {0, 1, 2, 3}  # the initial two, and the births of steps 5 and 10
    world = vec.venv.vec_envs[0].par_env.unwrapped.world  # SuperSuit's copy of the env
    assert np.allclose(hinge_targets(world, world.handles[-1]), np.pi / 4)  # clipped to 1
    vec.close()


@pytest.mark.slow
def test_ppo_learns_over_a_changing_population() -> None:
    """A few hundred steps of stable-baselines3's PPO through the route, births and deaths in it."""
    vec = _vec(_slots(3))
    # No seed=: SB3 would call the vec env's seed(), which SuperSuit 3.11's ConcatVecEnv lacks.
    model = sb3.PPO("MlpPolicy", vec, n_steps=64, batch_size=96, n_epochs=2, device="cpu")
    before = [p.detach().clone() for p in model.policy.parameters()]
    model.learn(total_timesteps=384)
    assert model.num_timesteps == 384
    after = list(model.policy.parameters())
    assert any(not bool((a == b).all()) for a, b in zip(after, before, strict=True))
    vec.close()

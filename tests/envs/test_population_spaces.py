"""PopulationEnv within PettingZoo's contract under births and deaths: spaces for every possible
agent, uniform spaces with masks, births and deaths inside a step, bad actions."""

from __future__ import annotations

import numpy as np
import pytest

from revolve_env.body.examples import gecko, snake, spider
from revolve_env.envs.checks import (
    BirthsAndDeaths,
    check_population,
    check_population_determinism,
    population_with_births,
)
from revolve_env.envs.population import PopulationEnv, population_env


@pytest.mark.parametrize("kwargs", [{}, {"space_mode": "exact"}, {"proprioception": True}],
                         ids=["uniform", "exact", "uniform-proprioception"])
def test_conformance_with_births_every_10_and_deaths_every_15(kwargs: dict[str, object]) -> None:
    """PettingZoo's API and seed tests, determinism, parallel_to_aec and SuperSuit's wrappers."""
    check_population(lambda: population_with_births(**kwargs), num_cycles=60)


@pytest.mark.parametrize("mode", ["exact", "uniform"])
def test_every_possible_agent_has_spaces_born_or_not(mode: str) -> None:
    env = population_env(initial_robots=[snake(3)], max_births=5, space_mode=mode)
    before = [(env.observation_space(a), env.action_space(a)) for a in env.possible_agents]
    env.reset(seed=0)
    env.add_robot(gecko())
    env.remove_robot("robot_0")
    env.step({})
    for agent, (obs_space, act_space) in zip(env.possible_agents, before, strict=True):
        assert env.observation_space(agent) is obs_space  # born, dead or unborn: the same object
        assert env.action_space(agent) is act_space
    assert before[4][0].shape == (10,) and before[4][1].shape == (10,)  # Table 1's limits
    with pytest.raises(KeyError, match="unknown agent 'robot_5'"):
        env.action_space("robot_5")


def test_exact_mode_gives_the_body_sizes_unless_asked_before_birth() -> None:
    env = population_env(initial_robots=[snake(3)])
    pinned = env.action_space("robot_1")  # asked before robot_1 exists: its body is unknown
    env.reset(seed=0)
    assert env.action_space("robot_0").shape == (3,)  # born before asked: its own sizes
    env.add_robot(snake(2), controlled_by="agent")
    assert env.action_space("robot_1") is pinned and pinned.shape == (10,)
    np.testing.assert_array_equal(env.action_mask("robot_1"), np.arange(10) < 2)
    obs, *_ = env.step({"robot_1": np.r_[0.5, 0.5, np.zeros(8)].astype(np.float32)})
    assert obs["robot_1"].shape == (10,) and obs["robot_0"].shape == (6,)
    env.reset(seed=0)
    assert env.action_space("robot_1") is pinned  # uniform spaces last the env's lifetime


def test_uniform_padding_is_ignored_and_brains_do_not_move_a_bit() -> None:
    robots = [gecko(), {"robot": spider(), "controlled_by": "agent"}, snake(2)]

    def run(mode: str, padding: float) -> tuple[list[dict[str, float]], np.ndarray]:
        env = population_env(initial_robots=robots, space_mode=mode)
        env.reset(seed=4)
        rng = np.random.default_rng(0)
        rewards = []
        for _ in range(40):
            drive = rng.uniform(-1, 1, 8)
            action = drive if mode == "exact" else np.r_[drive, np.full(2, padding)]
            rewards.append(env.step({"robot_1": action.astype(np.float32)})[1])
        positions = np.array(list(env.positions().values()))
        env.close()
        return rewards, positions

    exact = run("exact", 0.0)
    for padding in (0.0, 1.0):
        uniform = run("uniform", padding)
        assert uniform[0] == exact[0]
        np.testing.assert_array_equal(uniform[1], exact[1])


def test_uniform_observations_masks_and_infos() -> None:
    env = population_env(initial_robots=[snake(3), gecko()], space_mode="uniform")
    obs, infos = env.reset(seed=0)
    for agent in env.agents:
        mask = env.observation_mask(agent)
        assert infos[agent]["obs_mask"] is mask and not mask.flags.writeable
        assert infos[agent]["act_mask"] is env.action_mask(agent)
        assert obs[agent].shape == (10,) and not obs[agent][~mask].any()  # padding is 0
        assert env.observation_space(agent).contains(obs[agent])
        np.testing.assert_array_equal(obs[agent], env.observe(agent))
    assert int(env.action_mask("robot_0").sum()) == 3
    with pytest.raises(KeyError, match="robot_2.*not been born"):
        env.action_mask("robot_2")
    env.remove_robot("robot_0")
    env.step({})
    assert int(env.action_mask("robot_0").sum()) == 3  # a dead agent's mask stays known


def test_the_five_dicts_on_the_step_of_a_birth_and_of_a_death() -> None:
    env = population_with_births(lifecycle=BirthsAndDeaths(birth_every=3, death_every=5),
                                 initial_robots=[{"robot": snake(3), "controlled_by": "agent"},
                                                 snake(2)])
    env.reset(seed=0)
    dt = env.config.control_period
    zeros = np.zeros(10, np.float32)
    for _ in range(2):
        env.step({"robot_0": zeros})
    obs, rewards, terms, truncs, infos = env.step({"robot_0": zeros})  # step 3: a birth
    assert set(obs) == {"robot_0", "robot_1", "robot_2"} == set(infos)
    assert infos["robot_2"]["age"] == pytest.approx(dt) and infos["robot_2"]["death"] is None
    assert (rewards["robot_2"], terms["robot_2"], truncs["robot_2"]) == (0.0, False, False)
    assert env.observation_space("robot_2").contains(obs["robot_2"])
    env.step({"robot_0": zeros})
    last = env.observe("robot_0")
    # Step 5 removes robot_0 (the oldest) after its action was checked: the action is dropped.
    obs, rewards, terms, truncs, infos = env.step({"robot_0": np.ones(10, np.float32)})
    assert (terms["robot_0"], truncs["robot_0"], rewards["robot_0"]) == (True, False, 0.0)
    assert infos["robot_0"]["death"] == "removed"
    np.testing.assert_array_equal(obs["robot_0"], last)
    assert "robot_0" not in env.agents
    obs, *_ = env.step({})
    assert "robot_0" not in obs  # reported once, then never again


def test_bad_actions_name_the_agent_and_change_nothing() -> None:
    env = population_env(initial_robots=[{"robot": snake(3), "controlled_by": "agent"}, gecko()],
                         space_mode="uniform", max_births=4)
    env.reset(seed=0)
    env.remove_robot("robot_1")
    env.step({})
    time, positions = env.time, env.positions()
    good = np.zeros(10, np.float32)
    with pytest.raises(KeyError, match="'robot_3' has not been born"):
        env.step({"robot_0": good, "robot_3": good})
    with pytest.raises(KeyError, match="'robot_1' is dead"):
        env.step({"robot_0": good, "robot_1": good})
    with pytest.raises(KeyError, match="unknown agent 'robot_9'"):
        env.step({"robot_9": good})
    with pytest.raises(ValueError, match=r"'robot_0' must have shape \(10,\) \(the uniform.*3 "
                                         r"entries.*got \(3,\)"):
        env.step({"robot_0": np.zeros(3, np.float32)})  # its exact shape is not its space's
    with pytest.raises(ValueError, match="'robot_0' contains NaN"):
        env.step({"robot_0": np.r_[0.0, 0.0, 0.0, np.nan, np.zeros(6)]})
    assert env.time == time and env.positions() == positions and env.agents == ["robot_0"]


def test_the_determinism_check_catches_an_unseeded_lifecycle() -> None:
    def unseeded(env: PopulationEnv, step: int) -> None:
        if step % 5 == 0:  # a birth position from fresh entropy, not from env.np_random
            jitter = float(np.random.default_rng().uniform(0.0, 0.5))
            env.add_robot(snake(2), (10.0 * step + jitter, 0.0))  # 10 m apart: never a clash

    with pytest.raises(AssertionError, match="differ between two envs"):
        check_population_determinism(lambda: population_with_births(lifecycle=unseeded), steps=20)


def test_limits_without_room_for_the_imu_are_refused() -> None:
    from revolve_env.body.validate import Limits

    with pytest.raises(ValueError, match="3 inputs leave no room for the core's 6 IMU values"):
        population_env(limits=Limits(max_inputs=3))

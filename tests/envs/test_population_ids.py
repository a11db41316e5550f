"""The population env's robots by id: the caller's ids, typed statuses equal to the infos, and
one clock of insertion and maturity."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from revolve_env import example
from revolve_env.envs.population import PopulationEnv
from revolve_env.envs.reports import status_info
from revolve_env.status import RobotStatus


def _env(**kwargs: Any) -> PopulationEnv:
    env = PopulationEnv(initial_robots=(), max_births=20, **kwargs)
    env.reset(seed=2)
    return env


def test_a_caller_gives_its_own_ids_which_never_repeat() -> None:
    env = _env()
    assert env.add_robot(example("spider")) == "robot_0"
    assert env.add_robot(example("gecko"), robot_id=4) == "robot_4"  # a gap: 1..3 never born
    assert env.add_robot(example("snake")) == "robot_5"  # then one more than the last
    assert env.robot_ids == [0, 4, 5] and env.agents == []  # agents change in step only
    env.step({})
    assert env.agents == ["robot_0", "robot_4", "robot_5"]
    for bad, message in ((5, "robot_id 5 is used or below the last one"),
                         (2, "the next free one is 6"), (20, "not below max_births=20"),
                         (True, "must be an integer")):
        with pytest.raises(ValueError, match=message):
            env.add_robot(example("snake"), robot_id=bad)
    assert env.robot_ids == [0, 4, 5] and env.births == 3  # nothing changed
    env.remove_robot(4)  # by id, or by name
    env.remove_robot("robot_0")
    with pytest.raises(KeyError, match="agent 'robot_4' is dead"):
        env.status(4)
    with pytest.raises(KeyError, match="'robot_3' has not been born"):
        env.observe(3)
    _, _, terminations, _, infos = env.step({})
    assert terminations == {"robot_4": True, "robot_0": True, "robot_5": False}
    assert [infos[a]["robot_id"] for a in ("robot_4", "robot_0", "robot_5")] == [4, 0, 5]
    env.close()


def _same(status: RobotStatus, info: dict[str, Any], masks: Any) -> bool:
    expected = status_info(status, masks)
    return all((np.array_equal(v, info[k]) if isinstance(v, np.ndarray) else v == info[k])
               for k, v in expected.items()) and set(expected) == set(info)


def test_the_infos_are_the_typed_statuses_under_pettingzoos_names() -> None:
    born = []

    def lifecycle(env: PopulationEnv, k: int) -> None:
        if k == 30:
            born.append(env.add_robot(example("snake"), robot_id=11))
        if k == 50:
            env.remove_robot(env.agents[0])

    env = PopulationEnv(initial_robots=[example("spider"), example("gecko")], max_births=20,
                        insertion_time=0.2, maturity_age=0.5, lifecycle=lifecycle)
    env.reset(seed=0)
    deaths = {}
    for _ in range(60):
        _, rewards, _, _, infos = env.step({})
        statuses = env.statuses
        assert [f"robot_{k}" for k in statuses] == list(infos)
        for k, status in statuses.items():
            info = infos[f"robot_{k}"]
            assert _same(status, info, (info["obs_mask"], info["act_mask"]))
            if status.death is not None:
                deaths[k] = status.death
        for k in env.robot_ids:  # a living robot's status now is the one the step reported
            info = infos[f"robot_{k}"]
            assert _same(env.status(k), info, (info["obs_mask"], info["act_mask"]))
    assert born == ["robot_11"] and deaths == {0: "removed"}
    env.close()


def test_insertion_and_maturity_are_counted_in_control_periods() -> None:
    env = PopulationEnv(initial_robots=[example("spider")], insertion_time=0.1,
                        maturity_age=0.25, control_period=0.05)
    env.reset(seed=0)
    assert (env.status(0).inserting, env.status(0).mature) == (True, False)
    seen = []
    for _ in range(6):
        env.step({})
        s = env.status(0)
        seen.append((s.age_steps, s.inserting, s.mature))
        assert s.age == pytest.approx(s.age_steps * 0.05)
    assert seen == [(1, True, False), (2, False, False), (3, False, False), (4, False, False),
                    (5, False, True), (6, False, True)]
    env.close()

"""PopulationEnv's five dicts and statuses, step by step, equal those of the code before the bulk
build (issue 28): the same keys in the same order, the same values of the same types, arrays the
caller's own.

The reference (``tests/population_dicts_reference.py``) is ``report_step`` and ``Living.statuses``
as they were on main (6d215cc), one robot status after the other; the env under test builds the
same dicts in bulk.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pytest
from population_dicts_reference import old_info, old_report, old_statuses

import revolve_env.envs.population as population_module
from revolve_env import _controller
from revolve_env.body.examples import gecko, snake, spider
from revolve_env.conditions import EvaluationConditions
from revolve_env.envs.population import PopulationEnv, population_env
from revolve_env.world import WorldConfig


def _same(a: Any, b: Any, where: str) -> None:
    """Equal values of the same type; arrays of the same dtype, shape, values and flags."""
    assert type(a) is type(b), f"{where}: {type(a).__name__} != {type(b).__name__}"
    if isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, where
        assert a.flags.writeable == b.flags.writeable, where
        np.testing.assert_array_equal(a, b, err_msg=where)
    elif isinstance(a, dict):
        assert list(a) == list(b), f"{where}: keys {list(a)} != {list(b)}"
        for key in a:
            _same(a[key], b[key], f"{where}[{key!r}]")
    elif isinstance(a, tuple):  # statuses (NamedTuples), positions, masks
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{where}[{i}]")
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"


def _lifecycle(env: PopulationEnv, k: int) -> None:
    """Births every 5 steps and a removal every 11, inside the step."""
    if k % 5 == 0:
        env.add_robot(snake(2) if k % 10 else gecko(), controlled_by="agent" if k % 3 else "brain")
    if k % 11 == 0 and len(env.robot_ids) > 2:
        env.remove_robot(env.robot_ids[0])


def _made(proprioception: bool, space_mode: str, trajectory_length: int | None = 5
          ) -> PopulationEnv:
    # 15 rad/s: the flailing learners blow up now and then; max_cycles truncates the rest.
    env = population_env(
        initial_robots=[spider(), {"robot": snake(3), "controlled_by": "agent"}, gecko()],
        world_config=replace(WorldConfig(), max_angular_speed=15.0, drop_height=0.0),
        max_births=40,
        conditions=EvaluationConditions(heading="random", sensor_noise=0.1, actuator_noise=0.1),
        insertion_time=0.1, maturity_age=0.3, trajectory_length=trajectory_length,
        max_cycles=60,
        lifecycle=_lifecycle, proprioception=proprioception, space_mode=space_mode)
    env.observation_space("robot_30")  # a future agent: uniform spaces, padded at its birth
    return env


@pytest.mark.parametrize(("proprioception", "space_mode", "trajectory_length"),
                         [(False, "exact", 5), (True, "exact", 5), (False, "uniform", 5),
                          (False, "exact", None)],
                         ids=["exact", "exact-proprioception", "uniform", "whole-trajectories"])
def test_step_gives_the_dicts_and_statuses_of_the_code_before(
        proprioception: bool, space_mode: str, trajectory_length: int | None,
        monkeypatch: pytest.MonkeyPatch) -> None:
    new, old = (_made(proprioception, space_mode, trajectory_length),
                _made(proprioception, space_mode, trajectory_length))
    reports = [new.reset(seed=5), old.reset(seed=5)]
    _same(reports[0], (dict(zip(old.agents, old._roster.living.views(), strict=True)),
                       {a: old_info(s, old._spaces.masks[a]) for a, s in
                        zip(old.agents, old_statuses(old._roster.living), strict=True)}),
          "reset")
    _same(new.statuses, old.statuses, "reset statuses")
    rng = np.random.default_rng(0)
    deaths: set[str] = set()
    kept: list[tuple[dict[str, Any], dict[str, Any]]] = []  # earlier observations, as given
    for k in range(1, 61):
        if k % 13 == 0 and len(new.robot_ids) > 1:  # a removal between two steps
            for env in (new, old):
                env.remove_robot(env.robot_ids[-1])
        actions = {a: rng.uniform(-1.0, 1.0, new.action_space(a).shape) for a in new.agents}
        got = new.step(actions)
        with monkeypatch.context() as patch:
            patch.setattr(population_module, "report_step", old_report)
            want = old.step(actions)
        _same(got, want, f"step {k}")
        _same(new.statuses, old.statuses, f"step {k} statuses")
        assert new.agents == old.agents
        for agent in new.agents:  # one robot's info (status_info) is the bulk one's
            _same(new.agent_info(agent), got[4][agent], f"step {k}: agent_info({agent!r})")
        deaths |= {info["death"] for info in got[4].values() if info["death"] is not None}
        # The observations are the caller's own: no later step writes into them.
        kept.append((got[0], {a: o.copy() for a, o in got[0].items()}))
        for given, copied in kept:
            _same(given, copied, f"step {k}: an earlier observation changed")
        # The arrays are views as NumPy's slicing makes them: of the same base, with its
        # strides (the compiled step_reports makes them without NumPy's indexing).
        for mine_, want_ in ((got[0], want[0]), *(
                ({a: i[key] for a, i in got[4].items()}, {a: i[key] for a, i in want[4].items()})
                for key in ("position", "trajectory"))):
            for agent, x in mine_.items():
                y = want_[agent]
                assert x.strides == y.strides and x.flags == y.flags, f"step {k}: {agent}"
                assert (x.base is None) == (y.base is None), f"step {k}: {agent}"
        mine = list(got[0].values())
        inside = [new._roster.living.view, new._roster.living.obs]
        for i, x in enumerate(mine):
            assert not any(np.shares_memory(x, y) for y in mine[i + 1:] + inside), f"step {k}"
    assert deaths == {"removed", "blow_up"}, deaths  # the scenario reached both deaths
    assert any(got[3].values()) and not new.agents  # max_cycles: the living truncated at 60
    for env in (new, old):
        env.close()


def test_step_reports_slices_as_numpy_does_and_refuses_bad_input() -> None:
    """The compiled call's views equal NumPy's slices (base, memory, strides, flags); bad input
    raises."""
    rng = np.random.default_rng(3)
    arena = rng.uniform(size=(40, 3))
    read = arena.view()
    read.flags.writeable = False
    view = rng.uniform(size=9)
    position = rng.uniform(size=(3, 3))
    ages = np.array([0, 7, 30])
    f, v, s, rewards = (rng.uniform(size=3) for _ in range(4))
    t_start, t_stop = np.array([0, 5, 12], dtype=np.intp), np.array([0, 9, 40], dtype=np.intp)
    v_start, v_stop = np.array([0, 2, 2], dtype=np.intp), np.array([2, 2, 9], dtype=np.intp)
    agents = ["robot_0", "robot_4", "robot_9"]
    templates = [{"robot_id": i, "age": None, "x": "kept", "inserting": None, "is_mature": None,
                  "fitness": None, "fitness_v": None, "fitness_s": None, "position": None,
                  "trajectory": None} for i in range(3)]
    keys = ("age", "inserting", "is_mature", "fitness", "fitness_v", "fitness_s", "position",
            "trajectory")

    def call(**change: Any) -> Any:
        args = dict(agents=agents, templates=templates, keys=keys, ages=ages, dt=1 / 60,
                    insertion_steps=7, maturity_steps=30, f=f, v=v, s=s, rewards=rewards,
                    position=position, trajectories=read, trajectory_starts=t_start,
                    trajectory_stops=t_stop, view=view, view_starts=v_start, view_stops=v_stop)
        return _controller.step_reports(**{**args, **change})

    obs, rew, infos, columns = call()
    want_obs = [view[a:b] for a, b in zip(v_start.tolist(), v_stop.tolist(), strict=True)]
    want_traj = [read[a:b] for a, b in zip(t_start.tolist(), t_stop.tolist(), strict=True)]
    want_columns = ((ages * (1 / 60)).tolist(), (ages < 7).tolist(), (ages >= 30).tolist(),
                    f.tolist(), v.tolist(), s.tolist(), list(position), want_traj,
                    ages.tolist())
    assert len(columns) == len(want_columns)
    for c, (got_column, want_column) in enumerate(zip(columns, want_columns, strict=True)):
        assert type(got_column) is list and len(got_column) == len(want_column)
        for row, (x, y) in enumerate(zip(got_column, want_column, strict=True)):
            _same(x, y, f"column {c}, row {row}")
    for got_arrays, want_arrays in ((list(obs.values()), want_obs), (columns[6], list(position)),
                                    (columns[7], want_traj)):
        for x, y in zip(got_arrays, want_arrays, strict=True):
            assert x.base is y.base and x.strides == y.strides and x.flags == y.flags
            # the same memory too (an empty slice at the array's start, as NumPy puts it)
            assert x.__array_interface__["data"] == y.__array_interface__["data"]
    assert list(obs) == list(rew) == list(infos) == agents
    _same(rew, dict(zip(agents, rewards.tolist(), strict=True)), "rewards")
    for row, (agent, info) in enumerate(infos.items()):
        want = {**templates[row], **dict(zip(keys, [c[row] for c in want_columns], strict=False))}
        _same(info, want, agent)
        assert info is not templates[row] and templates[row]["age"] is None  # a copy
    with pytest.raises(ValueError, match="outside"):
        call(trajectory_stops=np.array([0, 9, 41], dtype=np.intp))
    with pytest.raises(ValueError, match="outside"):
        call(view_starts=np.array([0, 3, 2], dtype=np.intp))
    with pytest.raises(TypeError, match="dtype"):
        call(ages=ages.astype(np.float64))
    with pytest.raises(ValueError, match="one entry per agent"):
        call(f=f[:2])
    with pytest.raises(ValueError, match="one entry per agent"):
        call(templates=templates[:2])
    with pytest.raises(TypeError, match="numpy array"):
        call(rewards=rewards.tolist())

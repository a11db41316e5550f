"""Gymnasium conventions of the single-robot env: defaults for ``gym.make``, robots by name or
file, and a registered ``max_episode_steps`` that never cuts an episode the env goes on with."""

from __future__ import annotations

import json
import warnings
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import revolve_env
from revolve_env.body.examples import EXAMPLES, gecko, resolve_robot, spider
from revolve_env.body.serialize import save, to_dict
from revolve_env.body.validate import Limits, RobotError
from revolve_env.registration import (
    DEFAULT_CONTROL_PERIOD,
    DEFAULT_MAX_EPISODE_STEPS,
    LOCOMOTION_ID,
    LOCOMOTION_V1_ID,
    episode_steps,
)
from revolve_env.world import WorldConfig

SHORT = {"insertion_time": 0.25, "evaluation_time": 0.5}


def test_make_without_a_robot_gives_the_spider_and_registers_the_episode_length() -> None:
    env = gym.make(LOCOMOTION_V1_ID)
    assert env.unwrapped.robot == spider()  # type: ignore[attr-defined]
    # Derived from the defaults: (3 s + 12 s) at the default world's 1/60 s per step.
    assert WorldConfig().control_period == DEFAULT_CONTROL_PERIOD == 1 / 60
    assert env.spec is not None and env.spec.max_episode_steps == DEFAULT_MAX_EPISODE_STEPS == 900
    assert gym.spec(LOCOMOTION_V1_ID).max_episode_steps == 900
    env.close()


def test_a_default_episode_ends_by_the_env_at_the_registered_limit() -> None:
    env = gym.make(LOCOMOTION_V1_ID, robot="gecko")
    env.reset(seed=0)
    zero = np.zeros(env.action_space.shape, dtype=np.float32)
    steps, info = 0, {}
    while True:
        _, _, terminated, truncated, info = env.step(zero)
        steps += 1
        if terminated or truncated:
            break
    assert steps == DEFAULT_MAX_EPISODE_STEPS and truncated
    assert info["time"] == pytest.approx(15.0) and info["fitness"] > 0  # evaluated 12 s
    env.close()


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_example_names_are_robots(name: str) -> None:
    env = gym.make(LOCOMOTION_V1_ID, robot=name, **SHORT)
    assert env.unwrapped.robot == EXAMPLES[name]()  # type: ignore[attr-defined]
    env.close()


def test_a_json_file_is_a_robot_and_a_file_wins_over_an_example_name(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "walker.json"
    save(gecko(), path)
    assert resolve_robot(path) == (gecko(), "walker")
    assert resolve_robot(str(path))[0] == gecko()
    env = gym.make(LOCOMOTION_V1_ID, robot=str(path), **SHORT)
    assert env.unwrapped.robot == gecko()  # type: ignore[attr-defined]
    env.close()
    # A file called "spider" in the working folder is what the user means (the CLI's rule).
    save(gecko(), tmp_path / "spider")
    monkeypatch.chdir(tmp_path)
    assert resolve_robot("spider") == (gecko(), "spider")


def test_unknown_names_and_missing_files_are_one_line_errors(tmp_path: Path) -> None:
    for bad in ("spidr", str(tmp_path / "missing.json"), tmp_path):
        with pytest.raises(ValueError, match="no such robot file") as error:
            gym.make(LOCOMOTION_V1_ID, robot=bad)
        message = str(error.value)
        assert "\n" not in message and "spider, gecko" in message, message
    with pytest.raises(TypeError, match="example name"):
        resolve_robot(3.5)  # type: ignore[arg-type]


def test_a_bad_robot_file_names_the_rule(tmp_path: Path) -> None:
    data = to_dict(spider())
    data["body"]["children"][0]["slot"] = 7  # a core has slots 0-3
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    with pytest.raises(RobotError):
        gym.make(LOCOMOTION_V1_ID, robot=path)
    with pytest.raises(RobotError, match="max_parts|parts"):  # limits apply to examples too
        resolve_robot("spider", Limits(max_parts=5))


def test_the_cli_and_the_envs_share_the_rule() -> None:
    from evolution.cli.robots import CliError, robot_file

    assert robot_file("spider") == resolve_robot("spider")
    with pytest.raises(CliError, match="no such robot file: nope.json"):
        robot_file("nope.json")


@pytest.mark.parametrize(("kwargs", "expected"), [
    ({"evaluation_time": 30.0}, "max_episode_steps=900 cuts the 1980-step episode short.*"
                                "max_episode_steps=1980"),
    ({"max_episode_steps": 400}, "max_episode_steps=400 cuts the 900-step episode"),
    ({"max_episode_steps": 100}, "within the 180-step insertion phase.*every return would be 0"),
    ({"insertion_time": 1.0, "max_episode_steps": 60}, "within the 60-step insertion phase"),
])
def test_a_time_limit_that_would_cut_the_episode_is_refused(
        kwargs: dict[str, float], expected: str) -> None:
    with pytest.raises(ValueError, match=expected) as error:
        gym.make(LOCOMOTION_V1_ID, **kwargs)
    assert "\n" not in str(error.value)


def test_time_limits_that_fit_and_no_limit_are_accepted() -> None:
    short = gym.make(LOCOMOTION_V1_ID, **SHORT)  # the env ends first
    assert short.spec is not None and short.spec.max_episode_steps == 900
    exact = gym.make(LOCOMOTION_V1_ID, evaluation_time=30.0, max_episode_steps=1980)
    unlimited = gym.make(LOCOMOTION_V1_ID, evaluation_time=30.0, max_episode_steps=-1)
    assert unlimited.spec is not None and unlimited.spec.max_episode_steps is None
    insertion, total = episode_steps(0.25, 0.5, 1 / 60)
    assert (insertion, total) == (15, 45)
    for env in (short, exact, unlimited):
        env.close()


def test_v0_is_kept_for_older_code_and_v1_is_current() -> None:
    assert gym.spec(LOCOMOTION_ID).kwargs == {}
    assert gym.spec(LOCOMOTION_V1_ID).kwargs == {"proprioception": True}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gym.make(LOCOMOTION_V1_ID, **SHORT).close()  # no "out of date" warning
    with pytest.warns(DeprecationWarning, match="out of date"):
        warnings.simplefilter("always")
        gym.make(LOCOMOTION_ID, **SHORT).close()
    assert revolve_env.LOCOMOTION_V1_ID == LOCOMOTION_V1_ID


def test_the_wrappers_shortcut_keeps_their_state_and_truncation() -> None:
    """gym.make's layers under the registration's wrapper: the same episode with and without
    the shortcut, the TimeLimit's count and its truncation (at the env's own end here: a limit
    before it is refused), the order enforcer as Gymnasium has them."""
    env = gym.make(LOCOMOTION_V1_ID, **SHORT)
    with pytest.raises(gym.error.ResetNeeded):
        env.step(env.action_space.sample())  # the order enforcer
    env.close()
    runs = []
    for shortcut in (True, False):
        env = gym.make(LOCOMOTION_V1_ID, max_episode_steps=105, insertion_time=0.25,
                       evaluation_time=1.5)
        if not shortcut:
            env._layers = None  # type: ignore[attr-defined]
        assert env._layers is not None or not shortcut  # type: ignore[attr-defined]
        env.reset(seed=0)
        steps, done = [], False
        while not done:
            out = env.step(np.full(env.action_space.shape, 0.5, dtype=np.float32))
            steps.append((out[0].tobytes(), out[1:4],
                          env.get_wrapper_attr("_elapsed_steps")))
            done = out[2] or out[3]
        runs.append((steps, env.get_wrapper_attr("_elapsed_steps")))
        env.close()
    assert runs[0] == runs[1]
    assert runs[0][1] == 105 and runs[0][0][-1][1][2] is True


def test_the_shortcut_falls_back_to_the_layers_where_gymnasiums_internals_differ(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A TimeLimit whose step keeps more state than the shortcut knows (a Gymnasium that
    differs): the check sees it, and every step goes through the layers as Gymnasium has them."""
    from gymnasium.wrappers import TimeLimit

    from revolve_env.registration import shortcut_holds

    assert shortcut_holds()  # this Gymnasium: the shortcut is taken (the test above)
    plain_step = TimeLimit.step

    def counting_step(self: Any, action: Any) -> Any:
        self.seen = getattr(self, "seen", 0) + 1
        return plain_step(self, action)

    monkeypatch.setattr(TimeLimit, "step", counting_step)
    assert not shortcut_holds()
    env = gym.make(LOCOMOTION_V1_ID, **SHORT)
    assert env._layers is None  # type: ignore[attr-defined]
    env.reset(seed=0)
    for _ in range(5):
        env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    assert env.get_wrapper_attr("seen") == 5 and env.get_wrapper_attr("_elapsed_steps") == 5
    env.close()
    monkeypatch.undo()
    assert shortcut_holds()  # checked again for the methods back as they were

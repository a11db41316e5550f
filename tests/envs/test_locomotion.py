"""revolve_env/Locomotion-v0: checkers on every example robot, determinism, reward = fitness
increase, truncation, brain control, blow-ups and bad input."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import revolve_env.envs  # noqa: F401  (registers the env)
from revolve_env.body.examples import EXAMPLES, spider
from revolve_env.body.robot import Node, PartType, Robot
from revolve_env.body.serialize import save
from revolve_env.body.validate import RobotError
from revolve_env.envs import LOCOMOTION_ID, LocomotionEnv
from revolve_env.envs.checks import _rollout, check_determinism, check_locomotion, registered_ids
from revolve_env.fitness import window_fitness
from revolve_env.world import WorldConfig

SHORT = {"insertion_time": 0.25, "evaluation_time": 0.5}


@pytest.mark.parametrize("env_id", registered_ids())
@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_checkers_pass_on_every_example_robot(name: str, env_id: str) -> None:
    """Gymnasium's and SB3's checkers, two-env determinism and pickling (library checks)."""
    check_locomotion(EXAMPLES[name](), env_id, **SHORT)


def test_the_package_registers_its_envs() -> None:
    assert LOCOMOTION_ID in registered_ids()


class _SeedIgnoringEnv(LocomotionEnv):
    """Draws its noise from fresh entropy whatever the seed: not reproducible."""

    def reset(self, *, seed=None, options=None):  # type: ignore[no-untyped-def, override]
        return super().reset(seed=None, options=options)


def test_the_determinism_check_catches_a_nondeterministic_env() -> None:
    flaky = "revolve_env_test/SeedIgnoring-v0"
    if flaky not in gym.registry:
        gym.register(id=flaky, entry_point=_SeedIgnoringEnv)
    with pytest.raises(AssertionError, match="differ"):
        check_determinism(flaky, robot=spider(), sensor_noise=0.05, steps=5, **SHORT)


def test_reset_with_the_same_seed_replays_exactly() -> None:
    env = gym.make(LOCOMOTION_ID, robot=spider(), sensor_noise=0.05, actuator_noise=0.1, **SHORT)
    a = _rollout(env, 7, 40)
    _rollout(env, 3, 10)  # something else in between
    b = _rollout(env, 7, 40)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    c = _rollout(env, 8, 40)
    assert not np.array_equal(a[0], c[0])  # the noise follows the seed
    env.close()


def test_return_is_the_fitness_and_episode_truncates_on_time() -> None:
    env = LocomotionEnv(spider(), insertion_time=0.5, evaluation_time=1.0, controller="brain")
    env.reset(seed=0)
    rewards, times, positions = [], [], []
    steps = 0
    while True:
        _, reward, terminated, truncated, info = env.step(np.zeros(8, dtype=np.float32))
        steps += 1
        rewards.append(reward)
        if info["evaluating"]:
            times.append(info["time"])
            positions.append((info["x_position"], info["y_position"]))
        assert not terminated
        if truncated:
            break
    assert steps == 90  # (0.5 + 1.0) s at 60 Hz
    assert rewards[:29] == [0.0] * 29  # nothing is scored while the robot settles
    assert sum(rewards) == pytest.approx(info["fitness"])
    assert info["fitness"] > 0.0
    # poses at 5 Hz (the default): every 12th control period from the end of insertion
    expected = window_fitness(times[::12], positions[::12], window=12.0)
    assert info["fitness"] == pytest.approx(expected.fitness)
    assert info["fitness"] == pytest.approx(info["fitness_v"] + 5 * info["fitness_s"])
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(8, dtype=np.float32))
    env.close()


def test_brain_controller_ignores_the_action_and_modulate_zero_equals_brain() -> None:
    def positions(controller: str) -> np.ndarray:
        env = LocomotionEnv(spider(), controller=controller, **SHORT)  # type: ignore[arg-type]
        env.reset(seed=0)
        rng = np.random.default_rng(0)
        out = []
        for _ in range(30):
            action = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
            _, _, _, _, info = env.step(action)
            out.append((info["x_position"], info["y_position"]))
        env.close()
        return np.array(out)

    brain = positions(controller="brain")
    env = LocomotionEnv(spider(), controller="brain", action="modulate", **SHORT)
    assert env.action_space.shape == (16,)
    env.reset(seed=0)
    modulated = []
    for _ in range(30):
        _, _, _, _, info = env.step(np.zeros(16, dtype=np.float32))
        modulated.append((info["x_position"], info["y_position"]))
    np.testing.assert_array_equal(np.array(modulated), brain)
    # a non-zero modulation changes the gait
    env.reset(seed=0)
    for _ in range(30):
        _, _, _, _, info = env.step(
            np.concatenate([np.full(8, -1.0), np.zeros(8)]).astype(np.float32)
        )
    # scale -1 silences the brain: the robot barely moves from where it landed
    assert abs(info["x_position"]) + abs(info["y_position"]) < 0.01
    env.close()
    agent = positions(controller="agent")
    assert not np.array_equal(agent, brain)
    brain_again = positions(controller="brain")
    np.testing.assert_array_equal(brain_again, brain)


def test_blow_up_terminates_with_zero_fitness_and_finite_observation() -> None:
    # A sanity speed limit lower than a walking spider's makes any motion count as a blow-up.
    env = LocomotionEnv(spider(), insertion_time=0.0, evaluation_time=2.0, controller="brain",
                        world_config=WorldConfig(max_linear_speed=0.05))
    env.reset(seed=0)
    for _ in range(120):
        obs, _, terminated, truncated, info = env.step(np.zeros(8, dtype=np.float32))
        if terminated:
            break
    assert terminated and not truncated
    assert "core speed" in info["blow_up"]
    assert info["fitness"] == 0.0
    assert np.all(np.isfinite(obs)) and env.observation_space.contains(obs)
    env.close()


def test_robot_from_json_path(tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "spider.json"
    save(spider(), path)
    env = gym.make(LOCOMOTION_ID, robot=str(path), **SHORT)
    assert env.action_space.shape == (8,)
    env.close()


def test_invalid_robot_is_rejected_before_any_physics() -> None:
    brick = Node(PartType.BRICK)
    # a core has slots 0-3 only
    bad = Robot(Node(PartType.CORE, children=((7, brick),)))
    with pytest.raises(RobotError):
        LocomotionEnv(bad)
    with pytest.raises(TypeError, match="a Robot, an example name or a path"):
        LocomotionEnv(42)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="modulate"):
        LocomotionEnv(spider(), controller="agent", action="modulate")
    with pytest.raises(ValueError, match="evaluation_time"):
        LocomotionEnv(spider(), evaluation_time=0.0)
    with pytest.raises(ValueError, match="whole multiple"):
        LocomotionEnv(spider(), control_period=0.01)
    with pytest.raises(ValueError, match="render_mode"):
        LocomotionEnv(spider(), render_mode="ascii")
    env = LocomotionEnv(spider(), **SHORT)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(3, dtype=np.float32))
    with pytest.raises(ValueError, match="NaN"):
        env.step(np.full(8, np.nan, dtype=np.float32))
    env.close()


def test_rgb_array_render_shows_the_robot() -> None:
    env = gym.make(LOCOMOTION_ID, robot=spider(), render_mode="rgb_array", **SHORT)
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert frame.std() > 5  # not a blank picture
    env.close()


def test_control_period_comes_from_world_config_unless_given() -> None:
    slow = WorldConfig(control_period=1 / 30)
    env = LocomotionEnv(spider(), world_config=slow, **SHORT)
    assert env.config.control_period == pytest.approx(1 / 30)  # not silently reset to 1/60
    assert env.metadata["render_fps"] == 30  # one frame per env step
    assert LocomotionEnv.metadata["render_fps"] == 60  # the class default is untouched
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.zeros(8, dtype=np.float32))
    assert info["time"] == pytest.approx(1 / 30)
    env.close()
    given = LocomotionEnv(spider(), world_config=slow, control_period=1 / 60, **SHORT)
    assert given.config.control_period == pytest.approx(1 / 60)
    assert given.config.max_linear_speed == slow.max_linear_speed

"""PopulationEnv: births and deaths, ids, spaces, placement, control, determinism, blow-ups."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from world_views import hinge_targets

from revolve_env.body.examples import gecko, snake, spider
from revolve_env.body.geometry import Assembly, PlacedBox, assemble, overlapping_boxes
from revolve_env.body.robot import Layer, Node, PartType, Robot
from revolve_env.body.validate import RobotError
from revolve_env.envs.population import PopulationEnv, footprint_radius, population_env
from revolve_env.world import WorldConfig


def small_env(**kwargs: object) -> PopulationEnv:
    """An env whose reset adds nothing (tests add their own robots)."""
    kwargs.setdefault("initial_robots", [])
    return population_env(**kwargs)


def test_default_reset_adds_the_example_robots() -> None:
    env = population_env()
    obs, infos = env.reset(seed=3)
    assert env.agents == [f"robot_{i}" for i in range(5)]
    assert set(obs) == set(infos) == set(env.agents)
    for agent in env.agents:
        assert env.observation_space(agent).contains(obs[agent])
        assert infos[agent]["age"] == 0.0 and infos[agent]["inserting"]
        assert math.hypot(*infos[agent]["position"][:2]) <= env.birth_radius + 1e-9
    assert env.world.body_count() == 1 + 5
    env.close()


def test_ids_are_never_reused_and_the_dead_stay_dead() -> None:
    env = small_env(max_births=4)
    env.reset(seed=0)
    a = env.add_robot(snake(2))
    b = env.add_robot(snake(2))
    env.remove_robot(a)
    c = env.add_robot(snake(2))
    assert (a, b, c) == ("robot_0", "robot_1", "robot_2")
    assert env.robot_ids == [1, 2] and env.agents == []  # agents change in step only
    with pytest.raises(KeyError, match="robot_0.*dead"):
        env.remove_robot(a)
    with pytest.raises(KeyError, match="robot_0.*dead"):
        env.step({a: np.zeros(2, np.float32)})
    with pytest.raises(KeyError, match="robot_3.*not been born"):
        env.remove_robot("robot_3")
    with pytest.raises(KeyError, match="unknown agent 'robot_99'"):
        env.remove_robot("robot_99")
    _, _, term, _, infos = env.step({})
    assert term == {b: False, c: False}  # robot_0 left before a step reported it: never an agent
    assert env.agents == [b, c]
    env.remove_robot(b)
    assert env.robot_ids == [2] and env.agents == [b, c]  # b leaves agents in the next step
    _, _, term, _, infos = env.step({b: np.zeros(2, np.float32)})  # its action is dropped
    assert term == {b: True, c: False} and infos[b]["death"] == "removed"
    assert env.agents == [c]
    _, _, term, _, _ = env.step({})
    assert set(term) == {c}  # reported once, then gone
    assert env.add_robot(snake(2)) == "robot_3"
    bodies = env.world.body_count()
    with pytest.raises(ValueError, match="max_births=4"):
        env.add_robot(snake(2))
    assert env.world.body_count() == bodies and env.robot_ids == [2, 3]
    assert set(env.agents) <= set(env.possible_agents)


def test_spaces_are_cached_per_agent_and_follow_the_body() -> None:
    env = small_env()
    env.reset(seed=0)
    a = env.add_robot(snake(3), controlled_by="agent")
    b = env.add_robot(gecko())
    assert env.observation_space(a) is env.observation_space(a)
    assert env.action_space(a) is env.action_space(a)
    assert env.action_space(a).shape == (3,)
    assert env.action_space(b).shape == (len(gecko().neurons_of(Layer.OUTPUT)),)
    space = env.action_space(a)
    env.step({})
    env.remove_robot(a)
    *_, infos = env.step({})
    assert infos[a]["death"] == "removed"
    assert env.action_space(a) is space  # a dead agent keeps its space while it is reported
    env.step({})
    with pytest.raises(KeyError, match="'robot_0' is dead"):  # then it is released
        env.action_space(a)
    # PettingZoo's contract: an agent not yet born has spaces too (uniform, its body is unknown).
    assert env.observation_space("robot_7") is env.observation_space("robot_7")
    with pytest.raises(KeyError, match="unknown agent 'robot_7000'"):
        env.observation_space("robot_7000")


def _posed_boxes(robot: Robot, xy: np.ndarray, yaw: float, part: int) -> list[PlacedBox]:
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    shift = np.array([xy[0], xy[1], 0.0])
    return [replace(b, center=rot @ b.center + shift, rotation=rot @ b.rotation, part=part)
            for b in assemble(robot).boxes]


def test_random_births_never_overlap_a_living_robot() -> None:
    env = small_env(birth_radius=0.9, max_placement_tries=500)
    env.reset(seed=11)
    robots = [spider(), gecko(), snake(4), spider(), gecko(), snake(3), spider(), gecko()]
    agents = [env.add_robot(r) for r in robots]
    boxes: list[PlacedBox] = []
    for k, agent in enumerate(agents):
        m = env._roster.member(agent, "test")
        assert math.hypot(*m.birth_position) <= 0.9 + 1e-9
        boxes += _posed_boxes(m.robot, np.asarray(m.birth_position), m.yaw, part=k)
    # Boxes of different robots (= different "parts" here) must not intersect.
    assert overlapping_boxes(Assembly(parts=(), boxes=tuple(boxes), bodies=())) == []
    # and the check has teeth: two robots at the same place do overlap
    twin = (_posed_boxes(robots[0], np.zeros(2), 0.0, 0)
            + _posed_boxes(robots[1], np.zeros(2), 0.0, 1))
    assert overlapping_boxes(Assembly(parts=(), boxes=tuple(twin), bodies=()))


def test_bad_births_change_nothing() -> None:
    env = small_env(birth_radius=0.3, max_placement_tries=20)
    env.reset(seed=0)
    a = env.add_robot(spider(), (0.0, 0.0))
    bodies, agents = env.world.body_count(), list(env.agents)
    with pytest.raises(ValueError, match="overlaps robot_0"):
        env.add_robot(gecko(), (0.1, 0.0))
    bad = Robot(Node(PartType.BRICK))
    with pytest.raises(ValueError, match="robot_1.*invalid robot.*root") as err:
        env.add_robot(bad, (5.0, 5.0))
    assert isinstance(err.value.__cause__, RobotError)
    with pytest.raises(ValueError, match="controlled_by"):
        env.add_robot(gecko(), (5.0, 5.0), controlled_by="human")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="finite"):
        env.add_robot(gecko(), (math.nan, 0.0))
    with pytest.raises(ValueError, match=r"position must be \(x, y\)"):
        env.add_robot(gecko(), (5.0, 5.0, 0.0))  # type: ignore[arg-type]
    draws = env.np_random.bit_generator.state
    with pytest.raises(ValueError, match="yaw must be finite"):
        env.add_robot(gecko(), yaw=math.inf)  # refused before a random position is drawn
    assert env.np_random.bit_generator.state == draws  # the seeded sequence of births is intact
    assert env.world.body_count() == bodies and env.agents == agents
    assert env.add_robot(gecko(), (5.0, 5.0)) == "robot_1"  # no id was consumed
    del a


def test_bad_actions_name_the_agent_and_change_nothing() -> None:
    env = small_env()
    env.reset(seed=0)
    a = env.add_robot(snake(2), (0.0, 0.0), controlled_by="agent")
    b = env.add_robot(gecko(), (1.0, 0.0))
    t = env.time
    with pytest.raises(ValueError, match=f"action for '{a}' must have shape \\(2,\\)"):
        env.step({a: np.zeros(3)})
    with pytest.raises(ValueError, match=f"action for '{b}' must have shape"):
        env.step({a: np.zeros(2), b: np.zeros(1)})
    with pytest.raises(ValueError, match=f"'{a}' contains NaN"):
        env.step({a: np.array([0.0, np.nan])})
    with pytest.raises(KeyError, match="robot_5"):
        env.step({a: np.zeros(2), "robot_5": np.zeros(2)})
    assert env.time == t
    assert all(i["age"] == 0.0 for i in (env.agent_info(a), env.agent_info(b)))


def test_a_removed_robot_leaves_no_body_behind() -> None:
    env = small_env()
    env.reset(seed=0)
    assert env.world.body_count() == 1  # the ground
    agents = [env.add_robot(r) for r in (spider(), gecko(), snake(3))]
    assert env.world.body_count() == 4
    env.step({})
    env.remove_robot(agents[1])
    assert env.world.body_count() == 3
    assert set(env.positions()) == {agents[0], agents[2]}
    env.step({})
    for agent in (agents[0], agents[2]):
        env.remove_robot(agent)
    assert env.world.body_count() == 1 and env.robot_ids == []
    _, _, term, _, _ = env.step({})
    assert term == {agents[0]: True, agents[2]: True} and env.agents == []


def test_brain_and_agent_robots_share_the_world() -> None:
    env = small_env()
    env.reset(seed=0)
    driven = env.add_robot(snake(2), (0.0, 0.0), controlled_by="agent")
    walker = env.add_robot(gecko(), (1.5, 0.0))
    rng = np.random.default_rng(0)
    target = np.array([0.5, -0.5], np.float32)
    for _ in range(60):
        # the brain robot's action is checked and ignored
        _, _, _, _, infos = env.step({driven: target,
                                            walker: rng.uniform(-1, 1, 6).astype(np.float32)})
    angles = env.world.joint_angles(env._roster.member(driven, "test").handle)
    np.testing.assert_allclose(angles, target * math.radians(45.0), atol=0.05)
    walker_angles = env.world.joint_angles(env._roster.member(walker, "test").handle)
    assert np.ptp(walker_angles) > 0.1  # its own gait moves it

    # Same births, other (ignored) actions for the brain robot: same motion.
    env2 = small_env()
    env2.reset(seed=0)
    env2.add_robot(snake(2), (0.0, 0.0), controlled_by="agent")
    env2.add_robot(gecko(), (1.5, 0.0))
    for _ in range(60):
        _, _, _, _, infos2 = env2.step({driven: target})
    np.testing.assert_array_equal(infos2[walker]["trajectory"], infos[walker]["trajectory"])


def test_age_insertion_maturity_fitness_and_reward() -> None:
    env = small_env(insertion_time=0.5, maturity_age=1.0, fitness_window=0.5)
    env.reset(seed=0)
    a = env.add_robot(gecko(), (0.0, 0.0))
    total = 0.0
    for step in range(1, 91):
        _, rewards, _, _, infos = env.step({})
        info = infos[a]
        total += rewards[a]
        assert info["age"] == pytest.approx(step / 60)
        assert info["inserting"] == (step < 30)
        assert info["is_mature"] == (step >= 60)
        if step < 30:
            assert rewards[a] == 0.0 and info["fitness"] == 0.0
    # rewards sum to the current fitness, which is v + 5 s over the last 0.5 s of poses: at 5 Hz
    # (the default) ages 30, 42, ..., 90, the window starting at the pose held at age 60 (54's)
    assert total == pytest.approx(info["fitness"])
    traj = info["trajectory"]
    assert traj.shape == (91, 3) and not traj.flags.writeable
    window = traj[[54, 66, 78, 90], :2]
    v = np.sum(np.linalg.norm(np.diff(window, axis=0), axis=1))
    s = np.linalg.norm(window[-1] - window[0])
    assert info["fitness"] == pytest.approx(v + 5 * s)
    assert info["fitness"] > 0.0


def _run(seed: int) -> list[tuple]:
    env = small_env()
    env.reset(seed=seed)
    out = []
    env.add_robot(gecko())
    env.add_robot(snake(3), controlled_by="agent")
    rng = np.random.default_rng(1)
    for k in range(45):
        if k == 10:
            env.add_robot(spider())
        if k == 20:
            env.remove_robot("robot_0")
        actions = {"robot_1": rng.uniform(-1, 1, 3)}
        obs, rew, term, _, infos = env.step(actions)
        out.append((obs, rew, term, {a: (i["position"], i["fitness"]) for a, i in infos.items()}))
    env.close()
    return out


def test_same_seed_and_same_births_and_deaths_give_the_same_run() -> None:
    a, b = _run(5), _run(5)
    for (oa, ra, ta, ia), (ob, rb, tb, ib) in zip(a, b, strict=True):
        assert oa.keys() == ob.keys() and ta == tb and ra == rb
        for agent in oa:
            np.testing.assert_array_equal(oa[agent], ob[agent])
            np.testing.assert_array_equal(ia[agent][0], ib[agent][0])
    c = _run(6)  # other seed: other birth places
    assert not np.array_equal(a[0][3]["robot_0"][0], c[0][3]["robot_0"][0])


def test_blow_up_removes_the_robot_with_a_reason() -> None:
    # Hinges faster than 5 rad/s count as a blow-up: the flailing robot blows up, the still one
    # does not.
    env = small_env(world_config=WorldConfig(max_angular_speed=5.0, drop_height=0.0))
    env.reset(seed=0)
    still = env.add_robot(snake(2), (0.0, 0.0), controlled_by="agent")
    wild = env.add_robot(snake(2), (1.0, 0.0), controlled_by="agent")
    sign = 1.0
    for _ in range(30):
        sign = -sign
        obs, _, term, _, infos = env.step({still: np.zeros(2), wild: np.full(2, sign)})
        if term[wild]:
            break
    assert term == {still: False, wild: True}
    assert infos[wild]["death"] == "blow_up" and "exceeds 5.0 rad/s" in infos[wild]["blow_up"]
    assert np.all(obs[wild] == 0.0)
    assert env.agents == [still] and env.world.body_count() == 2
    _, _, term, _, _ = env.step({still: np.zeros(2)})
    assert term == {still: False}
    with pytest.raises(KeyError, match="dead"):
        env.step({wild: np.zeros(2)})


def test_max_cycles_truncates_everyone_and_ends_the_episode() -> None:
    env = small_env(max_cycles=3)
    env.reset(seed=0)
    a = env.add_robot(snake(2))
    for _ in range(2):
        _, _, term, trunc, _ = env.step({})
        assert trunc == {a: False}
    _, _, term, trunc, _ = env.step({})
    assert trunc == {a: True} and term == {a: False} and env.agents == []
    with pytest.raises(RuntimeError, match=r"max_cycles=3 .*reset\(\)"):
        env.step({})
    env.reset(seed=0)  # a new episode runs its max_cycles steps again
    assert env.step({})[3] == {a: False for a in env.agents}


def test_max_steps_is_the_deprecated_name_of_max_cycles() -> None:
    with pytest.warns(DeprecationWarning, match="max_cycles"):
        env = small_env(max_steps=4)
    assert env.max_cycles == 4
    with pytest.raises(ValueError, match="give one"):
        small_env(max_steps=4, max_cycles=5)
    with pytest.raises(ValueError, match="max_cycles must be an integer >= 1"):
        small_env(max_cycles=0)


def test_a_crowded_birth_disc_places_the_newborn_outside_it() -> None:
    """A birth never fails for lack of room: the nearest free spot outside the disc is used,
    clear of every robot, and the info says so."""
    env = small_env(birth_radius=0.3, max_placement_tries=20)
    env.reset(seed=0)
    first = env.add_robot(spider(), (0.0, 0.0))
    second = env.add_robot(spider())
    _, _, _, _, infos = env.step({})
    assert infos[first]["born_inside_disc"] and not infos[second]["born_inside_disc"]
    x, y = infos[second]["birth_position"]
    assert math.hypot(x, y) > 0.3
    assert math.hypot(x, y) >= 2 * footprint_radius(spider()) + env.birth_clearance - 1e-9
    env.close()


def test_footprint_radius_covers_the_robot() -> None:
    for robot in (spider(), gecko(), snake(5)):
        lower, upper = assemble(robot).bounds()
        r = footprint_radius(robot)
        corners = [(x, y) for x in (lower[0], upper[0]) for y in (lower[1], upper[1])]
        assert max(math.hypot(*c) for c in corners) == pytest.approx(r)


def test_observations_stay_in_their_spaces() -> None:
    from revolve_env.body.examples import sensor_crawler

    env = small_env()
    env.reset(seed=0)
    agents = [env.add_robot(r) for r in (sensor_crawler(), gecko(), snake(3))]
    for _ in range(40):
        obs, _, _, _, _ = env.step({})
        for a in agents:
            assert env.observation_space(a).contains(obs[a]), (a, obs[a])


def test_brains_keep_their_own_network_when_another_brain_robot_dies() -> None:
    from revolve_env.body.examples import sensor_crawler
    from revolve_env.brain import ReferenceBatchController

    env = small_env()
    env.reset(seed=0)
    first = env.add_robot(snake(3), (0.0, 0.0))
    second = env.add_robot(sensor_crawler(), (2.0, 0.0))
    third = env.add_robot(gecko(), (-2.0, 0.0))
    dt = env.config.control_period
    reference = ReferenceBatchController(dt)
    reference.add(sensor_crawler())
    out = np.zeros(reference.n_outputs)
    inputs = env.observe(second)  # the brain's first input: the birth observation
    for k in range(30):
        if k == 10:
            env.remove_robot(first)  # shifts every later robot's slice in the batch arrays
        reference.step(inputs, out)
        obs, _, _, _, _ = env.step({})
        world_targets = hinge_targets(env.world, env._roster.member(second, "test").handle)
        np.testing.assert_allclose(world_targets, np.clip(out, -1, 1) * math.radians(45.0),
                                   atol=1e-9)
        inputs = obs[second]
    assert third in env.agents


def test_observe_gives_a_newborn_its_first_observation_and_refuses_the_dead() -> None:
    env = small_env(max_births=3)
    env.reset(seed=0)
    old = env.add_robot(gecko(), (0.0, 0.0), controlled_by="agent")
    env.step({})
    newborn = env.add_robot(spider(), (1.5, 0.0), controlled_by="agent")  # mid-episode
    first = env.observe(newborn)
    # The sensors read in the world at its birth, inside its own space, never seen by step yet.
    handle = env._roster.member(newborn, "test").handle
    np.testing.assert_array_equal(first, env.world.read_sensors(handle))
    assert env.observation_space(newborn).contains(first)
    first[:] = 123.0  # a copy: changing it changes nothing in the env
    assert not np.any(env.observe(newborn) == 123.0)
    obs, *_ = env.step({old: np.ones(6, np.float32), newborn: np.zeros(8, np.float32)})
    for agent in (old, newborn):
        np.testing.assert_array_equal(env.observe(agent), obs[agent])  # the latest one
    env.remove_robot(old)
    with pytest.raises(KeyError, match="observe: agent 'robot_0' is dead"):
        env.observe(old)
    with pytest.raises(KeyError, match="robot_2.*not been born"):
        env.observe("robot_2")
    with pytest.raises(KeyError, match="unknown agent 'robot_7'"):
        env.observe("robot_7")
    env.close()


def test_world_config_control_period_is_kept_unless_overridden() -> None:
    """A world_config's own control period is not silently replaced by a default."""
    from revolve_env.world import WorldConfig

    slow = WorldConfig(control_period=1.0 / 30.0)
    env = PopulationEnv(world_config=slow, initial_robots=())
    assert env.config.control_period == slow.control_period
    env2 = PopulationEnv(world_config=slow, control_period=1.0 / 60.0, initial_robots=())
    assert env2.config.control_period == 1.0 / 60.0


@pytest.mark.parametrize("max_angular_speed", [200.0, 10.0])  # 10 rad/s: all blow up at once
def test_advance_is_step_without_the_dicts(max_angular_speed: float) -> None:
    # Brains and a learner with noise, a removal, blow-ups: advance() leaves the env exactly
    # where step() does and gives the statuses of the lives that ended.
    from revolve_env.conditions import EvaluationConditions

    def made() -> PopulationEnv:
        config = replace(WorldConfig(), max_angular_speed=max_angular_speed)
        env = small_env(conditions=EvaluationConditions(heading="random", sensor_noise=0.1,
                                                        actuator_noise=0.2),
                        world_config=config)
        env.reset(seed=4)
        env.add_robot(spider())
        env.add_robot(gecko(), controlled_by="agent")
        env.add_robot(snake(3))
        return env

    stepped, advanced = made(), made()
    ended: dict[int, str | None] = {}
    for k in range(40):
        if k == 10 and stepped.robot_ids:
            for env in (stepped, advanced):
                env.remove_robot(env.robot_ids[0])
        actions = {f"robot_{r}": np.full(stepped.action_space(f"robot_{r}").shape, 0.5)
                   for r in stepped.robot_ids if stepped.status(r).controlled_by == "agent"}
        stepped.step(actions)
        got = advanced.advance(actions)
        want = {r: s for r, s in stepped.statuses.items() if s.death is not None}
        assert list(got) == list(want)
        for r, s in got.items():
            assert (s.death, s.blow_up, s.fitness, s.age) == \
                (want[r].death, want[r].blow_up, want[r].fitness, want[r].age)
            np.testing.assert_array_equal(s.position, want[r].position)
            ended[r] = s.death
        assert stepped.robot_ids == advanced.robot_ids
        for r in stepped.robot_ids:
            a, b = stepped.status(r), advanced.status(r)
            assert (a.fitness, a.v, a.s, a.age) == (b.fitness, b.v, b.s, b.age)
            np.testing.assert_array_equal(stepped.observe(r), advanced.observe(r))
    if max_angular_speed > 100:
        assert set(ended.values()) == {"removed"} and len(stepped.robot_ids) == 2
    else:
        assert set(ended.values()) == {"blow_up"} and not stepped.robot_ids

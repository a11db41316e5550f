"""MuJoCo births and deaths: the scene's layout, collision bits, batched deaths, exact survivors."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from world_robots import every_part, lone_core, snake, spider

from revolve_env import example
from revolve_env.world import World, WorldConfig, build_model

mujoco = pytest.importorskip("mujoco", reason="the mujoco package is not installed")

from revolve_env.world import compiled, mujoco_backend, mujoco_scene  # noqa: E402 (needs mujoco)

MJ = WorldConfig(engine="mujoco")


def _backend(world: World) -> Any:
    return world.backend


def test_every_robots_addresses_are_those_mujoco_gives_its_names() -> None:
    robots = [every_part(), spider(), snake(), lone_core(),
              *(example(name) for name in ("gecko", "sensor_crawler", "bar_walker"))]
    with World(MJ) as world:
        for i, robot in enumerate(robots):
            world.add_robot(robot, position=(1.5 * i, 0.0), yaw=0.3 * i)
        world.remove_robot(world.handles[2])
        world.step(1)
        b = _backend(world)
        m = b._model
        for key, r in b._robots.items():
            links = r.model.links
            names = [m.body(f"r{key}/b{i}").id for i in range(len(links))]
            assert r.bodies.tolist() == names
            hinges = [m.joint(f"r{key}/j{i}").id for i in range(1, len(links))
                      if not links[i].fixed]
            assert r.hinge_qpos.tolist() == m.jnt_qposadr[hinges].tolist()
            assert r.hinge_dofs.tolist() == m.jnt_dofadr[hinges].tolist()
            root = m.joint(f"r{key}/root").id
            assert (r.qpos.start, r.dofs.start) == (m.jnt_qposadr[root], m.jnt_dofadr[root])


def _collide(m: Any, g1: int, g2: int) -> bool:
    """MuJoCo's contype/conaffinity rule and its exclusions, for two geoms."""
    if m.geom_bodyid[g1] == m.geom_bodyid[g2]:
        return False  # MuJoCo never collides a body with itself
    if not (m.geom_contype[g1] & m.geom_conaffinity[g2]
            or m.geom_contype[g2] & m.geom_conaffinity[g1]):
        return False
    b1, b2 = sorted((m.geom_bodyid[g1], m.geom_bodyid[g2]))
    signature = (b1 << 16) + b2
    return signature not in set(m.exclude_signature.tolist())


def test_robots_collide_with_each_other_and_the_ground_never_with_themselves_beyond_30() -> None:
    n = mujoco_scene.COLORS + 3  # three robots share the last collision bit
    with World(MJ) as world:
        for i in range(n):
            world.add_robot(every_part() if i % 2 else snake(),
                            position=(0.6 * (i % 8), 0.6 * (i // 8)))
        b = _backend(world)
        m = b._model
        assert sorted(r.color for r in b._robots.values()) == [*range(mujoco_scene.COLORS),
                                                                *[mujoco_scene.COLORS] * 3]
        owner = np.full(m.nbody, -1)
        for row, r in enumerate(b._robots.values()):
            owner[r.bodies] = row
        rng = np.random.default_rng(0)
        robot_geoms = np.flatnonzero(m.geom_bodyid > 0)
        pairs = [(int(a), int(c)) for a, c in (rng.choice(robot_geoms, 2, replace=False)
                                               for _ in range(3000))]
        # every geom of the three sharing robots against every geom of the same three
        shared = [g for g in robot_geoms if owner[m.geom_bodyid[g]] >= mujoco_scene.COLORS]
        pairs += [(int(a), int(c)) for a in shared for c in shared if a < c]
        for g1, g2 in pairs:
            same = owner[m.geom_bodyid[g1]] == owner[m.geom_bodyid[g2]]
            assert _collide(m, g1, g2) != same, (g1, g2)
        assert all(_collide(m, 0, int(g)) for g in robot_geoms)  # geom 0: the ground


def test_two_robots_sharing_a_collision_bit_stack_and_do_not_blow_up() -> None:
    with World(MJ) as world:
        for i in range(mujoco_scene.COLORS):
            world.add_robot(lone_core(), position=(2.0 + 0.2 * i, 3.0))
        below = world.add_robot(lone_core())
        above = world.add_robot(lone_core(), drop_height=0.2)
        snake_h = world.add_robot(snake(), position=(1.0, 0.0))  # its hinge boxes overlap
        assert {r.color for r in _backend(world)._robots.values()} == set(
            range(mujoco_scene.COLORS + 1))
        world.step(90)
        assert world.core_position(above)[2] == pytest.approx(0.0465 * 1.5, abs=5e-3)
        assert world.core_position(below)[2] == pytest.approx(0.0465 / 2, abs=5e-3)
        assert world.blow_up(snake_h) is None


def _crowd(world: World) -> list[int]:
    robots = [every_part(), spider(), snake(), example("gecko"), spider(), lone_core()]
    return [world.add_robot(r, position=(0.22 * i, 0.1 * (i % 2)), yaw=0.5 * i)
            for i, r in enumerate(robots)]


def _drive(world: World, periods: int) -> np.ndarray:
    seen = []
    for k in range(periods):
        for j, h in enumerate(world.handles):
            world.set_targets(h, np.sin(k / 9 + j + np.arange(world.n_outputs(h))))
        world.step()
        seen.append(np.concatenate([world.core_positions().ravel()]
                                   + [world.read_sensors(h) for h in world.handles]))
    return np.array(seen)


def test_deaths_are_compiled_once_and_the_survivors_go_on_as_after_deaths_one_by_one(
        monkeypatch: pytest.MonkeyPatch) -> None:
    compiles = []
    original = mujoco_backend.MujocoBackend._compile

    def counted(self: Any) -> None:
        compiles.append(len(self._robots))
        original(self)

    monkeypatch.setattr(mujoco_backend.MujocoBackend, "_compile", counted)
    runs = []
    for one_by_one in (False, True):
        with World(MJ) as world:
            handles = _crowd(world)
            before = _drive(world, 30)
            compiles.clear()
            for h in handles[1:4]:
                world.remove_robot(h)
                if one_by_one:  # a contact read compiles the scene without the dead robot
                    world.read_sensors(handles[0])
            read = [world.core_positions(), world.joint_angles(handles[4])]
            assert len(compiles) == (3 if one_by_one else 0)
            runs.append((before, read, _drive(world, 60), _backend(world)._model_digest()))
            assert len(compiles) == (3 if one_by_one else 1)
    (b1, r1, after1, digest1), (b2, r2, after2, digest2) = runs
    np.testing.assert_array_equal(b1, b2)
    for x, y in zip(r1, r2, strict=True):
        np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(after1, after2)
    assert digest1 == digest2


def test_a_birth_after_deaths_compiles_once_and_a_refused_one_changes_nothing(
        monkeypatch: pytest.MonkeyPatch) -> None:
    import revolve_env.world.world as world_module

    with World(MJ) as world:
        handles = _crowd(world)
        _drive(world, 10)
        world.remove_robot(handles[0])
        world.remove_robot(handles[2])
        state = [world.core_positions(), world.joint_angles(handles[1])]
        model = build_model(snake())
        bad = dataclasses.replace(model, links=(dataclasses.replace(
            model.links[0], box_half_extents=-model.links[0].box_half_extents), *model.links[1:]))
        with monkeypatch.context() as patch:
            patch.setattr(world_module, "build_model", lambda robot: bad)
            with pytest.raises(ValueError, match="MuJoCo cannot build this robot"):
                world.add_robot(snake(), position=(2.0, 0.0))
        assert world.handles == tuple(handles[i] for i in (1, 3, 4, 5))
        np.testing.assert_array_equal(world.core_positions(), state[0])
        np.testing.assert_array_equal(world.joint_angles(handles[1]), state[1])
        newborn = world.add_robot(snake(), position=(2.0, 0.0))
        assert world.body_count() == 6 and not _backend(world)._deaths_pending
        np.testing.assert_array_equal(world.core_positions()[:4], state[0])
        _drive(world, 5)
        assert world.blow_up(newborn) is None


def test_a_blow_up_that_makes_mujoco_fail_is_contained_like_any_other(
        tmp_path: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    # In a crowd, a NaN that reaches a later physics step's collision pass can exhaust MuJoCo's
    # arena: mj_step raises FatalError (seen with 36 touching robots) instead of returning NaN.
    monkeypatch.chdir(tmp_path)  # MuJoCo logs its NaN warning to ./MUJOCO_LOG.TXT
    real_step = mujoco.mj_step
    failures = []

    def failing(m: Any, d: Any, nstep: int = 1) -> None:
        real_step(m, d, nstep)
        if nstep > 1 and not np.isfinite(d.qvel).all():
            failures.append(d.time)
            raise mujoco.FatalError("mj_stackAlloc: out of memory")

    def run() -> tuple[np.ndarray, str | None]:
        with World(MJ) as world:
            calm = world.add_robot(spider(), position=(1.0, 0.0))
            bad = world.add_robot(spider())
            path = []
            for i in range(20):
                if i == 10:
                    _backend(world)._data.qvel[14 + 6] = np.nan  # a hinge of the second robot
                world.step()
                path.append(world.core_position(calm))
            assert np.isfinite(world.core_position(bad)).all()
            return np.array(path), world.blow_up(bad)

    plain, reason = run()  # the compiled world step, where it is built
    monkeypatch.setattr(mujoco, "mj_step", failing)  # the module the backend calls
    monkeypatch.setattr(compiled, "world_step", lambda *a, **k: None)  # which it is
    failed, failed_reason = run()
    assert len(failures) == 1 and reason is not None and failed_reason == reason
    np.testing.assert_array_equal(failed, plain)  # as if MuJoCo had returned the NaN


def test_a_failing_mj_step_in_an_isolated_world_is_contained_as_in_a_world_alone(
        tmp_path: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # MuJoCo logs its NaN warning to ./MUJOCO_LOG.TXT
    real_step = mujoco.mj_step
    failures = []

    def failing(m: Any, d: Any, nstep: int = 1) -> None:
        real_step(m, d, nstep)
        if nstep > 1 and not np.isfinite(d.qvel).all():
            failures.append(d.time)
            raise mujoco.FatalError("mj_stackAlloc: out of memory")

    def run() -> tuple[np.ndarray, str | None]:
        with World(MJ, isolated=True) as world:
            calm = world.add_robot(snake())  # another model: the scenes are not one mujoco.batch
            bad = world.add_robot(spider())
            path = []
            for i in range(20):
                if i == 10:  # a hinge of the second robot (its scene's data and saved state)
                    scenes = _backend(world)
                    m, d, *_, views, _ = scenes._plan[1]
                    for qvel in (d.qvel, views[scenes._parity][1 + m.nq:]):
                        qvel[6] = np.nan
                world.set_all_targets(np.full(world.output_offsets[-1], 0.3))
                world.step()
                path.append(np.concatenate([world.core_position(calm), world.core_position(bad),
                                            world.sensor_values()]))
            return np.array(path), world.blow_up(bad)

    plain, reason = run()
    monkeypatch.setattr(mujoco, "mj_step", failing)  # the module the scenes call
    failed, failed_reason = run()
    assert len(failures) == 1 and reason is not None and failed_reason == reason
    np.testing.assert_array_equal(failed, plain)  # as if MuJoCo had returned the NaN

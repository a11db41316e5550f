"""The physics engines: one table of what each is, needs and can do, and the backend factory.

Every engine is one :class:`Engine` record in :data:`TABLE`: its backend (a module path and a
class name, imported only when a world is built, by :func:`make_backend`), the package it needs
(checked by :func:`require_engine` without importing it, so that reading a stored config never
loads an engine), the revision of how this package steps it, and its capabilities. Drivers ask
for a capability (``engine(name).gui``) instead of testing engine names; a capability
an engine lacks is refused in one line. :data:`ENGINES` and :data:`PHYSICS_REVISIONS` are read
off the table. A new engine is one backend module plus one record here.
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

from revolve_env.world.backend import EngineUnavailableError, PhysicsBackend
from revolve_env.world.config import WorldConfig
from revolve_env.world.isolated import IsolatedBackend

__all__ = ["ENGINES", "PHYSICS_REVISIONS", "TABLE", "Capability", "Engine",
           "EngineUnavailableError", "capable", "engine", "make_backend", "require_engine",
           "with_engine"]

Capability = Literal["gui", "exact_restore", "isolated_exact", "offscreen_gl", "shared_world",
                     "deterministic"]
"""The yes/no capabilities of an :class:`Engine`."""


@dataclass(frozen=True, slots=True)
class Engine:
    """One physics engine: where its backend is, what it needs, what it can do.

    Attributes:
        name: What ``WorldConfig.engine`` and every ``engine=`` keyword call it.
        module: The backend's module (imported when a world of this engine is built).
        backend: The backend's class in ``module``: a
            :class:`~revolve_env.world.backend.PhysicsBackend`.
        isolated: ``"module:Class"`` of the engine's own backend for isolated worlds (a scene
            per robot, stepped together; made as ``Class(config, threads=...)``), or None: the
            generic :class:`~revolve_env.world.isolated.IsolatedBackend` over scenes of
            ``backend``.
        package: The module the engine's Python package installs (checked, not imported, by
            :func:`require_engine`).
        pip: What ``pip install`` brings that package.
        extra: This project's optional extra that brings it (``revolve-env[extra]``); None: a
            core dependency.
        revision: The revision of how this package steps the engine, raised by a change that
            moves its numbers (the results store records it; a run made with another revision
            is not continued: its remaining births would live in other physics).
        gui: Whether the engine opens an interactive window (``World(gui=True)``).
        exact_restore: Whether a world's snapshot continues bit for bit after a restore
            (``World.snapshot`` / ``World.restore``; online runs resume from checkpoints).
        isolated_exact: Whether a robot's result in an isolated world is that of a world where it
            is alone, independent of the batch it is evaluated in.
        offscreen_gl: Whether its pictures are drawn with OpenGL, whose offscreen backend must
            be chosen before the package is imported (:mod:`revolve_env.envs.offscreen`); False:
            a renderer of its own that needs no display.
        shared_world: Whether robots can share one scene and meet (``World(config)`` without
            ``isolated``); False: isolated worlds only (a robot per world), the rest refused.
        deterministic: Whether the same inputs give the same numbers bit for bit, run after run
            and at any batch size; False: float32 worlds whose numbers depend on the batch and
            the device (what :attr:`isolated_exact` False also says of a robot's result).
        threads: CPU threads one backend steps with (a process pool may run ``cores / threads``
            workers).
        device: Where the physics runs (``"cpu"``; ``"warp"``: the device Warp picks, a GPU
            when one is present, else the CPU).
    """

    name: str
    module: str
    backend: str
    isolated: str | None
    package: str
    pip: str
    extra: str | None
    revision: int
    gui: bool
    exact_restore: bool
    isolated_exact: bool = True
    offscreen_gl: bool = False
    shared_world: bool = True
    deterministic: bool = True
    threads: int = 1
    device: str = "cpu"

    def install_hint(self) -> str:
        """How to install the engine's package, for one-line errors."""
        hint = f"pip install {self.pip}"
        if self.extra is not None:
            hint += f" (or this package's extra: pip install 'revolve-env[{self.extra}]')"
        return hint


TABLE: tuple[Engine, ...] = (
    # pybullet 2: each link keeps its own inertia, servo and sensors in a robot whose links
    # pybullet renumbers (a touch sensor anywhere but last; revision 1 drove a welded touch half
    # instead of the servo's hinge: pybullet_backend.pybullet_link_order).
    Engine("pybullet", "revolve_env.world.pybullet_backend", "PybulletBackend", None,
           package="pybullet", pip="pybullet", extra=None, revision=2, gui=True,
           exact_restore=False),
    # MuJoCo 2: the discrete integrator with islands off and one spec per robot (revision 1,
    # with ``implicitfast``, made every result stored before revision numbers).
    Engine("mujoco", "revolve_env.world.mujoco_backend", "MujocoBackend",
           "revolve_env.world.mujoco_batch:MujocoBatchScenes", package="mujoco", pip="mujoco",
           extra="mujoco", revision=2, gui=True, exact_restore=True, offscreen_gl=True),
    # MuJoCo Warp 1: MuJoCo's model (the same scenes, built on the CPU) stepped in float32 on
    # Warp's device, copies of one body as the worlds of one batch (docs/engines.md, "MuJoCo
    # Warp"). Never the default: its numbers are not CPU MuJoCo's and depend on the batch.
    Engine("mujoco_warp", "revolve_env.world.mujoco_backend", "MujocoBackend",
           "revolve_env.world.warp_scenes:WarpScenes", package="mujoco_warp",
           pip="mujoco-warp warp-lang", extra="warp", revision=1, gui=False, exact_restore=False,
           isolated_exact=False, offscreen_gl=True, shared_world=False, deterministic=False,
           device="warp"),
)
"""Every engine this package runs; the first is the reference."""

#: Names accepted by ``WorldConfig(engine=...)`` and every ``engine=`` keyword.
ENGINES: tuple[str, ...] = tuple(e.name for e in TABLE)

#: Engine name -> :attr:`Engine.revision` (stored with every run).
PHYSICS_REVISIONS: dict[str, int] = {e.name: e.revision for e in TABLE}


def engine(name: str) -> Engine:
    """The record of engine ``name``.

    Raises:
        ValueError: unknown engine name.
    """
    for record in TABLE:
        if record.name == name:
            return record
    raise ValueError(f"unknown physics engine {name!r}: choose one of {', '.join(ENGINES)}")


def capable(capability: Capability) -> tuple[str, ...]:
    """The names of the engines that have ``capability`` (for one-line refusals)."""
    return tuple(e.name for e in TABLE if getattr(e, capability))


def require_engine(name: str) -> Engine:
    """The record of engine ``name``, checked to be known and installed (nothing is imported).

    Raises:
        ValueError: unknown engine name.
        EngineUnavailableError: its package is not installed.
    """
    record = engine(name)
    try:
        found = importlib.util.find_spec(record.package) is not None
    except (ImportError, ValueError):  # a broken parent package, a module without a spec
        found = False
    if not found:
        raise EngineUnavailableError(
            f"engine {name!r} needs the {record.package!r} package, which is not installed; "
            f"install it with: {record.install_hint()}")
    return record


def with_engine(config: WorldConfig, name: str | None) -> WorldConfig:
    """``config`` on engine ``name`` (None: its own), checked to be known and installed.

    The one place where an ``engine=`` keyword (of ``evaluate`` and the envs) meets a config,
    so that a missing package fails when the env is made rather than at its first reset.

    Raises:
        ValueError: unknown engine name.
        EngineUnavailableError: the engine's package is not installed.
    """
    out = config if name is None else dataclasses.replace(config, engine=name)
    require_engine(out.engine)
    return out


def _load(record: Engine, path: str) -> Callable[..., PhysicsBackend]:
    """The class at ``"module:Class"`` of ``record``'s backends, imported now.

    Raises:
        EngineUnavailableError: the engine's package is installed but does not import.
    """
    module, _, cls = path.partition(":")
    try:
        loaded: Callable[..., PhysicsBackend] = getattr(importlib.import_module(module), cls)
    except ImportError as e:
        raise EngineUnavailableError(
            f"engine {record.name!r}: its package {record.package!r} does not import ({e}); "
            f"reinstall it with: {record.install_hint()}") from None
    return loaded


def make_backend(config: WorldConfig, *, gui: bool = False, isolated: bool = False,
                 threads: int = 1) -> PhysicsBackend:
    """A fresh backend of ``config.engine`` built from ``config``.

    With ``isolated``, every robot is in a scene of its own (the engine's own isolated backend,
    else :class:`~revolve_env.world.isolated.IsolatedBackend`), whose batched stepping, where the
    engine has one, runs on ``threads`` threads.

    Raises:
        ValueError: unknown engine name.
        EngineUnavailableError: its package is not installed.
        RuntimeError: a GUI window was asked of an engine (or an isolated world) that has none,
            a shared world of an engine without one, or the engine could not start (e.g. a GUI
            without a display).
    """
    record = engine(config.engine)  # what it lacks is refused first, installed or not
    if gui and (isolated or not record.gui):
        why = ("an isolated world has no GUI window (its robots are in separate scenes)"
               if isolated else
               f"the {record.name!r} engine has no GUI window in revolve-env (its capability "
               "gui is False); use render_mode='rgb_array'")
        raise RuntimeError(why)
    if not isolated and not record.shared_world:
        raise RuntimeError(
            f"the {record.name!r} engine steps isolated worlds only (its capability shared_world "
            "is False): use World(config, isolated=True), evaluate/evaluate_many, the vector env "
            f"or the Training Center, or an engine with shared worlds "
            f"({', '.join(capable('shared_world'))})")
    require_engine(record.name)
    scene = _load(record, f"{record.module}:{record.backend}")
    if not isolated:
        return scene(config, gui=gui)
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ValueError(f"threads must be an integer >= 1, got {threads!r}")
    if record.isolated is not None:
        return _load(record, record.isolated)(config, threads=threads)
    return IsolatedBackend(config, scene=scene)

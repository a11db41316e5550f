"""Online population: a PettingZoo parallel env whose robots are born and die in one world.

All robots live in ONE :class:`~revolve_env.world.World` (an infinite flat plane; robots collide
with each other). Robots are added and removed between steps by the caller (online evolution, a
test harness, a learner); each is one PettingZoo agent ``robot_<n>``.

The robots' bookkeeping and the five dicts are in :mod:`revolve_env.envs.members`, the exact and
uniform spaces and masks in :mod:`revolve_env.envs.agent_spaces`, a birth's checks in
:mod:`revolve_env.envs.births`, the snapshots' plain data in
:mod:`revolve_env.envs.population_snapshot`. This module is over 600 lines on purpose: it is the
env's reference documentation too. About 340 of its lines are docstrings (the class docstring
alone, some 210 lines, is the documentation of the agents, spaces, infos, rewards, conditions
and the five dicts on births and deaths); the code is about 470 lines.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, Literal

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from numpy.typing import ArrayLike, NDArray
from pettingzoo import ParallelEnv

from revolve_env.body.examples import EXAMPLES
from revolve_env.body.robot import Layer, Robot
from revolve_env.body.validate import Limits
from revolve_env.brain import BatchController
from revolve_env.conditions import EvaluationConditions
from revolve_env.envs.agent_spaces import AgentSpaces, SpaceMode
from revolve_env.envs.births import check_birth, initial_births, jittered
from revolve_env.envs.living import Living, final_info
from revolve_env.envs.members import (
    Controller,
    Dicts,
    Lifetimes,
    Member,
    noise_generator,
    sensor_bounds,
)
from revolve_env.envs.placement import Disc, clash, footprint_radius, place
from revolve_env.envs.population_snapshot import member_snapshot, read_snapshot
from revolve_env.fitness import DEFAULT_WINDOW
from revolve_env.world import World, WorldConfig
from revolve_env.world.backend import SnapshotMismatchError

__all__ = ["ONLINE_CONDITIONS", "Controller", "Lifecycle", "PopulationEnv", "SpaceMode",
           "footprint_radius", "population_env", "sensor_bounds"]

ONLINE_CONDITIONS = EvaluationConditions(heading="random")
"""The population env's default conditions: random headings, no jitter, no noise (as always)."""

Lifecycle = Callable[["PopulationEnv", int], None]
"""Called as ``lifecycle(env, k)`` inside step ``k`` (1, 2, ... since reset), before the physics;
it may add and remove robots (see :class:`PopulationEnv`, Births and deaths inside a step)."""


def _check_arguments(max_births: int, render_mode: str | None, render_view: str,
                     render_size: tuple[int, int], times: dict[str, float],
                     fitness_window: float, max_placement_tries: int, trajectory_stride: int,
                     max_steps: int | None, space_mode: str, lifecycle: object) -> None:
    """Refuse bad constructor arguments (``times``: the ones that must be >= 0) by name."""
    if not (isinstance(max_births, int) and max_births >= 1):
        raise ValueError(f"max_births must be an integer >= 1, got {max_births!r}")
    if render_mode is not None and render_mode != "rgb_array":
        raise ValueError(f"render_mode must be 'rgb_array' or None, got {render_mode!r}")
    if render_view not in ("top", "chase"):
        raise ValueError(f"render_view must be 'top' or 'chase', got {render_view!r}")
    if len(render_size) != 2 or min(render_size) < 1:
        raise ValueError(f"render_size must be (width, height) in pixels, got {render_size!r}")
    for name, value in times.items():
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value}")
    if not (math.isfinite(fitness_window) and fitness_window > 0):
        raise ValueError(f"fitness_window must be a positive number of seconds, got "
                         f"{fitness_window}")
    if max_placement_tries < 1:
        raise ValueError(f"max_placement_tries must be >= 1, got {max_placement_tries}")
    if trajectory_stride < 1:
        raise ValueError(f"trajectory_stride must be >= 1, got {trajectory_stride}")
    if max_steps is not None and max_steps < 1:
        raise ValueError(f"max_steps must be >= 1 or None, got {max_steps}")
    if space_mode not in ("exact", "uniform"):
        raise ValueError(f"space_mode must be 'exact' or 'uniform', got {space_mode!r}")
    if lifecycle is not None and not callable(lifecycle):
        raise TypeError(f"lifecycle must be callable as lifecycle(env, step), got "
                        f"{type(lifecycle).__name__}")


# pettingzoo ships no type information (no py.typed), so mypy sees ParallelEnv as Any.
class PopulationEnv(ParallelEnv[str, NDArray[np.float64], NDArray[np.float32]]):  # type: ignore[misc]
    """A changing population of RoboGen robots in one world; reward is each robot's fitness gain.

    ## Agents
    Each robot is an agent ``robot_<n>`` (``n`` counts births since ``reset``, from 0). Ids are
    never reused and a dead agent never comes back; ``possible_agents`` is the pool
    ``robot_0 .. robot_<max_births - 1>``. Robots enter through :meth:`add_robot` (or ``reset``'s
    initial robots) and leave through :meth:`remove_robot` or a physics blow-up:

    * A robot added between two steps is in :attr:`agents` at once and is reported in all five
      dicts of the next :meth:`step` (it is simulated in that step).
    * A robot removed between two steps leaves the world (and :attr:`agents`) at once; the next
      :meth:`step` reports it one last time with ``terminations[agent] = True`` and
      ``infos[agent]["death"] = "removed"``; then it disappears.
    * A robot whose simulation blows up is removed at the end of the step that saw it, reported in
      that step with ``terminations[agent] = True``, ``infos[agent]["death"] = "blow_up"`` and the
      reason in ``infos[agent]["blow_up"]``.

    With ``max_steps`` set, every living robot is truncated after that many steps (the episode
    ends); by default the episode never ends on its own.

    ## Births and deaths inside a step
    ``lifecycle(env, k)``, if given, is called inside step ``k`` (counting from 1 after
    ``reset``) once the actions are checked and before the physics. It may call :meth:`add_robot`
    and :meth:`remove_robot`: a robot it adds is simulated and reported in step ``k``; a robot it
    removes is reported in step ``k`` as removed and its action, given for that step, is dropped.
    This is how PettingZoo's own ``generated_agents_parallel_v0`` makes agents, and it is the
    way to use births and deaths through ``parallel_to_aec`` and wrapper libraries, which learn
    of agents only from what ``step`` reports (a robot removed between two steps would still get
    an action from them, which is an error here). An error raised by ``lifecycle`` propagates; the
    robots it added or removed before raising stay added or removed, nothing else changed.

    ## The five dicts of a step
    Keys: every agent alive before the step or born before the physics of the step (between
    steps or by ``lifecycle``), plus every agent removed since the last step. Per agent:

    | Dict         | Born (first report)          | Removed              | Blown up in this step  |
    |--------------|------------------------------|----------------------|------------------------|
    | observations | its observation after it     | its last observation | zeros                  |
    | rewards      | fitness gain (0 inserting)   | 0.0                  | minus its fitness      |
    | terminations | False (True if it blew up)   | True                 | True                   |
    | truncations  | True only at ``max_steps``   | False                | False                  |
    | infos        | ``age`` = one control period | ``death="removed"``, | ``death="blow_up"``,   |
    |              | ``death=None``, its masks    | its last state       | reason in ``blow_up``  |

    A living robot that is neither born nor dying is reported like the first column with its own
    age. An agent is reported one last time in the step of its death, then never again.

    ## Control
    ``controlled_by="brain"``: the robot's own neural network (its ``Robot`` neurons) drives its
    hinges; all brain-controlled robots are stepped by one call of the compiled
    :class:`~revolve_env.brain.BatchController`, fed with the robot's previous sensor values. Its
    action, if given, is checked and ignored. ``controlled_by="agent"``: the action from the
    ``actions`` dict drives the hinges; an agent-controlled robot missing from ``actions`` keeps its
    previous targets (0 at birth).

    ## Spaces: exact or uniform
    Every agent of ``possible_agents`` (``robot_0 .. robot_<max_births - 1>``) has an observation
    and an action space at any time, born or not, and ``observation_space(agent)`` /
    ``action_space(agent)`` return the same object on every call.

    * ``space_mode="uniform"``: every agent has spaces of the same shape, sized by ``limits``
      (Table 1: 10 inputs, 10 outputs; hidden neurons are not observed), created on first request
      and kept for the env's lifetime. A robot's values fill the first entries of each block and
      the rest is padding (0 in observations, ignored in actions). Which entries are real is given
      by :meth:`observation_mask` and :meth:`action_mask` and in ``infos[agent]["obs_mask"]`` and
      ``["act_mask"]`` (read-only bool arrays; not ``"action_mask"``, which PettingZoo's samplers
      would pass to ``Box.sample``). One shared policy can drive robots of any body this way.
    * ``space_mode="exact"`` (default): a robot gets spaces of its own body's sizes at its birth,
      for that episode (agent ids restart at ``robot_0`` after ``reset``). A future agent's body
      is unknown, so an agent whose spaces are requested before its birth (PettingZoo's
      converters and wrapper libraries walk ``possible_agents``) gets the uniform spaces instead,
      keeps them for the env's lifetime, and is observed and driven as in uniform mode.

    ## Action Space (per agent)
    ``Box(-1, 1, (n,), float32)``: exact: ``n`` is the robot's number of active hinges (may be
    0); uniform: ``n = limits.max_outputs`` and entries past the robot's hinges are ignored.

    | Index | Action                              | Min | Max | Unit                    |
    |-------|-------------------------------------|-----|-----|-------------------------|
    | i     | position target of active hinge i   | -1  | 1   | normalized (1 = 45 deg) |

    Hinges are in traversal order (the robot's output neuron order).

    ## Observation Space (per agent)
    ``Box(low, high, (m,), float64)``. Exact: the robot's ``s`` sensor values, then with
    ``proprioception=True`` its ``n`` hinge angles and ``n`` hinge velocities (``m = s + 2 n``).
    Uniform: blocks of ``limits.max_inputs`` sensor values, then with proprioception
    ``limits.max_outputs`` angles and ``limits.max_outputs`` velocities, each block padded.

    | Values                               | Min (exact / uniform) | Max           | Unit        |
    |--------------------------------------|-----------------------|---------------|-------------|
    | core accelerometer x, y, z (core     | -inf / -157           | inf / 157     | m/s^2       |
    | frame, incl. the reaction to gravity)|                       |               |             |
    | core gyroscope x, y, z (core frame)  | -inf / -34.9          | inf / 34.9    | rad/s       |
    | touch sensor: left, right half       | 0                     | 1             | binary      |
    | light sensor: intensity              | 0                     | 1             | 1           |
    | angle of active hinge i (opt-in)     | -pi                   | pi            | rad         |
    | velocity of active hinge i (opt-in)  | -200                  | 200           | rad/s       |

    Sensors are in traversal order (the robot's input neuron order); the core comes first, so
    the first six values are always its IMU. Uniform observations saturate the IMU at its full
    scale (16 g, 2000 deg/s, as :class:`~revolve_env.envs.locomotion.LocomotionEnv` does) so that
    the bounds are finite; exact ones keep the raw readings. Hinge angles saturate at +-pi and
    velocities at ``world_config.max_angular_speed`` (faster is a blow-up). A robot's own network
    reads its raw sensor values only, never the hinge values. The observation of a robot whose
    simulation blew up is all zeros.

    ## Rewards
    ``reward = fitness(t) - fitness(t - control_period)`` with the sliding-window fitness
    ``f = v + 5 s`` (:class:`~revolve_env.fitness.FitnessWindows`, window
    ``fitness_window``) over the core positions sampled after the insertion phase (the first
    ``insertion_time`` seconds of the robot's life, scored 0). On a blow-up the fitness is set to 0
    (that step's reward is minus the fitness so far). A removed robot's last reward is 0.

    ## Info (per agent)
    | Key            | Meaning                                                               |
    |----------------|-----------------------------------------------------------------------|
    | age            | seconds since birth                                                   |
    | birth_time     | simulated time of birth. Seconds                                      |
    | birth_position | core ``(x, y)`` where the robot was placed. Metres                    |
    | born_inside_disc | False when a crowded birth disc put it outside (see placement)      |
    | inserting      | ``age < insertion_time`` (the fitness is not yet sampled)             |
    | is_mature      | ``age >= maturity_age``                                               |
    | fitness        | ``v + 5 s`` over the window. Metres                                   |
    | fitness_v      | horizontal path length over the window. Metres                        |
    | fitness_s      | straight horizontal displacement over the window. Metres              |
    | position       | core centre ``(x, y, z)``. Metres (a copy)                            |
    | trajectory     | ``(T, 3)`` read-only core positions, one per ``trajectory_stride``     |
    |                | control periods since birth (birth position first). Metres            |
    | controlled_by  | ``"brain"`` or ``"agent"``                                            |
    | blow_up        | reason string, or None                                                |
    | death          | None while alive; ``"removed"`` or ``"blow_up"`` in the last report   |
    | obs_mask       | bool per observation entry: True where it holds the robot's value     |
    | act_mask       | bool per action entry: True where it drives one of the robot's hinges |

    ## Birth placement
    :meth:`add_robot` drops a robot (lowest point ``world_config.drop_height`` above the ground)
    at the given ``(x, y)``, or at a uniformly random position within ``birth_radius`` of the
    origin, with a heading from ``conditions`` (random by default). A robot occupies a disc of
    radius :func:`footprint_radius` about its core; a new robot's disc must keep
    ``birth_clearance`` from every living robot's disc (about its current core position). The
    rule is :func:`revolve_env.envs.placement.place`, which the evolution engine's online world
    uses too: after ``max_placement_tries`` random draws in a crowded birth disc, the robot goes
    to the nearest free position outside it, and ``infos[agent]["born_inside_disc"]`` is False;
    a birth never fails for lack of room. A given position that overlaps is a ``ValueError``.
    Draws come from the generator seeded by ``reset(seed=...)``.

    ## Conditions
    ``conditions`` (:class:`~revolve_env.conditions.EvaluationConditions`, default
    :data:`ONLINE_CONDITIONS`: random heading, no jitter, no noise) are the conditions every
    newborn lives in, the same object an offline evaluation takes:

    * heading: a robot added without ``yaw`` gets ``conditions.heading``, or with ``"random"`` a
      heading drawn uniformly in ``[0, 2 pi)`` from the env's generator;
    * position jitter: a robot added at a given position is moved to a point drawn uniformly
      from the disc of radius ``position_jitter`` around it (env's generator; an overlap at the
      jittered point is the ``ValueError`` above). A robot placed by the placement rule is
      already at a random point of the birth disc: no jitter is added on top;
    * sensor noise: Gaussian noise of std ``sensor_noise`` on every sensor value read after a
      step and at birth (clipped to the sensors' bounds), so on what brains read and agents
      observe; the opt-in hinge values (proprioception) carry none;
    * actuator noise: Gaussian noise of std ``actuator_noise`` on every hinge target set, from an
      action or a brain (an agent-controlled robot missing from ``actions`` keeps its last,
      noisy, targets).

    The noise draws from a generator of its own, seeded at ``reset`` from the reset's seed
    (:func:`~revolve_env.envs.members.noise_generator`), so births and headings do not depend
    on the noise, and without noise nothing is drawn from it. Snapshots hold its state.

    ## Reset
    ``reset(seed, options)`` builds a fresh world and adds the initial robots:
    ``options["robots"]`` if given, else the ``initial_robots`` argument, else one of each example
    robot of :data:`revolve_env.body.examples.EXAMPLES` (spider, gecko, snake, sensor crawler,
    bar walker), brain-controlled, at random free positions. Each entry is a ``Robot`` or a mapping
    with keys ``robot`` and optional ``position``, ``controlled_by``, ``yaw``. Other option keys are
    ignored (PettingZoo's API test passes arbitrary ones).

    ## Arguments
    | Keyword             | Default  | Meaning                                                     |
    |---------------------|----------|-------------------------------------------------------------|
    | max_births          | 1000     | size of ``possible_agents``: births per episode             |
    | initial_robots      | None     | robots added by ``reset`` (see Reset)                       |
    | render_mode         | None     | "rgb_array"                                                 |
    | render_view         | "top"    | "top" (straight down) or "chase" (oblique), whole arena     |
    | render_size         | (480, 360) | image width and height. Pixels                            |
    | insertion_time      | 3.0      | not scored after birth. Seconds                             |
    | maturity_age        | 15.0     | age from which ``is_mature`` holds. Seconds                 |
    | fitness_window      | 12.0     | sliding window of the fitness. Seconds                      |
    | birth_radius        | 2.0      | random births lie within this distance of the origin. m     |
    | birth_clearance     | 0.02     | gap kept between footprints at birth. Metres                |
    | max_placement_tries | 200      | random draws in the birth disc before placing outside it    |
    | trajectory_stride   | 1        | control periods between trajectory samples                  |
    | max_steps           | None     | truncate every robot after this many steps (None: never)    |
    | control_period      | None     | time per env step. Seconds (a multiple of the timestep);    |
    |                     |          | None: world_config's (1/60 s by default)                    |
    | world_config        | None     | a :class:`~revolve_env.world.WorldConfig` (physics)         |
    | limits              | None     | validation limits (:class:`~revolve_env.body.Limits`)       |
    |                     |          | and the sizes of the uniform spaces (None: Table 1)         |
    | space_mode          | "exact"  | "exact" or "uniform" (see Spaces)                           |
    | proprioception      | False    | observe hinge angles and velocities                         |
    | lifecycle           | None     | births and deaths inside a step (see above)                 |
    | engine              | None     | "pybullet" or "mujoco"; None: world_config's (pybullet)     |
    | conditions          | random   | heading, jitter and noise of newborns (see Conditions);     |
    |                     | heading  | :data:`ONLINE_CONDITIONS` by default                        |

    Bad input raises before anything changes, naming the agent: an action for an agent not alive
    (never born, removed, blown up) is a ``KeyError``; an action of the wrong shape (the uniform
    shape in uniform mode) or with NaN or infinity is a ``ValueError``.
    """

    metadata: dict[str, Any] = {  # noqa: RUF012 (PettingZoo's convention; copied per instance)
        "render_modes": ["rgb_array"], "name": "revolve_population_v0", "render_fps": 60,
        "is_parallelizable": True,
    }


    def __init__(
        self,
        max_births: int = 1000,
        initial_robots: Sequence[Robot | Mapping[str, Any]] | None = None,
        render_mode: Literal["rgb_array"] | None = None,
        render_view: Literal["top", "chase"] = "top",
        render_size: tuple[int, int] = (480, 360),
        insertion_time: float = 3.0,
        maturity_age: float = 15.0,
        fitness_window: float = DEFAULT_WINDOW,
        birth_radius: float = 2.0,
        birth_clearance: float = 0.02,
        max_placement_tries: int = 200,
        trajectory_stride: int = 1,
        max_steps: int | None = None,
        control_period: float | None = None,
        world_config: WorldConfig | None = None,
        limits: Limits | None = None,
        space_mode: SpaceMode = "exact",
        proprioception: bool = False,
        lifecycle: Lifecycle | None = None,
        engine: str | None = None,
        conditions: EvaluationConditions = ONLINE_CONDITIONS,
    ) -> None:
        if not isinstance(conditions, EvaluationConditions):
            raise TypeError(f"conditions must be an EvaluationConditions, got "
                            f"{type(conditions).__name__}")
        times = {"insertion_time": insertion_time, "maturity_age": maturity_age,
                 "birth_radius": birth_radius, "birth_clearance": birth_clearance}
        _check_arguments(max_births, render_mode, render_view, render_size, times, fitness_window,
                         max_placement_tries, trajectory_stride, max_steps, space_mode, lifecycle)
        config = world_config if world_config is not None else WorldConfig()
        if control_period is not None:  # replace() validates it against the timestep
            config = dataclasses.replace(config, control_period=control_period)
        config = config.with_engine(engine)
        self.config = config
        self.max_births = max_births
        self.initial_robots = None if initial_robots is None else list(initial_robots)
        self.render_mode = render_mode
        self.render_view = render_view
        self.render_size = (int(render_size[0]), int(render_size[1]))
        self.insertion_time = float(insertion_time)
        self.maturity_age = float(maturity_age)
        self.fitness_window = float(fitness_window)
        self.birth_radius = float(birth_radius)
        self.birth_clearance = float(birth_clearance)
        self.max_placement_tries = int(max_placement_tries)
        self.trajectory_stride = int(trajectory_stride)
        self.max_steps = max_steps
        self.limits = limits
        self.space_mode: SpaceMode = space_mode
        self.proprioception = bool(proprioception)
        self.lifecycle = lifecycle
        self.conditions = conditions
        self._spaces = AgentSpaces(max_births, space_mode, self.proprioception, limits, config)
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self.config.control_period)}
        dt = self.config.control_period
        self._life = Lifetimes(dt, round(self.insertion_time / dt), round(self.maturity_age / dt))

        self.possible_agents: list[str] = self._spaces.possible_agents
        self.agents: list[str] = []
        self._members: dict[str, Member] = {}
        self._dead: list[tuple[Member, str]] = []  # removed since the last step: (member, death)
        self._births = 0
        self._steps = 0
        self._world: World | None = None
        self._brain: BatchController | None = None
        self._brain_out = np.zeros(0)
        self._brain_rows = np.zeros(0, dtype=np.intp)  # rows of the brain robots, brain order
        self._brain_inputs = np.zeros(0, dtype=np.intp)  # entries of the sensor values they read
        self._brain_targets = np.zeros(0, dtype=np.intp)  # and of the flat targets they drive
        self._living = Living(self.fitness_window, self.trajectory_stride, self._life,
                              self._spaces)
        self._np_random: np.random.Generator | None = None
        self._np_random_seed: int | None = None
        self._noise: np.random.Generator | None = None  # sensor and actuator noise

    # -- spaces ----------------------------------------------------------------------------------
    def observation_space(self, agent: str) -> spaces.Box:
        """The observation space of any agent of ``possible_agents`` (the same object every call).

        See the class doc (Spaces) for exact and uniform spaces.

        Raises:
            KeyError: ``agent`` is not one of ``possible_agents``.
        """
        return self._spaces.observation_space(agent)

    def action_space(self, agent: str) -> spaces.Box:
        """The action space of any agent of ``possible_agents`` (the same object every call).

        Raises:
            KeyError: ``agent`` is not one of ``possible_agents``.
        """
        return self._spaces.action_space(agent)

    def observation_mask(self, agent: str) -> NDArray[np.bool_]:
        """Which entries of the agent's observations carry its values (True) and which are padding.

        All True for exact spaces. Read-only; known from the agent's birth on, also once it died
        (until ``reset``).

        Raises:
            KeyError: naming the agent when it is unknown or not yet born in this episode.
        """
        return self._spaces.mask(agent, "observation_mask")[0]

    def action_mask(self, agent: str) -> NDArray[np.bool_]:
        """Which entries of the agent's actions drive a hinge (True); the others are ignored.

        Raises:
            KeyError: naming the agent when it is unknown or not yet born in this episode.
        """
        return self._spaces.mask(agent, "action_mask")[1]

    # -- properties ------------------------------------------------------------------------------
    @property
    def np_random(self) -> np.random.Generator:
        """The env's generator (birth positions and headings), seeded by ``reset(seed=...)``."""
        if self._np_random is None:
            self._np_random, self._np_random_seed = seeding.np_random()
        return self._np_random

    @property
    def births(self) -> int:
        """Robots born since ``reset`` (the next one is ``robot_<births>``)."""
        return self._births

    @property
    def time(self) -> float:
        """Simulated time since reset. Seconds."""
        return self._steps * self.config.control_period

    @property
    def world(self) -> World:
        """The physics world (read-only use: adding or removing robots here breaks the env)."""
        if self._world is None:
            raise RuntimeError("call reset() first")
        return self._world

    def robot(self, agent: str) -> Robot:
        """The body and brain of a living robot."""
        return self._member(agent, "robot").robot

    def positions(self) -> dict[str, tuple[float, float]]:
        """Core positions ``(x, y)`` of the living robots, in birth order. Metres."""
        if self._world is None:
            return {}
        centres = self._world.states.core_pos.tolist()  # rows: the agents, in birth order
        return {a: (p[0], p[1]) for a, p in zip(self.agents, centres, strict=True)}

    def observe(self, agent: str) -> NDArray[np.float64]:
        """The current observation of a living robot (a copy, in its observation space).

        It is made at its birth, or after the last step (its sensor part is what the next
        :meth:`step` feeds its brain).

        A robot added between two steps gets its first observation here, before it is ever
        reported by :meth:`step` (an agent-controlled policy needs one to choose its first
        action).

        Raises:
            KeyError: naming the agent when it is unknown, not yet born, or dead.
        """
        self._member(agent, "observe")
        return self._living.view_of(self.agents.index(agent))

    def agent_info(self, agent: str) -> dict[str, Any]:
        """The current info of a living robot (as :meth:`step` reports it)."""
        self._member(agent, "agent_info")
        return self._living.info(self.agents.index(agent), self._spaces.masks, None)

    def _member(self, agent: str, what: str) -> Member:
        try:
            return self._members[agent]
        except KeyError:
            pass
        if agent in self._spaces.masks:  # born in this episode
            raise KeyError(f"{what}: agent {agent!r} is dead (removed or blown up)")
        raise KeyError(f"{what}: {self._spaces.unknown(agent)}")

    # -- PettingZoo API --------------------------------------------------------------------------
    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, NDArray[np.float64]], dict[str, dict[str, Any]]]:
        """Start a new episode in a fresh world and add the initial robots (see the class doc)."""
        reseed = seed is not None or self._np_random is None
        if reseed:
            self._np_random, self._np_random_seed = seeding.np_random(seed)
        if reseed or self._noise is None:
            self._noise = noise_generator(self._np_random_seed)
        if self._world is not None:
            self._world.close()
        self._world = World(self.config)
        self._brain = BatchController(self.config.control_period)
        self.agents = []
        self._members = {}
        self._dead = []
        self._living.clear()
        self._relayout_brains()
        self._spaces.reset()
        self._births = 0
        self._steps = 0

        entries: Iterable[Robot | Mapping[str, Any]]
        if options is not None and "robots" in options:
            entries = options["robots"]
        elif self.initial_robots is not None:
            entries = self.initial_robots
        else:
            entries = [make() for make in EXAMPLES.values()]
        for kwargs in initial_births(entries):
            self.add_robot(**kwargs)
        living = self._living
        obs = dict(zip(self.agents, living.views(), strict=True))
        infos = dict(zip(self.agents, living.infos(self._spaces.masks, [None] * len(living)),
                         strict=True))
        return obs, infos

    def step(self, actions: Mapping[str, ArrayLike]) -> Dicts:
        """Advance every robot one control period (see the class doc for the five dicts).

        Raises:
            KeyError: an action for an agent that is not alive (never born, removed, blown up).
            ValueError: an action of the wrong shape, or with NaN or infinity.
            Nothing changes then (all actions are checked before ``lifecycle`` and the physics).
        """
        world = self._world
        if world is None or self._brain is None:
            raise RuntimeError("call reset() before step()")
        checked = self._checked_actions(actions)
        if self.lifecycle is not None:
            self.lifecycle(self, self._steps + 1)
            # Robots it removed leave with this step's death report; their actions are dropped.
            checked = [(m, a) for m, a in checked if m.agent in self._members]
        self._physics(world, checked)
        return self._report(world)

    def _checked_actions(
        self, actions: Mapping[str, ArrayLike]
    ) -> list[tuple[Member, NDArray[np.float64]]]:
        """Check every action before anything changes; the agent-controlled robots' targets."""
        checked: list[tuple[Member, NDArray[np.float64]]] = []
        for agent, action in actions.items():
            member = self._member(agent, "action")
            a = self._spaces.checked_action(member, action)
            if member.controlled_by == "agent":
                checked.append((member, a[:member.n_outputs] if member.padded else a))
        return checked

    def _physics(self, world: World, checked: list[tuple[Member, NDArray[np.float64]]]) -> None:
        """Set every hinge target (actions, then one batch step of the brains); step the world.

        Actuator noise draws robot after robot: the agents in the order of ``actions``, then
        the brain robots in birth order.
        """
        brain, noise, sd = self._brain, self._noise, self.conditions.actuator_noise
        assert brain is not None and noise is not None
        if checked:
            offsets = world.output_offsets
            rows = world.rows([m.handle for m, _ in checked])
            index = np.concatenate([np.arange(offsets[r], offsets[r + 1]) for r in rows.tolist()])
            values = np.concatenate([a for _, a in checked])
            if sd > 0:
                values = values + noise.normal(0.0, sd, values.shape)
            world.set_target_entries(index, values)  # clips to [-1, 1]
        if self._brain_rows.size:
            brain.step(self._living.obs[self._brain_inputs], self._brain_out)
            targets = self._brain_out
            if sd > 0:
                targets = targets + noise.normal(0.0, sd, targets.shape)
            world.set_target_entries(self._brain_targets, targets)
        world.step(1)
        self._steps += 1

    def _report(self, world: World) -> Dicts:
        """The five dicts after the physics: every robot sensed at once, then the dicts."""
        living, masks = self._living, self._spaces.masks
        obs: dict[str, NDArray[np.float64]] = {}
        rewards: dict[str, float] = {}
        terminations: dict[str, bool] = {}
        truncations: dict[str, bool] = {}
        infos: dict[str, dict[str, Any]] = {}
        for member, death in self._dead:  # removed since the last step: one last report
            final = member.final
            obs[member.agent] = final.view.copy()
            rewards[member.agent] = 0.0
            terminations[member.agent] = True
            truncations[member.agent] = False
            infos[member.agent] = final_info(member, self._life, death, masks[member.agent])
        self._dead = []
        truncate = self.max_steps is not None and self._steps >= self.max_steps
        blown = world.blown_up if world.any_blown_up else None
        previous = living.f.copy()
        assert self._noise is not None
        living.sense(world, self.time, self._noise, self.conditions.sensor_noise, blown)
        agents = self.agents
        deaths: list[str | None] = [None] * len(agents)
        if blown is not None:
            for row in np.flatnonzero(blown).tolist():
                member = living.members[row]
                member.blow_up = world.blow_up(member.handle)
                deaths[row] = "blow_up"
        obs.update(zip(agents, living.views(), strict=True))
        rewards.update(zip(agents, (living.f - previous).tolist(), strict=True))
        ended = blown.tolist() if blown is not None else [False] * len(agents)
        terminations.update(zip(agents, ended, strict=True))
        truncations.update(zip(agents, [truncate and not e for e in ended], strict=True))
        infos.update(zip(agents, living.infos(masks, deaths), strict=True))
        if blown is not None:
            for row in reversed(np.flatnonzero(blown).tolist()):
                self._drop(living.members[row])
        if truncate:
            for agent in list(self.agents):
                self._drop(self._members[agent])
        return obs, rewards, terminations, truncations, infos

    def render(self) -> NDArray[np.uint8] | None:
        """An RGB image ``(height, width, 3)`` of the whole arena (``render_mode="rgb_array"``).

        The camera frames every living robot (the birth disc when there is none): straight down for
        ``render_view="top"``, obliquely for ``"chase"``. Robots are drawn in their parts' colours.
        """
        if self.render_mode is None or self._world is None:
            return None
        return self.render_frame(self.render_view)

    def render_frame(self, view: Literal["top", "chase"] = "top") -> NDArray[np.uint8]:
        """An RGB image of the whole arena from ``view``, whatever the render mode."""
        world = self.world
        width, height = self.render_size
        members = [self._members[a] for a in self.agents]
        if members:
            xy = world.core_positions([m.handle for m in members])[:, :2]
            reach = np.array([[m.radius] for m in members]) + 0.2  # footprint and a margin
            lo, hi = (xy - reach).min(axis=0), (xy + reach).max(axis=0)
        else:
            lo, hi = np.full(2, -self.birth_radius), np.full(2, self.birth_radius)
        centre = (lo + hi) / 2
        half = np.maximum((hi - lo) / 2, 0.5)
        # fov 60 deg vertically: fit the larger of the vertical and the aspect-corrected extents
        extent = max(half[1], half[0] * height / width)
        distance = extent / math.tan(math.radians(30.0))
        target = (float(centre[0]), float(centre[1]), 0.0)
        if view == "top":
            return world.render(width, height, target=target, distance=distance, yaw_deg=0.0,
                                pitch_deg=-89.9)
        if view == "chase":
            return world.render(width, height, target=target, distance=1.3 * distance,
                                yaw_deg=30.0, pitch_deg=-40.0)
        raise ValueError(f"view must be 'top' or 'chase', got {view!r}")

    def close(self) -> None:
        """Release the physics client (the env can be reset again)."""
        if self._world is not None:
            self._world.close()
            self._world = None
        self._brain = None
        self.agents = []
        self._members = {}
        self._living.clear()

    # -- snapshots -------------------------------------------------------------------------------
    @property
    def exact_restore(self) -> bool:
        """Whether :meth:`restore` continues a :meth:`snapshot` bit for bit.

        True when the world's engine allows it: MuJoCo, not pybullet.
        """
        return self.world.exact_restore

    def snapshot(self) -> dict[str, Any]:
        """Everything an exact continuation of this episode needs, as plain data.

        The world (:meth:`World.snapshot`), the generator, the counters, every living robot's
        bookkeeping (fitness window, age, trajectory, observation, controller state and time),
        the robots removed since the last step (reported by the next one) and the masks and
        spaces of every agent born in this episode. :meth:`restore` on an env made with the same
        arguments continues exactly, on an engine whose :attr:`exact_restore` holds.

        Raises:
            RuntimeError: before ``reset``.
            NotImplementedError: the engine cannot restore its state exactly (pybullet).
        """
        world = self.world
        brain = self._brain
        assert brain is not None
        return {
            "world": world.snapshot(),
            "rng": dict(self.np_random.bit_generator.state),
            "rng_seed": self._np_random_seed,
            "noise_rng": None if self._noise is None else dict(self._noise.bit_generator.state),
            "births": self._births, "steps": self._steps,
            "members": [member_snapshot(m, self._living.final(row), brain, with_robot=False)
                        for row, m in enumerate(self._living.members)],
            "dead": [(member_snapshot(m, m.final, None, with_robot=True), death)
                     for m, death in self._dead],
            **self._spaces.snapshot(),
        }

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Continue the episode a :meth:`snapshot` was taken of, in a fresh world.

        The env must have been made with the same arguments as the one the snapshot was taken
        of. Whatever this env held is replaced.

        Raises:
            SnapshotMismatchError: the snapshot does not fit (another engine, damaged data, a
                scene that cannot be rebuilt exactly); the env must be ``reset`` then.
            NotImplementedError: the engine cannot restore its state exactly (pybullet).
        """
        if self._world is not None:
            self._world.close()
        self._world = None
        self._brain = None
        self.agents, self._members, self._dead = [], {}, []
        self._living.clear()
        restored = read_snapshot(snapshot, self.config, self._life)
        self._world, self._brain = restored.world, restored.brain
        self._np_random, self._np_random_seed = restored.rng, snapshot["rng_seed"]
        self._noise = restored.noise if restored.noise is not None else \
            noise_generator(self._np_random_seed)  # a snapshot from before noise existed
        self._births, self._steps = restored.births, restored.steps
        self._members = {m.agent: m for m in restored.members}
        self.agents = [m.agent for m in restored.members]
        self._dead = restored.dead
        self._spaces.restore(restored.masks, restored.spaces, restored.uniform)
        try:
            self._living.restore(restored.members, restored.rows)
        except (KeyError, TypeError, ValueError) as e:
            self.close()
            raise SnapshotMismatchError(f"damaged population snapshot: {e!r}") from e
        self._relayout_brains()

    # -- births and deaths -----------------------------------------------------------------------
    def add_robot(
        self,
        robot: Robot,
        position: tuple[float, float] | None = None,
        *,
        controlled_by: Controller = "brain",
        yaw: float | None = None,
    ) -> str:
        """Drop a robot into the world (between steps); returns its new agent id.

        Args:
            robot: A valid robot (checked with ``revolve_env.body.validate``); a brain-controlled
                robot's network must be valid with one input neuron per sensor value.
            position: Core ``(x, y)``. Metres; None draws a free position within
                ``birth_radius`` of the origin.
            controlled_by: ``"brain"`` (its own network) or ``"agent"`` (actions from ``step``).
            yaw: Heading. Radians; None: ``conditions.heading`` (random: drawn uniformly).

        Raises:
            ValueError: invalid robot or network, a position (after the jitter of
                ``conditions``) overlapping a living robot, or ``max_births`` reached. Nothing
                changes then.
        """
        world, brain = self._world, self._brain
        if world is None or brain is None:
            raise RuntimeError("call reset() before add_robot()")
        agent = f"robot_{self._births}"
        if self._births >= self.max_births:
            raise ValueError(f"cannot add a robot: max_births={self.max_births} births already "
                             "happened in this episode (raise max_births)")
        spec, low, high = check_birth(agent, robot, position, controlled_by, yaw, self.limits)
        radius = footprint_radius(robot)
        xy, inside = self._birth_position(agent, position, radius)
        heading = self._heading(yaw)

        # All checks passed: from here on nothing can fail on bad input.
        n_outputs = len(robot.neurons_of(Layer.OUTPUT))
        padded = self._spaces.is_padded(agent)
        handle = world.add_robot(robot, xy, heading)
        member = Member(
            agent=agent, robot=robot, controlled_by=controlled_by, handle=handle,
            brain=brain.add(spec) if spec is not None else None, birth_step=self._steps,
            birth_time=self._steps * self._life.dt, birth_position=xy, born_inside=inside,
            yaw=heading, radius=radius, n_outputs=n_outputs, padded=padded, sensor_low=low,
            sensor_high=high,
        )
        assert self._noise is not None
        obs = member.sense(world.read_sensors(handle), self.conditions.sensor_noise, self._noise)
        self._births += 1
        self._members[agent] = member
        self.agents.append(agent)
        self._spaces.register(agent, low, high, n_outputs, padded)
        living = self._living
        living.add(member, obs, world.core_position(handle), world)
        row = len(living) - 1
        living.trajectories.append(np.array([row]), living.position[row:row + 1])
        if self._life.insertion_steps == 0:
            living.first_sample(row, self.time)
        self._relayout_brains()
        return agent

    def _birth_position(self, agent: str, position: tuple[float, float] | None,
                        radius: float) -> tuple[tuple[float, float], bool]:
        """Where a newborn goes, and whether inside the birth disc (ValueError on an overlap)."""
        if position is None:
            placement = place(self._discs(), radius, self.birth_radius, self.birth_clearance,
                              self.np_random, self.max_placement_tries)
            return placement.position, placement.inside
        xy = (float(position[0]), float(position[1]))
        if not (math.isfinite(xy[0]) and math.isfinite(xy[1])):
            raise ValueError(f"add_robot ({agent}): position must be finite, got {position!r}")
        rng = self.np_random
        before = rng.bit_generator.state
        xy = jittered(xy, self.conditions.position_jitter, rng)
        clash = self._clash(xy, radius)
        if clash is not None:
            rng.bit_generator.state = before  # a refused birth changes nothing
            raise ValueError(f"add_robot ({agent}): position {xy} overlaps {clash}: a robot "
                             f"of footprint radius {radius:.3f} m needs "
                             f"{self.birth_clearance} m clearance")
        return xy, True

    def _heading(self, yaw: float | None) -> float:
        """A newborn's heading: ``yaw``, or the conditions' (drawn when random). Radians."""
        if yaw is not None:
            return float(yaw)
        if self.conditions.random_heading:
            return float(self.np_random.uniform(0.0, 2.0 * math.pi))
        return float(self.conditions.heading)

    def remove_robot(self, agent: str) -> None:
        """Take a living robot out of the world (between steps); its bodies are deleted at once.

        The next :meth:`step` reports it one last time, terminated, with ``death="removed"``.

        Raises:
            KeyError: the agent is unknown, not yet born, or already dead.
        """
        member = self._member(agent, "remove_robot")
        self._drop(member)
        self._dead.append((member, "removed"))

    def _drop(self, member: Member) -> None:
        """Take a robot out of the world and the arrays; keep its last state for its report."""
        assert self._world is not None and self._brain is not None
        living = self._living
        row = self.agents.index(member.agent)
        member.final = living.final(row)
        self._world.remove_robot(member.handle)
        del self._members[member.agent]
        self.agents.remove(member.agent)
        living.remove(row, self._world)
        if member.brain is not None:
            self._brain.remove(member.brain)
        self._relayout_brains()

    def _relayout_brains(self) -> None:
        """Where every brain robot's inputs come from and its outputs go (after a change)."""
        assert self._brain is not None
        brain = self._brain
        rows = [row for row, m in enumerate(self._living.members) if m.brain is not None]
        self._brain_rows = np.array(rows, dtype=np.intp)
        self._brain_inputs = self._living.brain_inputs(self._brain_rows)
        if self._world is not None and rows:
            offsets = self._world.output_offsets
            self._brain_targets = np.concatenate([np.arange(offsets[r], offsets[r + 1])
                                                  for r in rows])
        else:
            self._brain_targets = np.zeros(0, dtype=np.intp)
        self._brain_out = np.zeros(brain.n_outputs)

    def _discs(self) -> list[Disc]:
        """The living robots' footprints (in agent order)."""
        if not self._members:
            return []
        assert self._world is not None
        members = list(self._members.values())
        centres = self._world.core_positions([m.handle for m in members])
        return [Disc(float(c[0]), float(c[1]), m.radius) for c, m in zip(centres, members,
                                                                          strict=True)]

    def _clash(self, xy: tuple[float, float], radius: float) -> str | None:
        """The first living robot whose footprint is too close to a disc at ``xy``, else None."""
        k = clash(self._discs(), xy, radius, self.birth_clearance)
        return None if k is None else list(self._members)[k]

def population_env(**kwargs: Any) -> PopulationEnv:
    """Make a :class:`PopulationEnv` (keyword arguments as documented there)."""
    return PopulationEnv(**kwargs)

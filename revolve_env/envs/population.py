"""Online population: a PettingZoo parallel env whose robots are born and die in one world.

All robots live in ONE :class:`~revolve_env.world.World` (an infinite flat plane; robots collide
with each other). Robots are added and removed between steps by the caller (online evolution, a
test harness, a learner) or inside a step (``lifecycle``); each is one PettingZoo agent.

Along its seams: :class:`PopulationEnv` is PettingZoo's shell (arguments, spaces, ``reset``,
``step``, names); rewards are the task's (:mod:`revolve_env.tasks`); robots by id, world, brains,
births, deaths and the physics step are :class:`~revolve_env.envs.roster.Roster`, per-step arrays
:class:`~revolve_env.envs.living.Living`; births are planned by :mod:`~revolve_env.envs.births`
and :mod:`~revolve_env.envs.placement`; the five dicts are built from typed statuses by
:mod:`~revolve_env.envs.reports`; spaces :mod:`~revolve_env.envs.agent_spaces`; snapshots
:mod:`~revolve_env.envs.population_snapshot`.

## Robots and agents
A robot has one id, an int (:mod:`revolve_env.status`); its agent name is ``robot_<id>``. Ids
count births since ``reset`` from 0 unless the caller gives its own (``add_robot(...,
robot_id=k)``: an experiment gives its birth index, so the id is the one in its results).
Ids are never reused, only grow, and a dead agent never comes back; ``possible_agents`` is the
pool ``robot_0 .. robot_<max_births - 1>``. Robots enter through :meth:`PopulationEnv.add_robot`
(or ``reset``'s initial robots) and leave through :meth:`PopulationEnv.remove_robot` or a
physics blow-up:

``agents`` changes only in ``step`` and ``reset`` (PettingZoo's convention): it is the robots
the last of them reported alive, so ``{a: policy(obs[a]) for a in env.agents}`` always finds an
observation, and converters (``parallel_to_aec``) and wrappers see every change in a step.

* A robot added between two steps is in the world at once (placed, and simulated in the next
  step: its brain drives it, or its targets stay 0 until it gets an action) and enters
  ``agents`` in the next ``step``, which reports it in all five dicts with its first
  observation; an action may be given to it there (its id is known), none is needed.
  :meth:`PopulationEnv.observe` and :attr:`PopulationEnv.robot_ids` see it at once.
* A robot removed between two steps leaves the world at once and ``agents`` in the next
  ``step``, which reports it one last time with ``terminations[agent] = True`` and
  ``infos[agent]["death"] = "removed"`` (an action given to it there is checked and dropped);
  then it disappears. One removed before any step reported it is never reported.
* A robot whose simulation blows up is removed at the end of the step that saw it, reported in
  that step with ``terminations[agent] = True``, ``infos[agent]["death"] = "blow_up"`` and the
  reason in ``infos[agent]["blow_up"]``.

With ``max_cycles`` set (PettingZoo's name; ``max_steps`` is its deprecated alias), step
``max_cycles`` truncates every living robot and leaves ``agents`` empty: the episode has ended
and a further ``step`` is refused (RuntimeError) until ``reset``; ``lifecycle`` is not called
in that last step (a robot born there would be truncated at birth). By default the episode
never ends on its own. Every robot's typed status
(:class:`~revolve_env.status.RobotStatus`) is :meth:`PopulationEnv.status`; those the last step
reported are :attr:`PopulationEnv.statuses`; the infos are made from them.

## Births and deaths inside a step
``lifecycle(env, k)``, if given, is called inside step ``k`` (counting from 1 after ``reset``)
once the actions are checked and before the physics. It may call ``add_robot`` and
``remove_robot``: a robot it adds is simulated and reported in step ``k``; a robot it removes is
reported in step ``k`` as removed (unless it was added in that step too: then it is never
reported) and its action, given for that step, is dropped. This is how PettingZoo's own
``generated_agents_parallel_v0`` makes agents; births and deaths between two steps reach
converters and wrappers as well, since ``agents`` changes only in ``step``. An error raised by
``lifecycle`` propagates; the robots it added or removed before raising stay added or removed,
nothing else changed.

## Control
``controlled_by="brain"``: the robot's own network drives its hinges (every brain in one call
of the compiled :class:`~revolve_env.brain.BatchController`, fed with its previous sensor
values); its action, if given, is checked and ignored. ``controlled_by="agent"``: its action
drives them; one missing from ``actions`` keeps its previous targets (0 at birth).

## Spaces: exact or uniform
Every agent of ``possible_agents`` has an observation and an action space at any time, born or
not, and ``observation_space(agent)`` / ``action_space(agent)`` return the same object on every
call, until it is dead: its exact spaces and masks are released when the step after the one
that reported its death starts (or at the next step, for a robot removed before any step
reported it), and asking for them then is a KeyError naming it dead; so a long episode holds
the spaces of its living robots only. Uniform spaces, once handed out, stay.

* ``space_mode="uniform"``: every agent has spaces of the same shape, sized by ``limits``
  (Table 1: 10 inputs, 10 outputs; hidden neurons are not observed), created on first request
  and kept for the env's lifetime. A robot's values fill the first entries of each block and
  the rest is padding (0 in observations, ignored in actions). Which entries are real is given
  by ``observation_mask`` and ``action_mask`` and in ``infos[agent]["obs_mask"]`` and
  ``["act_mask"]`` (read-only bool arrays; not ``"action_mask"``, which PettingZoo's samplers
  would pass to ``Box.sample``). One shared policy can drive robots of any body this way.
* ``space_mode="exact"`` (default): a robot gets spaces of its own body's sizes at its birth,
  for that episode (agent ids restart at ``robot_0`` after ``reset``). A future agent's body
  is unknown, so an agent whose spaces are requested before its birth (PettingZoo's
  converters and wrapper libraries walk ``possible_agents``) gets the uniform spaces instead,
  keeps them for the env's lifetime, and is observed and driven as in uniform mode.

Sensors are in traversal order (the robot's input neuron order); the core comes first, so the
first six values are always its IMU. Uniform observations saturate the IMU at its full scale
(16 g, 2000 deg/s, as :class:`~revolve_env.envs.locomotion.LocomotionEnv` does) so that the
bounds are finite; exact ones keep the raw readings. Hinge angles saturate at +-pi and
velocities at ``world_config.max_angular_speed`` (faster is a blow-up). A robot's own network
reads its raw sensor values only, never the hinge values. The observation of a robot whose
simulation blew up is all zeros.

## Rewards
The task (``task=``, :mod:`revolve_env.tasks`; default :class:`~revolve_env.tasks.Locomotion`,
``f = v + 5 s``) scores every robot's sliding window of ``fitness_window`` seconds
(:class:`~revolve_env.fitness.FitnessWindows`) of core positions sampled after the insertion
phase (the first ``insertion_time`` seconds of its life, scored 0), and gives each step's
reward: for the shipped tasks ``reward = fitness(t) - fitness(t - control_period)``. On a
blow-up the fitness is set to 0 (with the shipped tasks that step's reward is minus the fitness
so far). A removed robot's last reward is 0.

## Birth placement and conditions
A newborn is placed by :func:`revolve_env.envs.placement.place` (the online engine's rule too),
or at a given position; its heading, position jitter and noise follow ``conditions``
(:class:`~revolve_env.conditions.EvaluationConditions`, default :data:`ONLINE_CONDITIONS`:
random heading, no jitter, no noise). Every newborn's active hinges start at angles and speeds
drawn uniformly from ``[-reset_noise_scale, reset_noise_scale]`` (radians, radians per second;
Gymnasium's convention), from the env's generator seeded by ``reset(seed=...)``: by default 0.1
(:data:`~revolve_env.conditions.DEFAULT_RESET_NOISE_SCALE`), so seeds give different episodes;
given ``conditions`` (an experiment's) keep their own (0 unless set: the paper's start);
``reset_noise_scale=0`` starts every hinge at rest at 0. The rules in full:
``docs/population-env.md``.

## Reset
``reset(seed, options)`` builds a fresh world and adds ``options["robots"]``, else
``initial_robots``, else one of each example robot (brain-controlled, at random free places):
each a ``Robot`` or a mapping with keys ``robot`` and optional ``position``, ``controlled_by``,
``yaw``. Other option keys are ignored (PettingZoo's API test passes arbitrary ones).

## Arguments (of :class:`PopulationEnv` and :func:`population_env`)
``PopulationEnv(initial_robots=None, setting=None, options=None, *, render_mode=None,
**keywords)``: ``setting`` (a :class:`~revolve_env.setting.Setting`) is where and how robots
are simulated (world: engine, terrain, timings; task; conditions; insertion and fitness window),
``options`` (a :class:`PopulationOptions`) the env's own options; the keywords are a thin
convenience that changes one part of either (the env's defaults where neither is given), so
``PopulationEnv(max_births=50, engine="pybullet")`` still reads as it did. An unknown keyword is
a TypeError.

| Keyword             | Default  | Meaning                                                     |
|---------------------|----------|-------------------------------------------------------------|
| initial_robots      | None     | robots added by ``reset`` (see Reset)                       |
| setting             | None     | a :class:`~revolve_env.setting.Setting`: world (engine,     |
|                     |          | terrain, timings), task, conditions, insertion and fitness  |
|                     |          | window at once; a keyword below given beside it changes     |
|                     |          | that part (its conditions keep their reset noise, 0)        |
| options             | None     | a :class:`PopulationOptions`: the options marked (o) below  |
|                     |          | at once; a keyword given beside it changes that option      |
| render_mode         | None     | "rgb_array"                                                 |
| max_births (o)      | 1000     | size of ``possible_agents``: the ids 0 .. max_births - 1    |
| render_view (o)     | "top"    | "top" (straight down) or "chase" (oblique), whole arena     |
| render_size (o)     | (480, 360) | image width and height. Pixels                            |
| maturity_age (o)    | 15.0     | age from which ``is_mature`` holds. Seconds                 |
| birth_radius (o)    | 2.0      | random births lie within this distance of the origin. m     |
| birth_clearance (o) | 0.02     | gap kept between footprints at birth. Metres                |
| max_placement_tries (o) | 200  | random draws in the birth disc before placing outside it    |
| trajectory_stride (o) | 1      | control periods between trajectory samples                  |
| trajectory_length (o) | None   | samples of its trajectory kept per robot, its latest (0:    |
|                     |          | none); None: its whole life (memory grows with its age)     |
| max_cycles (o)      | None     | truncate every robot after this many steps (None: never)    |
| limits (o)          | None     | validation limits (:class:`~revolve_env.body.Limits`)       |
|                     |          | and the sizes of the uniform spaces (None: Table 1)         |
| space_mode (o)      | "exact"  | "exact" or "uniform" (see Spaces)                           |
| proprioception (o)  | False    | observe hinge angles and velocities                         |
| lifecycle (o)       | None     | births and deaths inside a step (see the module doc)        |
| reset_noise_scale (o) | None   | half-width of the uniform noise on newborns' hinge start    |
|                     |          | angles (rad) and speeds (rad/s); None: the conditions'      |
|                     |          | when given, else 0.1; 0: at rest (see Birth placement)      |
| max_steps           | None     | deprecated name of ``max_cycles``                           |
| insertion_time      | None     | not scored after birth. Seconds; None: the setting's, 3.0   |
| fitness_window      | None     | sliding window of the fitness. Seconds; None: the setting's |
|                     |          | ``seconds``, 12.0                                           |
| control_period      | None     | time per env step. Seconds (a multiple of the timestep);    |
|                     |          | None: world_config's (1/60 s by default)                    |
| world_config        | None     | a :class:`~revolve_env.world.WorldConfig` (physics)         |
| engine              | None     | "mujoco" or "pybullet"; None: world_config's (mujoco)       |
| conditions          | None     | heading, jitter and noise of newborns (see Conditions);     |
|                     |          | None: :data:`ONLINE_CONDITIONS` with reset noise 0.1        |
| task                | None     | what robots are rewarded for (:func:`~revolve_env.tasks.    |
|                     |          | make_task`: a task, a name, a table); None: Locomotion      |
| terrain             | None     | "flat", "rugged", "crater", "bowl", a table; None: flat     |
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Literal, Unpack

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from numpy.typing import ArrayLike, NDArray
from pettingzoo import ParallelEnv

from revolve_env.body.robot import Robot
from revolve_env.conditions import EvaluationConditions, with_reset_noise
from revolve_env.envs.agent_spaces import AgentSpaces, SpaceMode
from revolve_env.envs.arena import arena_frame, arena_pixels
from revolve_env.envs.arguments import (
    PopulationKeywords,
    PopulationOptions,
    check_arguments,
    max_cycles_of,
    split_keywords,
    world_config_of,
)
from revolve_env.envs.births import BirthRules, initial_births, next_robot_id, plan_birth
from revolve_env.envs.living import Living
from revolve_env.envs.members import Controller, LifeClock, Member, sensor_bounds
from revolve_env.envs.placement import footprint_radius
from revolve_env.envs.reports import Dicts, StepStatuses, end_step, report_step, status_info
from revolve_env.envs.roster import Roster
from revolve_env.fitness import DEFAULT_WINDOW
from revolve_env.setting import Setting, env_parts
from revolve_env.status import RobotStatus, agent_name
from revolve_env.tasks import make_task
from revolve_env.world import World

__all__ = ["ONLINE_CONDITIONS", "Controller", "Lifecycle", "PopulationEnv", "PopulationKeywords",
           "PopulationOptions", "SpaceMode", "footprint_radius", "population_env", "sensor_bounds"]

ONLINE_CONDITIONS = EvaluationConditions(heading="random")
"""The population env's default conditions: random headings, no jitter, no noise (as always)."""

Lifecycle = Callable[["PopulationEnv", int], None]
"""Called as ``lifecycle(env, k)`` inside step ``k`` (1, 2, ... since reset), before the physics;
it may add and remove robots (see the module doc, Births and deaths inside a step)."""


# pettingzoo ships no type information (no py.typed), so mypy sees ParallelEnv as Any.
class PopulationEnv(ParallelEnv[str, NDArray[np.float64], NDArray[np.float32]]):  # type: ignore[misc]
    """A changing population of RoboGen robots in one world; reward is each robot's task gain.

    Agents, births and deaths, control, spaces, rewards, placement, conditions and reset are
    documented in the module doc (with the keyword arguments); the tables of a step are here.

    ## The five dicts of a step
    Keys: every agent alive before the step or born before the physics of the step (between
    steps or by ``lifecycle``), plus every agent removed since the last step. Per agent:

    | Dict         | Born (first report)          | Removed              | Blown up in this step  |
    |--------------|------------------------------|----------------------|------------------------|
    | observations | its observation after it     | its last observation | zeros                  |
    | rewards      | fitness gain (0 inserting)   | 0.0                  | minus its fitness      |
    | terminations | False (True if it blew up)   | True                 | True                   |
    | truncations  | True only at ``max_cycles``  | False                | False                  |
    | infos        | ``age`` = one control period | ``death="removed"``, | ``death="blow_up"``,   |
    |              | ``death=None``, its masks    | its last state       | reason in ``blow_up``  |

    A living robot that is neither born nor dying is reported like the first column with its own
    age. An agent is reported one last time in the step of its death, then never again.

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

    ## Info (per agent)
    The robot's :class:`~revolve_env.status.RobotStatus` under these names, and its masks:

    | Key            | Meaning                                                               |
    |----------------|-----------------------------------------------------------------------|
    | robot_id       | its id (the agent is ``robot_<robot_id>``)                            |
    | age            | seconds since birth                                                   |
    | birth_time     | simulated time of birth. Seconds                                      |
    | birth_position | core ``(x, y)`` where the robot was placed. Metres                    |
    | born_inside_disc | False when a crowded birth disc put it outside (see placement)      |
    | inserting      | ``age < insertion_time`` (the fitness is not yet sampled)             |
    | is_mature      | ``age >= maturity_age``                                               |
    | fitness        | the task's over the window (``v + 5 s`` by default, metres)           |
    | fitness_v      | horizontal path length over the window. Metres                        |
    | fitness_s      | straight horizontal displacement over the window. Metres              |
    | position       | core centre ``(x, y, z)``. Metres (a copy)                            |
    | trajectory     | ``(T, 3)`` read-only core positions, one per ``trajectory_stride``     |
    |                | control periods since birth (birth position first; the latest         |
    |                | ``trajectory_length`` only, if set). Metres                           |
    | controlled_by  | ``"brain"`` or ``"agent"``                                            |
    | blow_up        | reason string, or None                                                |
    | death          | None while alive; ``"removed"`` or ``"blow_up"`` in the last report   |
    | obs_mask       | bool per observation entry: True where it holds the robot's value     |
    | act_mask       | bool per action entry: True where it drives one of the robot's hinges |

    The keyword arguments are in the module doc's table (Arguments).

    Bad input raises before anything changes, naming the agent: an action for an agent neither
    alive nor removed since the last step (never born, dead) is a ``KeyError``; an action of the
    wrong shape (the uniform shape in uniform mode) or with NaN or infinity is a ``ValueError``.
    """

    metadata: dict[str, Any] = {  # noqa: RUF012 (PettingZoo's convention; copied per instance)
        "render_modes": ["rgb_array"], "name": "revolve_population_v0", "render_fps": 60,
        "is_parallelizable": True,
    }

    def __init__(
        self,
        initial_robots: Sequence[Robot | Mapping[str, Any]] | None = None,
        setting: Setting | None = None,
        options: PopulationOptions | None = None,
        *,
        render_mode: Literal["rgb_array"] | None = None,
        **keywords: Unpack[PopulationKeywords],
    ) -> None:
        """Make the env (the arguments: the module doc's table).

        Args:
            initial_robots: Robots added by ``reset`` (see Reset).
            setting: Where and how robots are simulated (world, task, conditions, insertion,
                fitness window); None: the env's defaults.
            options: The env's own options (:class:`PopulationOptions`); None: the defaults.
            render_mode: ``"rgb_array"`` or None.
            **keywords: Options or parts of the setting, changed (the table's keywords).

        Raises:
            TypeError: an unknown keyword, or an argument of the wrong type.
            ValueError: a bad value (named).
        """
        option_keywords, rest = split_keywords(keywords, type(self).__name__)
        max_steps = rest.pop("max_steps", None)
        if max_steps is not None:  # the deprecated name (a DeprecationWarning)
            option_keywords["max_cycles"] = max_cycles_of(option_keywords.get("max_cycles"),
                                                          max_steps)
        base = options if options is not None else PopulationOptions()
        if not isinstance(base, PopulationOptions):
            raise TypeError(f"options must be a PopulationOptions, got {type(base).__name__}")
        self.options = opts = dataclasses.replace(base, **option_keywords)
        conditions: EvaluationConditions | None = rest.get("conditions")
        given = conditions is not None or setting is not None
        world_config, task, conditions = env_parts(setting, rest.get("world_config"),
                                                   rest.get("task"), conditions)
        insertion_time: float | None = rest.get("insertion_time")
        if insertion_time is None:
            insertion_time = 3.0 if setting is None else setting.insertion
        fitness_window: float | None = rest.get("fitness_window")
        if fitness_window is None:
            fitness_window = DEFAULT_WINDOW if setting is None else setting.seconds
        conditions = conditions if conditions is not None else ONLINE_CONDITIONS
        check_arguments(render_mode, insertion_time, fitness_window, conditions)
        conditions = with_reset_noise(conditions, opts.reset_noise_scale, conditions_given=given)
        self.config = config = world_config_of(world_config, rest.get("control_period"),
                                               rest.get("engine"), rest.get("terrain"),
                                               opts.birth_radius)
        self.task, self.max_births = make_task(task), opts.max_births
        self.initial_robots = None if initial_robots is None else list(initial_robots)
        self.render_mode, self.render_view = render_mode, opts.render_view
        self.render_size = (int(opts.render_size[0]), int(opts.render_size[1]))
        self.insertion_time, self.maturity_age = float(insertion_time), float(opts.maturity_age)
        self.birth_radius = float(opts.birth_radius)
        self.birth_clearance = float(opts.birth_clearance)
        self.max_placement_tries, self.trajectory_stride = (opts.max_placement_tries,
                                                            opts.trajectory_stride)
        self.trajectory_length = opts.trajectory_length
        self.fitness_window, self.max_cycles = float(fitness_window), opts.max_cycles
        self.limits = opts.limits
        self.space_mode: SpaceMode = opts.space_mode
        self.proprioception = bool(opts.proprioception)
        self.lifecycle: Lifecycle | None = opts.lifecycle
        self.conditions = conditions
        self.metadata = {**self.metadata, "render_fps": round(1.0 / config.control_period)}
        self._rules = BirthRules(self.birth_radius, self.birth_clearance, opts.max_placement_tries,
                                 conditions, opts.limits, config.terrain)
        self._spaces = AgentSpaces(opts.max_births, opts.space_mode, self.proprioception,
                                   opts.limits, config)
        self.possible_agents: list[str] = self._spaces.possible_agents
        if config.brain_stride != 1:
            raise ValueError(f"brain_period ({config.brain_period} s) other than the control "
                             "period is not supported in the population env (a brain robot's "
                             "held targets would not survive births, deaths and snapshots); "
                             "use it with evaluate or the single-robot env")
        clock = LifeClock.of(config.control_period, self.insertion_time, self.maturity_age)
        living = Living(self.fitness_window, opts.trajectory_stride, clock, self._spaces, self.task,
                        opts.trajectory_length)
        self._roster = Roster(config, clock, living, self._spaces, conditions.actuator_noise,
                              conditions.sensor_noise)
        self._statuses: dict[int, RobotStatus] = {}
        # The last step's statuses, made when first read (most callers read the dicts only).
        self._pending: StepStatuses | None = None
        self._np_random: np.random.Generator | None = None
        self._np_random_seed: int | None = None

    # -- spaces ----------------------------------------------------------------------------
    def observation_space(self, agent: str) -> spaces.Box:
        """The observation space of any agent of ``possible_agents`` (the same object every call).

        Exact or uniform (module doc, Spaces); KeyError for an agent not of ``possible_agents``.
        """
        return self._spaces.observation_space(agent)

    def action_space(self, agent: str) -> spaces.Box:
        """The action space of any agent of ``possible_agents`` (the same object every call)."""
        return self._spaces.action_space(agent)

    def observation_mask(self, agent: str) -> NDArray[np.bool_]:
        """Which entries of the agent's observations carry its values (True, all for exact ones).

        Read-only, from its birth until its spaces are released (module doc, Spaces);
        KeyError naming an agent not yet born, or released.
        """
        return self._spaces.mask(agent, "observation_mask")[0]

    def action_mask(self, agent: str) -> NDArray[np.bool_]:
        """Which entries of the agent's actions drive a hinge (True); the others are ignored."""
        return self._spaces.mask(agent, "action_mask")[1]

    # -- the robots ------------------------------------------------------------------------
    @property
    def agents(self) -> list[str]:
        """The agents the last ``step`` (or ``reset``) reported alive, in birth order.

        PettingZoo's ``agents``: it changes only in ``step`` and ``reset`` (see the module doc,
        Robots and agents); the robots in the world now are :attr:`robot_ids`.
        """
        return self._roster.announced

    @property
    def robot_ids(self) -> list[int]:
        """The robots in the world now (born and not removed), by id, in birth order."""
        return list(self._roster.members)

    @property
    def np_random(self) -> np.random.Generator:
        """The env's generator (birth positions and headings), seeded by ``reset(seed=...)``."""
        if self._np_random is None:
            self._np_random, self._np_random_seed = seeding.np_random()
        return self._np_random

    @property
    def births(self) -> int:
        """Robots born since ``reset``."""
        return self._roster.births

    @property
    def time(self) -> float:
        """Simulated time since reset. Seconds."""
        return self._roster.time

    @property
    def world(self) -> World:
        """The physics world (read-only use: adding or removing robots here breaks the env)."""
        if self._roster.world is None:
            raise RuntimeError("call reset() first")
        return self._roster.world

    @property
    def statuses(self) -> dict[int, RobotStatus]:
        """The status of every robot the last ``step`` (or ``reset``) reported, by robot id.

        After :meth:`advance`: of the robots whose life ended in it.
        """
        if self._pending is not None:
            self._statuses, self._pending = self._pending(), None
        return self._statuses

    def status(self, robot: int | str) -> RobotStatus:
        """The status of a living robot now (its id or agent name); KeyError naming it."""
        member = self._member(robot, "status")
        return self._roster.living.status(self._roster.agents.index(member.agent))

    def agent_info(self, agent: int | str) -> dict[str, Any]:
        """The info of a living robot now (as ``step`` reports it)."""
        status = self.status(agent)
        return status_info(status, self._spaces.masks[agent_name(status.robot_id)])

    def robot(self, robot: int | str) -> Robot:
        """The body and brain of a living robot (its id or agent name)."""
        return self._member(robot, "robot").robot

    def positions(self) -> dict[str, tuple[float, float]]:
        """Core positions ``(x, y)`` of the living robots, in birth order. Metres."""
        if self._roster.world is None:
            return {}
        centres = self._roster.world.states.core_pos.tolist()  # rows: the agents
        return {a: (p[0], p[1]) for a, p in zip(self._roster.agents, centres, strict=True)}

    def observe(self, robot: int | str) -> NDArray[np.float64]:
        """The current observation of a living robot (a copy, in its observation space).

        Made at its birth or after the last step: a robot added between two steps gets its
        first one here. KeyError naming the agent when it is unknown, not yet born, or dead.
        """
        member = self._member(robot, "observe")
        return self._roster.living.view_of(self._roster.agents.index(member.agent))

    def _member(self, robot: int | str, what: str) -> Member:
        return self._roster.member(robot, what)

    # -- PettingZoo API --------------------------------------------------------------------
    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, NDArray[np.float64]], dict[str, dict[str, Any]]]:
        """Start a new episode in a fresh world and add the initial robots (see the module doc)."""
        reseed = seed is not None or self._np_random is None
        if reseed:
            self._np_random, self._np_random_seed = seeding.np_random(seed)
        self._roster.reset(self._np_random_seed, reseed)
        self._spaces.reset()
        for kwargs in initial_births(options, self.initial_robots):
            self.add_robot(**kwargs)
        roster, masks = self._roster, self._spaces.masks
        roster.announced = agents = list(roster.agents)
        statuses = roster.living.statuses()
        self._statuses, self._pending = {s.robot_id: s for s in statuses}, None
        return (dict(zip(agents, roster.living.views(), strict=True)),
                {a: status_info(s, masks[a]) for a, s in zip(agents, statuses, strict=True)})

    def step(self, actions: Mapping[str, ArrayLike]) -> Dicts:
        """Advance every robot one control period (see the class doc for the five dicts).

        Every action is checked before anything changes: KeyError for an agent not alive (never
        born, removed, blown up), ValueError for a wrong shape, NaN or infinity.
        """
        last = self._act(actions, "step")
        dicts, self._pending = report_step(self._roster, self._spaces.masks, last)
        return dicts

    def advance(self, actions: Mapping[str, ArrayLike]) -> dict[int, RobotStatus]:
        """:meth:`step` without the five dicts, for a caller that reads statuses only.

        The same step (the same numbers, births, deaths and snapshots after it), at less
        cost: no observation, reward or info dict is built. The living robots' statuses stay
        at hand (:meth:`status`, :meth:`observe` for a learner's next action).

        Returns:
            The statuses of the lives that ended, by robot id: every robot removed since the
            last step or blown up in this one (with its ``death``), and every robot when the
            episode is truncated (``max_cycles``). :attr:`statuses` holds them too.
        """
        last = self._act(actions, "advance")
        self._statuses, self._pending = end_step(self._roster, last), None
        return self._statuses

    def advance_periods(self, n: int) -> dict[int, RobotStatus]:
        """``n`` calls of :meth:`advance` with no actions, until the first that ends a life.

        The same steps (the same numbers, births, deaths and snapshots after them): where every
        robot is brain-driven, without noise, ``lifecycle`` or ``max_cycles``, on MuJoCo with
        the compiled rollout, many periods run in one compiled call
        (:meth:`Roster.compiled_periods <revolve_env.envs.roster.Roster.compiled_periods>`),
        with Python only at the periods that need it; elsewhere :meth:`advance` runs period by
        period. :attr:`steps` says how far it went.

        Returns:
            What the last :meth:`advance` returned: the statuses of the lives that ended in it
            (empty when ``n`` periods ended none). :attr:`statuses` holds them too.

        Raises:
            ValueError: ``n`` < 1.
        """
        if n < 1:
            raise ValueError(f"advance_periods: n must be >= 1 control period, got {n}")
        roster = self._roster
        if roster.world is None:
            raise RuntimeError("call reset() before advance_periods()")
        left = n
        while left > 0:
            got = (roster.compiled_periods(left)
                   if self.max_cycles is None and self.lifecycle is None else None)
            if got is None:
                statuses = self.advance({})
                left -= 1
            else:
                done, acted = got
                left -= done
                statuses = {}
                self._statuses, self._pending = statuses, None
                if acted:  # a period left to sense, as advance() senses it
                    self._statuses = statuses = end_step(roster, False)
                    left -= 1
            if statuses:
                return statuses
        return {}

    @property
    def steps(self) -> int:
        """Control periods since reset (:attr:`time` is ``steps * config.control_period``)."""
        return self._roster.steps

    def _act(self, actions: Mapping[str, ArrayLike], what: str) -> bool:
        """Check the actions, run the lifecycle, set the targets and step the physics.

        Returns:
            Whether this is the episode's last step (``max_cycles``: every agent truncated).
        """
        roster = self._roster
        if roster.world is None:
            raise RuntimeError(f"call reset() before {what}()")
        if self.max_cycles is not None and roster.steps >= self.max_cycles:
            raise RuntimeError(f"the episode ended after max_cycles={self.max_cycles} steps (every "
                               "agent truncated): call reset()")
        checked = roster.checked_actions(actions)
        roster.release_reported()  # the agents the last step reported dead: no longer asked for
        last = self.max_cycles is not None and roster.steps + 1 >= self.max_cycles
        if self.lifecycle is not None and not last:
            self.lifecycle(self, roster.steps + 1)
            # Robots it removed leave with this step's death report; their actions are dropped.
            checked = [(m, a) for m, a in checked if m.robot_id in roster.members]
        roster.act(checked)
        return last

    def render(self) -> NDArray[np.uint8] | None:
        """An RGB image ``(height, width, 3)`` of the arena from ``render_view`` (rgb_array)."""
        if self.render_mode is None or self._roster.world is None:
            return None
        return self.render_frame(self.render_view)

    def render_frame(self, view: Literal["top", "chase"] = "top") -> NDArray[np.uint8]:
        """An RGB image of the whole arena from ``view``, whatever the render mode."""
        return arena_frame(self.world, list(self._roster.members.values()), self.birth_radius,
                           self.render_size, view)

    def render_pixels(self, view: Literal["top", "chase"] = "top"
                      ) -> dict[int, tuple[float, float]]:
        """Where each living robot's core is in :meth:`render_frame`'s picture: pixels (x, y)."""
        members = list(self._roster.members.values())
        pixels = arena_pixels(self.world, members, self.birth_radius, self.render_size, view)
        return {m.robot_id: (float(x), float(y)) for m, (x, y) in zip(members, pixels,
                                                                      strict=True)}

    def close(self) -> None:
        """Release the physics client (the env can be reset again)."""
        self._roster.close()
        self._statuses, self._pending = {}, None

    # -- snapshots -------------------------------------------------------------------------
    @property
    def exact_restore(self) -> bool:
        """Whether :meth:`restore` continues a :meth:`snapshot` bit for bit (MuJoCo: yes)."""
        return self.world.exact_restore

    def snapshot(self) -> dict[str, Any]:
        """Everything an exact continuation of this episode needs, as plain data.

        The world, generators, counters, robots (living, and removed but not yet reported), and
        the agents' masks and spaces; :meth:`restore` on an env made with the same arguments
        continues exactly where :attr:`exact_restore`.

        Raises:
            RuntimeError: before ``reset``.
            NotImplementedError: the engine cannot restore its state exactly (pybullet).
        """
        self.world  # noqa: B018 - RuntimeError before reset
        return {**self._roster.snapshot(), "rng": dict(self.np_random.bit_generator.state),
                "rng_seed": self._np_random_seed, **self._spaces.snapshot()}

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Continue a :meth:`snapshot` in a fresh world (an env made with the same arguments).

        Whatever this env held is replaced.

        Raises:
            SnapshotMismatchError: the snapshot does not fit (another engine, damaged data, a
                scene that cannot be rebuilt exactly); the env must be ``reset`` then.
            NotImplementedError: the engine cannot restore its state exactly (pybullet).
        """
        self._statuses, self._pending = {}, None
        self._np_random = self._roster.restore(snapshot, snapshot.get("rng_seed"))
        self._np_random_seed = snapshot["rng_seed"]

    # -- births and deaths -----------------------------------------------------------------
    def add_robot(
        self,
        robot: Robot,
        position: tuple[float, float] | None = None,
        *,
        controlled_by: Controller = "brain",
        yaw: float | None = None,
        robot_id: int | None = None,
    ) -> str:
        """Drop a robot into the world (between steps, or inside one through ``lifecycle``).

        Args:
            robot: A valid robot (checked with ``revolve_env.body.validate``); a brain-controlled
                robot's network must be valid with one input neuron per sensor value.
            position: Core ``(x, y)``. Metres; None draws a free position within
                ``birth_radius`` of the origin.
            controlled_by: ``"brain"`` (its own network) or ``"agent"`` (actions from ``step``).
            yaw: Heading. Radians; None: ``conditions.heading`` (random: drawn uniformly).
            robot_id: Its id (e.g. an experiment's birth index); None: one more than the last
                id in this episode (0 first). Ids never repeat and only grow.

        Returns:
            Its agent name, ``robot_<id>``.

        Raises:
            ValueError: invalid robot or network, a position (after the jitter of
                ``conditions``) overlapping a living robot, an id already used or below the
                next one, or one of ``max_births`` or more. Nothing changes then.
        """
        roster = self._roster
        if roster.world is None:
            raise RuntimeError("call reset() before add_robot()")
        rid = next_robot_id(roster.next_id, robot_id, self.max_births)
        discs, names = roster.occupied()
        plan = plan_birth(self._rules, rid, agent_name(rid), robot, position, controlled_by, yaw,
                          discs, names, self.np_random)
        return roster.admit(plan).agent

    def remove_robot(self, robot: int | str) -> None:
        """Take a living robot out of the world (between steps); its bodies are deleted at once.

        It stays in ``agents`` until the next ``step`` reports it one last time, terminated, with
        ``death="removed"`` (an action given to it there is checked and dropped); a robot that no
        step has reported yet (added since the last one) leaves unreported. A KeyError names a
        robot unknown, not yet born, or already removed.
        """
        member = self._member(robot, "remove_robot")
        announced = member.agent in self._roster.announced
        self._roster.drop(member, "removed" if announced else None)
        if not announced:  # never reported: its spaces go at the next step
            self._roster.reported.append(member.agent)


def population_env(**kwargs: Any) -> PopulationEnv:
    """Make a :class:`PopulationEnv` (keyword arguments as documented there)."""
    return PopulationEnv(**kwargs)

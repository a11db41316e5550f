"""One shared PPO policy learns to walk while robots are born and die in one world (issue 12.4).

Parameter sharing over a changing population: the population env runs in ``space_mode="uniform"``
(every body observes and acts through the same padded spaces, with masks) with proprioception,
and :class:`revolve_env.envs.sb3_adapter.PopulationVecEnv` presents it to stable-baselines3 as a
``VecEnv`` of ``--slots`` slots, one per living agent-controlled robot (empty slots observe
zeros and earn 0). A ``BirthsAndDeaths`` lifecycle adds a spider or a gecko (alternately) every
``--birth-every`` steps and removes the oldest robot every ``--death-every`` steps, inside the
env's step; newborns take free slots at once and are driven by the same policy. RLlib is not
installed here, so this is the documented SB3 path of issue 12.

Prints, per PPO iteration (one rollout of ``--n-steps`` per slot, then the update): the mean
reward per robot and simulated second (the rate at which a robot's fitness f = v + 5 s grows,
m/s; 0 during a robot's 0.5 s insertion), the number of robots that lived in the rollout and
how many of them were born after the population episode began. One iteration is one whole
population episode (``--n-steps`` = ``--episode-steps`` = 600 steps, 10 s: the same schedule of
births and deaths every iteration, so iterations compare). At the end it runs the same schedule
once with every robot on its own network (the CPG) for reference, and with ``--figure PNG``
draws the curve with that line. The rewards are those of the stochastic training policy.

By default it runs 10 iterations: about 1 min of CPU (measured on 2026-11-27 under ``nice`` on
this project's loaded 2-core machine: 12 s to start and for the CPG reference, then 4.6 s of CPU
per iteration), with the reward per robot still near its start (0.13 to 0.15 m/s over the
first 4 iterations). The curve of docs/rl.md needs 150 iterations (about 12 min of CPU): 0.13 m/s
per robot at the first iteration, above the CPGs' 0.516 m/s from iteration 62 (298 k
slot-steps, 37 k population steps), 1.18 m/s at iteration 150 (pybullet, seed 0).

Usage::

    python examples/multi_agent_shared_policy.py                 # 10 iterations, ~1 min CPU
    python examples/multi_agent_shared_policy.py --iterations 150 \
        --figure docs/figures/multi_agent_curve.png              # the docs' curve, ~12 min CPU
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.logger import Logger
from stable_baselines3.common.vec_env import VecNormalize

import revolve_env
from revolve_env.envs.checks import BirthsAndDeaths
from revolve_env.envs.sb3_adapter import PopulationVecEnv


class Curve(BaseCallback):
    """Per rollout: mean raw reward per occupied slot-step, and which robots lived in it."""

    def __init__(self, slots: PopulationVecEnv, initial: set[str]) -> None:
        super().__init__()
        self.slots = slots
        self.initial = initial
        self.dt = slots.env.config.control_period
        self.rows: list[dict[str, Any]] = []
        self._start()
        self.t0 = time.perf_counter()

    def _start(self) -> None:
        self.total, self.count = 0.0, 0
        self.robots: set[str] = set()
        self.late_rewarded: set[str] = set()
        self.late_observed: set[str] = set()

    def _on_step(self) -> bool:
        venv = self.training_env
        normalized = isinstance(venv, VecNormalize)
        raw = venv.get_original_reward() if normalized else self.locals["rewards"]
        obs = venv.get_original_obs() if normalized else self.locals["new_obs"]
        for before, r in zip(self.previous, raw, strict=True):
            if before is None:  # an empty slot (or a newborn's first, uncredited step)
                continue
            self.total += float(r)
            self.count += 1
            self.robots.add(before)
            if before not in self.initial and r != 0:
                self.late_rewarded.add(before)
        self.previous = [info["agent"] for info in self.locals["infos"]]
        for agent, o in zip(self.previous, obs, strict=True):
            if agent is not None and agent not in self.initial and np.any(o != 0):
                self.late_observed.add(agent)
        return True

    def _on_rollout_start(self) -> None:
        self.previous = list(self.slots.slot_agents)

    def _on_rollout_end(self) -> None:
        rate = self.total / max(self.count, 1) / self.dt
        late = {a for a in self.robots if a not in self.initial}
        row = {"iteration": len(self.rows) + 1, "steps": self.num_timesteps, "rate": rate,
               "robot_steps": self.count, "robots": len(self.robots), "late_born": len(late),
               "late_rewarded": len(self.late_rewarded), "late_observed": len(self.late_observed),
               "wall": time.perf_counter() - self.t0}
        self.rows.append(row)
        print(f"iter {row['iteration']:3d}  slot-steps {self.num_timesteps:7d}  "
              f"reward/robot/s {rate:7.4f} m/s  robots {row['robots']:3d} "
              f"(late-born {len(late)}, rewarded {len(self.late_rewarded)})  "
              f"wall {row['wall']:6.1f} s", flush=True)
        self._start()


def population(args: argparse.Namespace, controlled_by: str) -> revolve_env.PopulationEnv:
    newborns = ((revolve_env.example("spider"), controlled_by),
                (revolve_env.example("gecko"), controlled_by))
    return revolve_env.population_env(
        space_mode="uniform", proprioception=True, insertion_time=0.5, fitness_window=2.5,
        birth_radius=3.0, max_births=60, max_cycles=args.episode_steps, engine=args.engine,
        lifecycle=BirthsAndDeaths(birth_every=args.birth_every, death_every=args.death_every,
                                  newborns=newborns))


def initial_robots(controlled_by: str) -> list[dict[str, Any]]:
    return [{"robot": revolve_env.example(name), "controlled_by": controlled_by}
            for name in ("spider", "gecko")]


def cpg_baseline(args: argparse.Namespace) -> float:
    """The same births and deaths with every robot on its own network (CPG): reward/robot/s.

    Counted as the adapter credits rewards: from the step after a robot's birth to its death.
    """
    env = population(args, "brain")
    env.reset(seed=args.seed, options={"robots": initial_robots("brain")})
    alive = set(env.agents)
    total, count = 0.0, 0
    for _ in range(args.episode_steps):
        _, rewards, terminations, truncations, _ = env.step({})
        for agent, r in rewards.items():
            if agent in alive:
                total += r
                count += 1
        alive = {a for a in env.agents}
    env.close()
    return total / max(count, 1) / env.config.control_period


def make(args: argparse.Namespace) -> PopulationVecEnv:
    env = population(args, "agent")
    venv = PopulationVecEnv(env, args.slots, reset_options={"robots": initial_robots("agent")})
    venv.seed(args.seed)
    return venv


def run(args: argparse.Namespace) -> list[dict[str, Any]]:
    torch.set_num_threads(1)
    venv = make(args)
    norm = VecNormalize(venv, norm_obs=True, norm_reward=True, clip_obs=10.0, gamma=0.99)
    model = PPO("MlpPolicy", norm, n_steps=args.n_steps, batch_size=256, n_epochs=10,
                learning_rate=3e-4, gamma=0.99, gae_lambda=0.95, seed=args.seed, device="cpu",
                policy_kwargs={"net_arch": [64, 64]}, verbose=0)
    model.set_logger(Logger(folder=None, output_formats=[]))  # SB3's default: an empty tmp folder
    curve = Curve(venv, {"robot_0", "robot_1"})
    model.learn(total_timesteps=args.iterations * args.n_steps * args.slots, callback=curve)
    print(f"population episodes: {venv.resets}, robots left without a slot: {len(venv.unslotted)}")
    norm.close()
    return curve.rows


def plot(rows: list[dict[str, Any]], path: Path, args: argparse.Namespace,
         cpg: float | None = None) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.8))
    ax.plot([r["iteration"] for r in rows], [r["rate"] for r in rows], marker=".",
            label="shared PPO policy (hinge targets, from scratch)")
    if cpg is not None:
        ax.axhline(cpg, color="k", linestyle="--", label=f"robots' own CPGs ({cpg:.3f} m/s)")
    ax.legend(fontsize=8)
    ax.set_xlabel(f"PPO iteration ({args.n_steps} steps x {args.slots} slots)")
    ax.set_ylabel("reward per robot per second (m/s)")
    ax.set_title(f"shared policy, births every {args.birth_every}, deaths every "
                 f"{args.death_every} steps")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--iterations", type=int, default=10,
                        help="PPO iterations (150 for the curve of docs/rl.md)")
    parser.add_argument("--slots", type=int, default=8, help="most robots driven at once")
    parser.add_argument("--n-steps", type=int, default=600, help="rollout length per slot")
    parser.add_argument("--birth-every", type=int, default=60, help="steps between births")
    parser.add_argument("--death-every", type=int, default=90, help="steps between deaths")
    parser.add_argument("--episode-steps", type=int, default=600,
                        help="population episode length (then a fresh world)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--engine", default="pybullet", choices=["pybullet", "mujoco"])
    parser.add_argument("--figure", default="", metavar="PNG",
                        help="also draw the curve into this PNG (default: none; the docs' "
                             "figure: docs/figures/multi_agent_curve.png)")
    args = parser.parse_args()
    rows = run(args)
    cpg = cpg_baseline(args)
    print(f"the same births and deaths on the robots' own CPGs: {cpg:.4f} m/s per robot")
    if args.figure:
        plot(rows, Path(args.figure), args, cpg)


if __name__ == "__main__":
    main()

"""PPO vs the robot's own CPG on ``revolve_env/Locomotion-v1``, over seeds (issue 22, item 5).

Trains stable-baselines3 PPO through :mod:`revolve_env.rl` (the normalised, short-episode vector
env and the PPO settings a user gets in three calls) on each robot (``--robots``, default spider
and gecko), in each action mode (``--modes``) and for each seed (``--seeds``, default 0 1 2):

* ``targets``: the policy sets every hinge's position target (PPO from scratch);
* ``modulate``: the policy scales and offsets the robot's own network's outputs (the zero action
  is the CPG's gait), i.e. learning on top of the CPG.

Every ``--eval-every`` env steps the policy is run deterministically for one episode as long as
a training episode (``--insertion`` + ``--evaluation``; the return is the fitness ``f = v + 5 s``
in metres; no noise, so one episode is exact), with the normalisation statistics frozen
(:func:`revolve_env.rl.policy_fitness`). At 100 k steps and at the end it is also run on the
paper's window (3 s insertion + 12 s evaluation). The CPG's fitness is the robot's own network
alone (``revolve_env.evaluate``) over the same two windows. The table gives per configuration and
seed: the fitness at 100 k steps and at the end in both windows, the CPG's, the first evaluation
from which every later one is above the CPG, and the wall time; then the mean and standard
deviation over the seeds. ``--figure`` plots each seed's curve and the mean, the CPG dashed.

Episode: 0.5 s insertion + 2.5 s evaluation at 60 Hz, 180 steps
(:class:`revolve_env.rl.VecEnvConfig`).

What was tried, and what mattered (pybullet, two shared CPU cores, training under ``nice``; PPO
is deterministic for a seed, so a re-run gives the same curve; read one-seed differences as
indications only):

* Issue 12 (seed 0 only, 200 k steps, 2 envs x 1024 steps per rollout): spider targets 5.74 m
  (CPG 2.21), modulate 4.30; gecko targets 7.91 (CPG 2.02), modulate 3.57. With seed 1 the
  spider (targets) was above its CPG only from 100 k steps.
* Observation normalisation and reward scaling (``VecNormalize``) mattered most: without them
  (``--no-norm``) the spider in targets mode reached 0.32 m at 80 k steps against 3.06 m with
  them. The plain ``PPO("MlpPolicy", env)`` on the paper's 15 s episodes (``--plain``): see the
  results below.
* Rollout length mattered next (spider, targets; fitness at 30 k / 50 k / 70 k / 100 k steps,
  CPG 2.21). A PPO update's gradient steps per sample do not depend on the rollout length
  (``n_epochs / batch_size``), but shorter rollouts update on fresher data four times as often:

  | setting (changes from the row above it, or from 4 x 512)  | seed | 30 k | 50 k | 70 k | 100 k |
  |-----------------------------------------------------------|------|------|------|------|-------|
  | 4 envs x 512 steps per rollout                            | 0    | 0.83 | 2.18 | 2.73 | 2.32  |
  |                                                           | 1    | 0.72 | 1.76 | 2.69 | 3.64  |
  |                                                           | 2    | 0.40 | 2.04 | 2.77 | 3.47  |
  | + initial log std -1 (std 0.37 instead of 1)              | 0    | 0.16 | 0.70 | 1.49 | 1.73  |
  | + learning rate 1e-3 (instead of 3e-4)                    | 0    | 0.39 | 0.98 | 2.02 |       |
  | + 20 epochs (instead of 10)                               | 0    | 0.72 | 1.14 | 2.55 |       |
  | 8 envs x 256 steps                                        | 0    | 0.18 | 0.66 | 0.85 |       |
  | 4 envs x 128 steps (chosen: ``rl.ppo_settings``)          | 0    | 2.34 | 4.01 | 4.34 | 5.33  |
  |                                                           | 1    | 2.07 | 3.10 | 4.25 | 4.80  |
  |                                                           | 2    | 2.14 | 4.95 | 6.12 | 6.02  |
  | 4 envs x 64 steps                                         | 0    | 3.29 | 3.24 | 5.62 |       |

  The gecko (CPG 2.02) at 100 k, seeds 0, 1, 2: 7.79, 6.15, 4.13 with 4 x 512; 7.92, 8.42, 7.83
  with 4 x 128. 64 steps per rollout was not clearly better than 128 (one seed).
* Longer training episodes (4 x 128, 0.5 s + 5.5 s; fitness over 5.5 s, CPG 4.76): seeds 0, 1,
  2 at 100 k: 3.54, 12.82, 10.67; on the paper's 12 s window 5.9, 24.4, 21.1 (CPG 10.20). Two
  seeds walk far better over 12 s than with 2.5 s episodes, but seed 0 stays below its CPG:
  kept at 2.5 s. The deterministic policy's fitness jumps between evaluations (seed 0: 6.91 at
  60 k, 1.84 at 80 k) while the training return rises steadily.
* Proprioception (``Locomotion-v1``), in modulate mode (``--v0`` observes the IMU only;
  fitness at 30 k steps, seeds 0, 1, 2, CPG 2.21): v1 2.91, 2.47, 2.64; v0 2.40, 2.52, 2.37
  (training return 2.0-2.2 against 1.87-1.94). The hinge angles tell the policy the gait's
  phase; the IMU barely does. This is why the SB3 learner takes ``proprioception=True``
  (``examples/infancy_ppo.py``).
* Kept from issue 12: ``gamma`` 0.99 (a horizon of ~1.7 s, a gait cycle), batch 64, 10 epochs,
  learning rate 3e-4, ``net_arch=[64, 64]``, initial std 1 in targets mode and 0.22 in modulate
  mode (the policy starts on the CPG's gait), ``torch.set_num_threads(1)``.
* The paper's 12 s window: a policy trained on 2.5 s episodes keeps walking over 12 s in most
  runs but not all (the s term rewards a straight path; a policy that drifts or stalls after
  3 s was never trained there): see the "12 s" columns of the results.

Results (``--robots spider --steps 100000 --engine mujoco``, seeds 0 1 2; MuJoCo because it
steps the spider 3.7 times as fast as pybullet in targets mode here, 1.9 times in modulate mode:
5,000 against 1,350 and 7,000 against 3,600 env steps per CPU second; wall times on two shared
cores, two runs at once). Fitness of the deterministic policy in the 2.5 s training window at the
100 k evaluation and at the end (100,352 steps), and over the paper's 3 s + 12 s at the end::

    robot   mode     seed  f@100k  f end   CPG above from 12s@100k 12s end CPG 12s   steps wall s
    spider  targets     0   4.541  5.213  2.28       30 k   11.560  10.707   10.21  100352    115
    spider  targets     1   4.856  4.954  2.28       40 k    5.657   4.909   10.21  100352    179
    spider  targets     2   3.681  3.372  2.28       40 k    3.929   7.830   10.21  100352    311
    spider  modulate    0   3.363  3.054  2.28       10 k   14.534  14.092   10.21  100352    117
    spider  modulate    1   3.266  3.103  2.28        0 k   13.168  12.285   10.21  100352    194
    spider  modulate    2   1.915  2.807  2.28      100 k   13.763  13.010   10.21  100352    311

    targets:  f@100k 4.36 +- 0.61 (3.68..4.86); above the CPG at 100 k in 3/3 seeds;
              12 s window at the end 7.82 +- 2.90 (4.91..10.71), CPG 10.21
    modulate: f@100k 2.85 +- 0.81 (1.92..3.36); above the CPG at 100 k in 2/3 seeds (seed 2
              dips to 1.92 at the 100 k evaluation, 3.28 at 80 k, 2.81 at the end);
              12 s window at the end 13.13 +- 0.91 (12.28..14.09), CPG 10.21

The same targets runs on pybullet (the rows "4 envs x 128" above; seeds 1 and 0 re-run after
merging main: seed 1 identical to the last digit, seed 0 up to 80 k, where the earlier run
stopped): 5.33, 4.80, 6.02 at 100 k, 5.38 +- 0.61, above the CPG (2.21) in 3/3
seeds; 12 s window at the end 8.52, 8.20, 17.70 (CPG 10.20); 155-727 s per run on a loaded
machine.

In the training window PPO from scratch (targets) is above the CPG in every seed from 40 k
steps; on top of the CPG (modulate) it is above it at the end in every seed but its
deterministic policy swings between evaluations. Over the paper's 12 s, modulate beats the CPG
in every seed (+29 % on average) while targets does so in one seed of three: a gait learned on
2.5 s episodes from scratch drifts or stalls later.

Usage::

    python benchmarks/bench_rl.py --figure docs/figures/rl_curves.png --json rl.json
    python benchmarks/bench_rl.py --from-json docs/figures/rl_curves.json   # table, no training
    python benchmarks/bench_rl.py --robots spider --modes targets --seeds 1 --steps 100000
    python benchmarks/bench_rl.py --routes --seeds 0 1 2 --steps 100000   # batched vs not

``--routes`` (issue 30's aim: PPO through ``rl.make_vec_env`` in less wall time) trains the same
PPO (``rl.make_ppo``, the first robot and mode, ``--engine`` default MuJoCo here) once per seed
on each route, the sides alternating seed by seed: ``rl.VecEnvConfig(batched=False)``
(``DummyVecEnv`` of ``Monitor``-ed single envs, the route before the native vector env) and the
default ``batched=True`` (:class:`~revolve_env.envs.sb3_vector.NativeVecEnv`). No evaluation
callback: per run it prints the wall and CPU seconds of the whole ``learn``, the part of them
spent stepping the envs (the inner ``VecEnv``'s ``reset`` and ``step_wait``: everything the env
route does, resets and model builds included) and the rest (PPO: the policy's forward passes,
``VecNormalize``, the updates), and the mean training episode return (the fitness gain of
SB3's last 100 episodes, metres) at every quarter of the run and at the end, to judge "the same
learning curve" (the two routes are meant to be the same steps bit for bit).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.logger import Logger
from stable_baselines3.common.vec_env import VecEnv

import revolve_env
from revolve_env import rl
from revolve_env.registration import LOCOMOTION_ID, LOCOMOTION_V1_ID

MILESTONE = 100_000
"""Steps at which the fitness is reported (the issue's aim: above the CPG in every seed)."""


@dataclass
class Curve:
    """One run's learning curve (deterministic-policy fitness vs env steps) and its figures."""

    robot: str
    mode: str
    seed: int
    cpg: float
    cpg_full: float
    steps: list[int] = field(default_factory=list)
    wall: list[float] = field(default_factory=list)
    fitness: list[float] = field(default_factory=list)
    train_return: list[float] = field(default_factory=list)
    full: dict[str, float] = field(default_factory=dict)  # steps -> 12 s window fitness

    def at(self, steps: int) -> float:
        """The fitness of the last evaluation at or before ``steps``."""
        k = int(np.searchsorted(self.steps, steps, side="right")) - 1
        return self.fitness[k] if k >= 0 else float("nan")

    def above_from(self) -> int | None:
        """The first evaluation's steps from which every later one is above the CPG."""
        above = None
        for s, f in zip(self.steps, self.fitness, strict=True):
            above = (s if above is None else above) if f > self.cpg else None
        return above


def cpg_fitness(robot: revolve_env.Robot, insertion: float, evaluation: float,
                engine: str) -> float:
    """The robot's own network alone (``evaluate``) over one window. Metres."""
    return float(revolve_env.evaluate(robot, seconds=evaluation, insertion=insertion,
                                      engine=engine).fitness)


class FitnessCallback(BaseCallback):
    """Every ``every`` steps the short-window fitness; at 100 k and at the end the full one."""

    def __init__(self, curve: Curve, venv: VecEnv, args: argparse.Namespace,
                 start: float) -> None:
        super().__init__()
        self.curve, self.venv, self.args, self.start = curve, venv, args, start
        self.next_at = 0
        self.full_done = False

    def record(self) -> None:
        a, c = self.args, self.curve
        wall = time.perf_counter() - self.start
        fitness = rl.policy_fitness(self.model, self.venv, insertion_time=a.insertion,
                                  evaluation_time=a.evaluation)
        buffer = self.model.ep_info_buffer
        train = float(np.mean([e["r"] for e in buffer])) if buffer else float("nan")
        c.steps.append(self.num_timesteps)
        c.wall.append(wall)
        c.fitness.append(fitness)
        c.train_return.append(train)
        line = (f"  {c.robot:7s} {c.mode:8s} seed {c.seed}  steps {self.num_timesteps:7d}  "
                f"wall {wall:6.1f} s  fitness {fitness:6.3f}  train {train:6.3f}  "
                f"(CPG {c.cpg:.3f})")
        if self.num_timesteps >= MILESTONE and not self.full_done:
            self.full_done = True
            self.record_full(line)
        else:
            print(line, flush=True)

    def record_full(self, line: str) -> None:
        full = rl.policy_fitness(self.model, self.venv)
        self.curve.full[str(self.num_timesteps)] = full
        print(f"{line}  12 s window {full:6.3f} (CPG {self.curve.cpg_full:.3f})", flush=True)

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.next_at:
            self.record()
            self.next_at += self.args.eval_every
        return True

    def _on_training_end(self) -> None:
        if not self.curve.steps or self.curve.steps[-1] != self.num_timesteps:
            self.record()
        if str(self.num_timesteps) not in self.curve.full:
            self.record_full(f"  end at {self.num_timesteps}:")


def train(robot_name: str, mode: str, seed: int, args: argparse.Namespace) -> Curve:
    robot = revolve_env.example(robot_name)
    curve = Curve(robot_name, mode, seed,
                  cpg_fitness(robot, args.insertion, args.evaluation, args.engine),
                  cpg_fitness(robot, 3.0, 12.0, args.engine))
    if args.plain:  # what a user tries first: the paper's 15 s episodes, one env, SB3's PPO
        curve.mode = f"{mode}-plain"
        config = rl.VecEnvConfig(n_envs=1, insertion_time=3.0, evaluation_time=12.0,
                                 normalize=False)
        venv = rl.make_vec_env(robot, config, seed=seed, action=mode, engine=args.engine)
        model: Any = PPO("MlpPolicy", venv, seed=seed, device="cpu", verbose=0)
        model.set_logger(Logger(folder=None, output_formats=[]))
        start = time.perf_counter()
        model.learn(total_timesteps=args.steps,
                    callback=FitnessCallback(curve, venv, args, start))
        venv.close()
        return curve
    config = rl.VecEnvConfig(n_envs=args.n_envs, insertion_time=args.insertion,
                             evaluation_time=args.evaluation, normalize=not args.no_norm,
                             gamma=args.gamma)
    venv = rl.make_vec_env(robot, config, seed=seed, action=mode, engine=args.engine,
                           env_id=LOCOMOTION_ID if args.v0 else LOCOMOTION_V1_ID)
    if args.v0:
        curve.mode = f"{mode}-v0"
    overrides: dict[str, Any] = {}
    for key in ("n_steps", "batch_size", "n_epochs", "learning_rate", "ent_coef", "gae_lambda",
                "clip_range", "target_kl"):
        value = getattr(args, key)
        if value is not None:
            overrides[key] = value
    policy_kwargs = dict(rl.ppo_settings(mode)["policy_kwargs"])
    if args.net is not None:
        policy_kwargs["net_arch"] = args.net
    if args.log_std is not None:
        policy_kwargs["log_std_init"] = args.log_std
    model = rl.make_ppo(venv, seed=seed, policy_kwargs=policy_kwargs, **overrides)
    start = time.perf_counter()
    model.learn(total_timesteps=args.steps, callback=FitnessCallback(curve, venv, args, start))
    venv.close()
    return curve


class _Timed:
    """Wall and CPU seconds spent inside methods ``names`` of ``owner`` (wrapped in place)."""

    def __init__(self, owner: Any, *names: str) -> None:
        self.wall = self.cpu = 0.0
        for name in names:
            setattr(owner, name, self._timed(getattr(owner, name)))

    def _timed(self, method: Any) -> Any:
        def timed(*args: Any, **kwargs: Any) -> Any:
            w, c = time.perf_counter(), time.process_time()
            try:
                return method(*args, **kwargs)
            finally:
                self.wall += time.perf_counter() - w
                self.cpu += time.process_time() - c
        return timed


class _Returns(BaseCallback):
    """The mean return of SB3's episode buffer at given steps (metres)."""

    def __init__(self, marks: list[int]) -> None:
        super().__init__()
        self.marks, self.seen = marks, {}  # type: dict[int, float]

    def _mean(self) -> float:
        buffer = self.model.ep_info_buffer
        return float(np.mean([e["r"] for e in buffer])) if buffer else float("nan")

    def _on_step(self) -> bool:
        for mark in self.marks:
            if mark not in self.seen and self.num_timesteps >= mark:
                self.seen[mark] = self._mean()
        return True

    def _on_training_end(self) -> None:
        self.seen[self.num_timesteps] = self._mean()


def route_run(robot_name: str, mode: str, seed: int, batched: bool,
              args: argparse.Namespace) -> dict[str, Any]:
    """One PPO run through ``rl.make_vec_env`` on one route: times, returns, final weights."""
    config = rl.VecEnvConfig(batched=batched)
    venv = rl.make_vec_env(revolve_env.example(robot_name), config, seed=seed, action=mode,
                           engine=args.engine)
    inner: VecEnv = venv.venv if hasattr(venv, "venv") else venv
    timer = _Timed(inner, "reset", "step_wait")
    model = rl.make_ppo(venv, seed=seed)
    updates = _Timed(model, "train")
    marks = [args.steps * k // 4 for k in (1, 2, 3)]
    returns = _Returns(marks)
    w, c = time.perf_counter(), time.process_time()
    model.learn(total_timesteps=args.steps, callback=returns)
    wall, cpu = time.perf_counter() - w, time.process_time() - c
    venv.close()
    weights = torch.cat([p.detach().flatten() for p in model.policy.parameters()])
    return {"wall": wall, "cpu": cpu, "env_wall": timer.wall, "env_cpu": timer.cpu,
            "update_wall": updates.wall,
            "returns": dict(sorted(returns.seen.items())), "weights": weights}


def routes(args: argparse.Namespace) -> None:
    """``--routes``: PPO's wall time with the native vector env vs ``DummyVecEnv``."""
    robot, mode = args.robots[0], args.modes[0]
    load = os.getloadavg()
    print(f"PPO {args.steps} steps, {robot}, {mode}, {args.engine}, rl.make_vec_env's defaults "
          f"(4 envs, 0.5 + 2.5 s episodes), torch threads {torch.get_num_threads()}; load "
          f"average at the start {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}", flush=True)
    names = {False: "DummyVecEnv", True: "native"}
    runs: dict[tuple[int, bool], dict[str, Any]] = {}
    for seed in args.seeds:
        for batched in (False, True):
            r = runs[seed, batched] = route_run(robot, mode, seed, batched, args)
            curve = ", ".join(f"{k / 1000:g} k {v:.3f}" for k, v in r["returns"].items())
            rest = r["wall"] - r["env_wall"] - r["update_wall"]
            print(f"  seed {seed} {names[batched]:11s}: wall {r['wall']:7.1f} s, CPU "
                  f"{r['cpu']:7.1f} s; env stepping wall {r['env_wall']:6.1f} s (CPU "
                  f"{r['env_cpu']:6.1f} s), PPO's updates {r['update_wall']:6.1f} s, the rest "
                  f"(policy, VecNormalize, buffer) {rest:6.1f} s; mean episode return (m) "
                  f"{curve}", flush=True)
        a, b = runs[seed, False], runs[seed, True]
        a["same"] = bool(torch.equal(a.pop("weights"), b.pop("weights")))
    print(f"load average at the end {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    for seed in args.seeds:
        a, b = runs[seed, False], runs[seed, True]
        print(f"seed {seed}: DummyVecEnv / native wall {a['wall'] / b['wall']:.2f}x, CPU "
              f"{a['cpu'] / b['cpu']:.2f}x, env stepping wall {a['env_wall'] / b['env_wall']:.2f}x"
              f"; final policy weights identical: {a['same']}")
    total = {k: sum(runs[s, k]["wall"] for s in args.seeds) for k in (False, True)}
    env = {k: sum(runs[s, k]["env_wall"] for s in args.seeds) for k in (False, True)}
    print(f"all seeds: wall {total[False]:.1f} s vs {total[True]:.1f} s -> "
          f"{total[False] / total[True]:.2f}x less with the native vector env (aim >= 3x); env "
          f"stepping {env[False]:.1f} s vs {env[True]:.1f} s ({env[False] / env[True]:.2f}x); "
          f"PPO's own part {total[False] - env[False]:.1f} s vs {total[True] - env[True]:.1f} s")


def table(curves: list[Curve]) -> None:
    print()
    print(f"{'robot':7s} {'mode':8s} {'seed':>4s} {'f@100k':>7s} {'f end':>6s} {'CPG':>5s} "
          f"{'above from':>10s} {'12s@100k':>8s} {'12s end':>7s} {'CPG 12s':>7s} "
          f"{'steps':>7s} {'wall s':>6s}")
    groups: dict[tuple[str, str], list[Curve]] = {}
    for c in curves:
        groups.setdefault((c.robot, c.mode), []).append(c)
        full_100k = next((v for k, v in c.full.items() if int(k) < c.steps[-1]), float("nan"))
        full_end = c.full.get(str(c.steps[-1]), float("nan"))
        above = c.above_from()
        print(f"{c.robot:7s} {c.mode:8s} {c.seed:4d} {c.at(MILESTONE):7.3f} {c.fitness[-1]:6.3f} "
              f"{c.cpg:5.2f} {'never' if above is None else f'{above // 1000} k':>10s} "
              f"{full_100k:8.3f} {full_end:7.3f} {c.cpg_full:7.2f} {c.steps[-1]:7d} "
              f"{c.wall[-1]:6.0f}")
    print()
    print("over seeds: mean +- standard deviation (min..max)")
    for (robot, mode), group in groups.items():
        def stats(values: list[float]) -> str:
            v = np.asarray(values)
            return f"{v.mean():.2f} +- {v.std(ddof=1) if len(v) > 1 else 0.0:.2f} " \
                   f"({v.min():.2f}..{v.max():.2f})"
        at = [c.at(MILESTONE) for c in group]
        beats = sum(f > c.cpg for f, c in zip(at, group, strict=True))
        print(f"{robot:7s} {mode:8s} {len(group)} seeds: f@100k {stats(at)}, end "
              f"{stats([c.fitness[-1] for c in group])}; CPG {group[0].cpg:.2f}; above the "
              f"CPG at 100 k in {beats}/{len(group)} seeds; 12 s window at the end "
              f"{stats([c.full.get(str(c.steps[-1]), np.nan) for c in group])} "
              f"(CPG {group[0].cpg_full:.2f}); wall {stats([c.wall[-1] for c in group])} s")


def plot(curves: list[Curve], path: Path, args: argparse.Namespace) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    robots = list(dict.fromkeys(c.robot for c in curves))
    fig, axes = plt.subplots(1, len(robots), figsize=(5.5 * len(robots), 4), squeeze=False)
    colors = {"targets": "tab:blue", "modulate": "tab:orange", "targets-plain": "tab:grey",
              "modulate-plain": "tab:brown"}
    labels = {"targets": "PPO targets (from scratch)", "modulate": "PPO modulate (on the CPG)",
              "targets-plain": "plain PPO, 15 s episodes, targets",
              "modulate-plain": "plain PPO, 15 s episodes, modulate"}
    for ax, robot in zip(axes[0], robots, strict=True):
        mine = [c for c in curves if c.robot == robot]
        for mode in dict.fromkeys(c.mode for c in mine):
            runs = [c for c in mine if c.mode == mode]
            for c in runs:
                ax.plot(c.steps, c.fitness, color=colors.get(mode), alpha=0.3, linewidth=0.8)
            n = min(len(c.steps) for c in runs)
            mean = np.mean([c.fitness[:n] for c in runs], axis=0)
            ax.plot(runs[0].steps[:n], mean, color=colors.get(mode), linewidth=2,
                    label=f"{labels.get(mode, mode)}, mean of {len(runs)} seeds")
        ax.axhline(mine[0].cpg, color="k", linestyle="--", label=f"own CPG ({mine[0].cpg:.2f} m)")
        ax.axvline(MILESTONE, color="grey", linewidth=0.5)
        ax.set_title(f"{robot}: Locomotion-v1, {args.engine}")
        ax.set_xlabel("environment steps (60 Hz), thousands")
        ax.xaxis.set_major_formatter(lambda x, _: f"{x / 1000:g}k")
        ax.set_ylabel(f"fitness f = v + 5 s over {args.evaluation:g} s (m)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=200_000, help="env steps per run")
    parser.add_argument("--robots", nargs="+", default=["spider", "gecko"])
    parser.add_argument("--modes", nargs="+", default=["targets", "modulate"],
                        choices=["targets", "modulate"])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--engine", default="pybullet", choices=["pybullet", "mujoco"])
    defaults = rl.VecEnvConfig()
    parser.add_argument("--n-envs", type=int, default=defaults.n_envs)
    parser.add_argument("--gamma", type=float, default=defaults.gamma)
    parser.add_argument("--insertion", type=float, default=defaults.insertion_time,
                        help="seconds, not scored")
    parser.add_argument("--evaluation", type=float, default=defaults.evaluation_time,
                        help="seconds, the fitness window")
    parser.add_argument("--no-norm", action="store_true",
                        help="no VecNormalize (neither observation nor reward scaling)")
    parser.add_argument("--v0", action="store_true",
                        help="Locomotion-v0: RoboGen's sensors only, no hinge angles or speeds")
    parser.add_argument("--plain", action="store_true",
                        help="PPO('MlpPolicy', env) with SB3's defaults on one env of the paper's "
                             "3 s + 12 s episodes, no normalisation (what a user tries first)")
    # PPO settings: None keeps revolve_env.rl.ppo_settings'.
    parser.add_argument("--n-steps", type=int, default=None, help="PPO rollout length per env")
    parser.add_argument("--batch-size", type=int, default=None)
    parser.add_argument("--n-epochs", type=int, default=None)
    parser.add_argument("--learning-rate", type=float, default=None)
    parser.add_argument("--ent-coef", type=float, default=None)
    parser.add_argument("--gae-lambda", type=float, default=None)
    parser.add_argument("--clip-range", type=float, default=None)
    parser.add_argument("--target-kl", type=float, default=None)
    parser.add_argument("--net", type=int, nargs="+", default=None, help="hidden layer sizes")
    parser.add_argument("--log-std", type=float, default=None, help="initial log std")
    parser.add_argument("--eval-every", type=int, default=10_000, help="env steps between evals")
    parser.add_argument("--figure", type=Path, default=None, help="write the curves (PNG)")
    parser.add_argument("--json", type=Path, default=None, help="write the curves (JSON)")
    parser.add_argument("--from-json", type=Path, default=None,
                        help="no training: print the table and plot the curves of --json's file")
    parser.add_argument("--routes", action="store_true",
                        help="PPO's wall time through rl.make_vec_env, native vector env vs "
                             "DummyVecEnv (batched=False), seed by seed (see the module doc)")
    args = parser.parse_args()
    torch.set_num_threads(1)
    if args.routes:
        if "--engine" not in sys.argv:
            args.engine = "mujoco"  # the native vector env's batch is MuJoCo's
        routes(args)
        return

    curves = []
    if args.from_json is not None:
        curves = [Curve(**c) for c in json.loads(args.from_json.read_text())]
        args.json = None
    for robot in args.robots if args.from_json is None else []:
        for mode in args.modes:
            for seed in args.seeds:
                print(f"== {robot} / {mode} / seed {seed}: {args.steps} steps, {args.engine}",
                      flush=True)
                curves.append(train(robot, mode, seed, args))
                if args.json is not None:  # after every run: a long job keeps what it did
                    args.json.parent.mkdir(parents=True, exist_ok=True)
                    args.json.write_text(json.dumps([asdict(c) for c in curves], indent=1))
    table(curves)
    if args.figure is not None:
        plot(curves, args.figure, args)


if __name__ == "__main__":
    main()

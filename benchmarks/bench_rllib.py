"""RLlib PPO, one shared policy over a population with births and deaths, vs the robots' own CPGs.

Trains RLlib's PPO (new API stack, one env runner in this process) on
:class:`revolve_env.envs.rllib.PopulationMultiAgentEnv`: the five example robots, every one driven
by the ONE shared policy, while :class:`~revolve_env.envs.checks.BirthsAndDeaths` adds a robot every
``--birth-every`` steps (example bodies in turn, policy-driven) and removes the oldest every
``--death-every`` steps; episodes of ``--seconds`` s (``max_cycles``), insertion ``--insertion`` s.

Evaluation, after every ``--eval-every`` iterations and at the end: the five example robots in one
world (same seed, same birth positions and headings, no births or deaths) for ``--seconds`` s,
once driven by the policy's mean action and once by their own networks (the CPGs: the same
robots with ``controlled_by="brain"``); the figure is each robot's fitness ``f = v + 5 s``
(metres over the sliding window after insertion) at the end, and their mean. One line per seed,
then the mean and standard deviation over seeds of (policy mean - CPG mean).

Usage (needs the rllib extra)::

    PYTHONPATH=. python benchmarks/bench_rllib.py --iterations 3 --seeds 0

Measured (issue 22; 2 shared CPU cores, other work running, ray 2.60 with gymnasium 1.2.2 in a
venv): see ``docs/rl_routes.md`` (the command and its output).
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from revolve_env.body.examples import EXAMPLES
from revolve_env.envs.checks import BirthsAndDeaths
from revolve_env.envs.population import PopulationEnv
from revolve_env.envs.rllib import PopulationMultiAgentEnv


def _robots(controlled_by: str) -> list[dict[str, Any]]:
    return [{"robot": make(), "controlled_by": controlled_by} for make in EXAMPLES.values()]


def evaluate(policy: Any, seed: int, seconds: float, insertion: float) -> dict[str, float]:
    """Each example robot's fitness after ``seconds`` s: driven by ``policy`` (None: its CPG).

    Args:
        policy: Maps a float32 observation batch ``(n, 10)`` to actions ``(n, 10)``; None: the
            robots' own networks.
        seed: The reset seed (birth positions and headings).
        seconds: Simulated time. Seconds.
        insertion: Insertion phase (not scored). Seconds.

    Returns:
        Fitness by robot name (the example's), metres.
    """
    env = PopulationEnv(initial_robots=_robots("brain" if policy is None else "agent"),
                        max_births=len(EXAMPLES), insertion_time=insertion, space_mode="uniform",
                        fitness_window=seconds - insertion, birth_radius=3.0)
    obs, infos = env.reset(seed=seed)
    for _ in range(round(seconds / env.config.control_period)):
        actions: dict[str, np.ndarray] = {}
        if policy is not None and env.agents:
            batch = np.stack([obs[a] for a in env.agents]).astype(np.float32)
            actions = dict(zip(env.agents, policy(batch), strict=True))
        obs, _, _, _, infos = env.step(actions)
    env.close()
    return {name: float(infos[f"robot_{k}"]["fitness"]) for k, name in enumerate(EXAMPLES)}


def _mean_action(module: Any) -> Any:
    import torch

    def act(batch: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            out = module.forward_inference({"obs": torch.from_numpy(batch)})
        inputs = out["action_dist_inputs"].numpy()
        return np.clip(inputs[:, : inputs.shape[1] // 2], -1.0, 1.0).astype(np.float32)

    return act


def run_seed(seed: int, args: argparse.Namespace) -> tuple[float, float]:
    """Train for one seed; print the evaluations; the final (policy mean, CPG mean)."""
    from ray.rllib.algorithms.ppo import PPOConfig

    steps = round(args.seconds * 60)
    env_config = {"initial_robots": _robots("agent"), "max_cycles": steps, "max_births": 200,
                  "insertion_time": args.insertion, "fitness_window": args.seconds - args.insertion,
                  "birth_radius": 3.0,
                  "lifecycle": BirthsAndDeaths(args.birth_every, args.death_every,
                                               tuple((make(), "agent")
                                                     for make in EXAMPLES.values()))}
    config = (PPOConfig()
              .environment(PopulationMultiAgentEnv, env_config=env_config)
              .env_runners(num_env_runners=0, rollout_fragment_length=steps)
              .training(train_batch_size_per_learner=args.batch, minibatch_size=256,
                        num_epochs=5, lr=3e-4)
              .multi_agent(policies={"shared"},
                           policy_mapping_fn=lambda agent_id, episode, **kw: "shared")
              .debugging(seed=seed))
    algo = config.build_algo()
    cpg = evaluate(None, seed, args.seconds, args.insertion)
    cpg_mean = float(np.mean(list(cpg.values())))
    start = time.process_time()
    mine = cpg
    for i in range(1, args.iterations + 1):
        result = algo.train()
        if i % args.eval_every == 0 or i == args.iterations:
            mine = evaluate(_mean_action(algo.get_module("shared")), seed, args.seconds,
                            args.insertion)
            sampled = result["env_runners"]["num_env_steps_sampled_lifetime"]
            print(f"seed {seed} iteration {i:3d} env steps {sampled:7.0f} cpu "
                  f"{time.process_time() - start:6.0f} s  policy "
                  f"{np.mean(list(mine.values())):6.3f} m  CPG {cpg_mean:6.3f} m  " +
                  " ".join(f"{n} {mine[n]:.2f}/{cpg[n]:.2f}" for n in EXAMPLES), flush=True)
    algo.stop()
    return float(np.mean(list(mine.values()))), cpg_mean


def main() -> None:
    """Parse the arguments, run every seed, print the summary."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=20)
    parser.add_argument("--eval-every", type=int, default=5)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--seconds", type=float, default=5.0, help="episode length, s")
    parser.add_argument("--insertion", type=float, default=0.5, help="insertion phase, s")
    parser.add_argument("--batch", type=int, default=4000, help="agent steps per iteration")
    parser.add_argument("--birth-every", type=int, default=60, help="steps")
    parser.add_argument("--death-every", type=int, default=90, help="steps")
    args = parser.parse_args()
    import ray

    ray.init(num_cpus=1, include_dashboard=False, log_to_driver=False)
    try:
        gaps = []
        for seed in args.seeds:
            policy, cpg = run_seed(seed, args)
            gaps.append(policy - cpg)
            print(f"seed {seed}: shared policy {policy:.3f} m, CPGs {cpg:.3f} m (mean of the "
                  f"{len(EXAMPLES)} robots)")
    finally:
        ray.shutdown()
    print(f"policy - CPG over {len(gaps)} seeds: mean {np.mean(gaps):.3f} m, sd "
          f"{np.std(gaps, ddof=1) if len(gaps) > 1 else 0.0:.3f} m")


if __name__ == "__main__":
    main()

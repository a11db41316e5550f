"""Hashes of whole Locomotion-v0/-v1 episodes: what a change of the env's step must not move.

Every observation, reward, flag and info value of every step of two episodes (seeds 0 and 1, in
one env: the second starts from a reset world) goes into one SHA-256 per configuration. Run it
before and after a change and compare the lines: a refactor of the step leaves every one as it
was. The configurations are the env's kinds of steps: the agent's targets and the robot's brain,
every shipped task (with a fitness limit, a heading, the light), a pose every period, a short
window, a user's task with its own reward, noise, modulation, Locomotion-v0, a robot with touch
and light sensors, and blow-ups (a low speed limit). The hash loop is ``tests/episode_hashes.py``'s,
the one the compiled step's test compares the two steps with.

Usage: ``python benchmarks/locomotion_hashes.py [--only NAME ...] [--path general]`` (``general``:
the env's general Python step, ``LocomotionEnv._fast_step = False``; default: as shipped).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the shared loop

from episode_hashes import episodes, make

from revolve_env import LOCOMOTION_ID, LOCOMOTION_V1_ID
from revolve_env.fitness import Window
from revolve_env.tasks import Locomotion
from revolve_env.world import WorldConfig


@dataclass(frozen=True)
class Doubled(Locomotion):
    """A user's task: not a shipped type, and its own reward (not the gain)."""

    def reward(self, window: Window, fitness: NDArray[np.float64],
               previous: NDArray[np.float64]) -> NDArray[np.float64]:
        return 2.0 * (fitness - previous) + window.s


SHORT = {"insertion_time": 0.25, "evaluation_time": 1.5}
BLOWS = {"world_config": WorldConfig(max_linear_speed=0.4)}
CASES: dict[str, tuple[str, dict[str, Any]]] = {
    "default": (LOCOMOTION_V1_ID, {}),
    "brain": (LOCOMOTION_V1_ID, {"controller": "brain"}),
    "limit": (LOCOMOTION_V1_ID, {"task": {"name": "locomotion", "limit": 0.05}}),
    "directed": (LOCOMOTION_V1_ID, {"task": {"name": "directed-locomotion", "heading": 1.0}}),
    "light": (LOCOMOTION_V1_ID, {"task": "light-following", "fitness_window": 0.5}),
    "every-period": (LOCOMOTION_V1_ID, {"task": {"name": "locomotion",
                                                 "pose_rate": "every-period"},
                                        "fitness_window": 0.3}),
    "window-1s": (LOCOMOTION_V1_ID, {"fitness_window": 1.0}),
    "user-task": (LOCOMOTION_V1_ID, {"task": Doubled()}),
    "no-insertion-noisy": (LOCOMOTION_V1_ID, {"insertion_time": 0.0, "sensor_noise": 0.1,
                                              "actuator_noise": 0.1}),
    "no-insertion": (LOCOMOTION_V1_ID, {"insertion_time": 0.0, "controller": "brain"}),
    "v0-brain": (LOCOMOTION_ID, {"controller": "brain"}),
    "v0-agent": (LOCOMOTION_ID, {}),
    "modulated-brain": (LOCOMOTION_V1_ID, {"action": "modulate", "task": "light-following"}),
    "sensors-light-brain": (LOCOMOTION_V1_ID, {"robot": "sensors", "controller": "brain",
                                               "task": "light-following"}),
    "sensors-agent": (LOCOMOTION_V1_ID, {"robot": "sensors"}),
    "blow-up-brain": (LOCOMOTION_V1_ID, {"robot": "sensors", "controller": "brain", **BLOWS}),
    "blow-up-agent": (LOCOMOTION_V1_ID, {"robot": "sensors", **BLOWS}),
    "full-brain": (LOCOMOTION_V1_ID, {"controller": "brain", "insertion_time": None,
                                      "evaluation_time": None}),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--only", nargs="*", default=sorted(CASES))
    parser.add_argument("--path", choices=("shipped", "general"), default="shipped")
    args = parser.parse_args()
    for case in args.only:
        env_id, kwargs = CASES[case]
        env = make(env_id, {**SHORT, **kwargs}, fast=args.path == "shipped")
        digest, blown = episodes(env)
        env.close()
        print(f"{case:22s} {digest} blow-ups {blown}", flush=True)


if __name__ == "__main__":
    main()

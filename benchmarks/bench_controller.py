"""Controller ticks per second for 1, 30 and 1000 robots: compiled vs the NumPy reference.

Run: ``python benchmarks/bench_controller.py [--seconds S]``. Each robot is a typical ~20-part
robot's brain: 10 inputs (core IMU and two touch sensors), 8 sigmoid outputs (active hinges),
5 hidden neurons (2 oscillators, 3 sigmoids) and 40 random connections, recurrent ones included.
:func:`seconds_per_tick` is the function to reuse when timing the controller inside a world tick.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from revolve_env.body.robot import (
    Activation,
    Connection,
    Layer,
    Neuron,
    Node,
    PartType,
    Robot,
)
from revolve_env.brain import BatchController, ReferenceBatchController

DT = 0.05  # seconds; an illustrative control period (does not change the cost)


def typical_robot(rng: np.random.Generator) -> Robot:
    """A core with 8 hinges (4 arms of 2) and 2 touch sensors, plus 5 hidden neurons."""
    imu = ("accel_x", "accel_y", "accel_z", "gyro_x", "gyro_y", "gyro_z")
    hidden = tuple(
        Neuron(f"h{k}", Layer.HIDDEN, Activation.OSCILLATOR if k < 2 else Activation.SIGMOID,
               bias=rng.uniform(-1, 1), gain=rng.uniform(0.5, 3), period=rng.uniform(0.5, 2),
               phase_offset=rng.uniform(0, 1), amplitude=rng.uniform(0.5, 1))
        for k in range(5)
    )
    core_neurons = tuple(Neuron(f"core-{n}", Layer.INPUT, Activation.INPUT) for n in imu) + hidden
    arms: list[tuple[int, Node]] = []
    for a in range(4):
        tip: Node | None = None
        if a < 2:
            tip = Node(PartType.TOUCH_SENSOR, neurons=(
                Neuron(f"t{a}-l", Layer.INPUT, Activation.INPUT),
                Neuron(f"t{a}-r", Layer.INPUT, Activation.INPUT),
            ))
        for k in (1, 0):
            out = Neuron(f"a{a}h{k}", Layer.OUTPUT, Activation.SIGMOID,
                         bias=rng.uniform(-1, 1), gain=rng.uniform(0.5, 3))
            tip = Node(PartType.ACTIVE_HINGE, neurons=(out,),
                       children=((1, tip),) if tip is not None else ())
        assert tip is not None
        arms.append((a, tip))
    body = Node(PartType.CORE, neurons=core_neurons, children=tuple(arms))
    robot = Robot(body)
    ids = [n.id for n in robot.neurons()]
    targets = [n.id for n in robot.neurons() if n.layer != Layer.INPUT]
    connections = tuple(
        Connection(str(rng.choice(ids)), str(rng.choice(targets)), float(rng.uniform(-2, 2)))
        for _ in range(40)
    )
    return Robot(body, connections, name="typical")


def seconds_per_tick(
    controller: BatchController | ReferenceBatchController, min_seconds: float = 0.5
) -> float:
    """Wall-clock seconds of one ``controller.step`` over all its networks.

    Steps with fixed random inputs into a preallocated output array (as a world would), in
    chunks of about 10 ms for at least ``min_seconds``, and returns the fastest chunk's mean
    (the machine is shared, so the minimum is the least disturbed figure, as ``timeit`` advises).
    """
    x = np.random.default_rng(0).uniform(-1, 1, controller.n_inputs)
    y = np.empty(controller.n_outputs)
    step = controller.step
    chunk = 1
    while True:  # size a chunk to ~10 ms; this also warms up (the reference packs its layout)
        start = time.perf_counter()
        for _ in range(chunk):
            step(x, y)
        if time.perf_counter() - start >= 0.01:
            break
        chunk *= 2
    best, spent = float("inf"), 0.0
    while spent < min_seconds:
        start = time.perf_counter()
        for _ in range(chunk):
            step(x, y)
        elapsed = time.perf_counter() - start
        best, spent = min(best, elapsed / chunk), spent + elapsed
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=1.0, help="timing per case, seconds")
    args = parser.parse_args()
    rng = np.random.default_rng(42)
    pool = [typical_robot(rng) for _ in range(1000)]
    print(f"{'robots':>7} {'compiled ticks/s':>17} {'reference ticks/s':>18} {'speed-up':>9} "
          f"{'compiled us/tick':>17} {'ns/robot-tick':>14}")
    for n in (1, 30, 1000):
        timings = {}
        for cls in (BatchController, ReferenceBatchController):
            ctrl = cls(DT)
            for r in pool[:n]:
                ctrl.add(r)
            timings[cls] = seconds_per_tick(ctrl, args.seconds)
        fast, ref = timings[BatchController], timings[ReferenceBatchController]
        print(f"{n:>7} {1 / fast:>17,.0f} {1 / ref:>18,.0f} {ref / fast:>8.1f}x "
              f"{fast * 1e6:>17.2f} {fast / n * 1e9:>14.0f}")


if __name__ == "__main__":
    main()

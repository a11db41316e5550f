"""Type stubs of the compiled rollout on MuJoCo (controller_cpp/src/rollout.cpp).

Use it through :mod:`revolve_env.world.compiled`.
"""

import numpy as np
from numpy.typing import NDArray

MUJOCO_HEADER: int
MUJOCO_VERSION: str
RUNNING: int
DONE: int
SCREEN: int
FALLBACK: int

def mujoco_version() -> int: ...
def imu_products(rows: NDArray[np.float64], rot: NDArray[np.float64]) -> NDArray[np.float64]: ...
def einsum_products(rot: NDArray[np.float64], w: NDArray[np.float64]) -> NDArray[np.float64]: ...
def falloff_values(pos: NDArray[np.float64], light: NDArray[np.float64],
                   light_range: float) -> NDArray[np.float64]: ...
def light_values(pos: NDArray[np.float64], rot: NDArray[np.float64], point: NDArray[np.float64],
                 facing: NDArray[np.float64], light: NDArray[np.float64],
                 light_range: float) -> NDArray[np.float64]: ...

class Rollout:
    def __init__(self, insertion_ticks: int, evaluation_ticks: int, brain_stride: int,
                 substeps: int, control_period: float, servo_k: float, max_velocity: float,
                 target_scale: float, gravity: float, imu_high: NDArray[np.float64],
                 light: NDArray[np.float64], light_range: float,
                 light_signal: bool = False) -> None: ...
    def add(self, model: int, data: int, root_body: int, root_qpos: int, root_dof: int,
            hinge_qpos: NDArray[np.int64], hinge_dof: NDArray[np.int64],
            active: NDArray[np.int64], n_inputs: int, touch_body: NDArray[np.int64],
            touch_dest: NDArray[np.int64], light_body: NDArray[np.int64],
            light_dest: NDArray[np.int64], light_point: NDArray[np.float64],
            light_facing: NDArray[np.float64], screen: NDArray[np.float64],
            prev_vel: NDArray[np.float64], kinds: NDArray[np.int8],
            params: NDArray[np.float64], src: NDArray[np.int32], dst: NDArray[np.int32],
            weight: NDArray[np.float64], net_inputs: int, net_outputs: int,
            brain_dt: float) -> int: ...
    def run(self, threads: int = 1) -> None: ...
    def status(self, index: int) -> int: ...
    def time(self, index: int) -> float: ...
    def resume(self, index: int, blown: bool) -> None: ...
    def path(self, index: int) -> NDArray[np.float64]: ...
    def signal(self, index: int) -> NDArray[np.float64]: ...
    def state(self, index: int) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                         NDArray[np.float64], NDArray[np.float64],
                                         NDArray[np.float64], NDArray[np.float64]]: ...

CALM: int
UNSETTLED: int
REPLAY: int
RESTART: int

class WorldStep:
    def __init__(self, model: int, data: int, substeps: int, control_period: float,
                 servo_k: float, max_velocity: float, gravity: float,
                 imu_high: NDArray[np.float64], light: NDArray[np.float64], light_range: float,
                 root_body: NDArray[np.int64], root_qpos: NDArray[np.int64],
                 root_dof: NDArray[np.int64], hinge_qpos: NDArray[np.int64],
                 hinge_dof: NDArray[np.int64], joint_start: NDArray[np.int64],
                 input_start: NDArray[np.int64], n_inputs: int, ctrl_qpos: NDArray[np.int64],
                 touch_body: NDArray[np.int64], touch_dest: NDArray[np.int64],
                 light_body: NDArray[np.int64], light_row: NDArray[np.int64],
                 light_dest: NDArray[np.int64], light_point: NDArray[np.float64],
                 light_facing: NDArray[np.float64], screen: NDArray[np.float64]) -> None: ...
    @property
    def states_size(self) -> int: ...
    def step(self, targets: NDArray[np.float64], start: NDArray[np.float64],
             states: NDArray[np.float64], sensors: NDArray[np.float64]) -> int: ...

ENV_DONE: int
ENV_BAD_ACTION: int
ENV_BRAIN_DIVERGED: int

class EnvStep:
    def __init__(self, world: WorldStep, targets: NDArray[np.float64],
                 outputs: NDArray[np.float64], start: NDArray[np.float64],
                 out: NDArray[np.float64], n_act: int, n_inputs: int, active: NDArray[np.int64],
                 proprioception: bool, low: NDArray[np.float64], high: NDArray[np.float64],
                 target_scale: float, task_kind: int, s_weight: float, limit: float,
                 cos_h: float, sin_h: float, window: float, insertion: int, stride: int,
                 signal_inputs: NDArray[np.int64], network: tuple[object, ...] | None,
                 brain_dt: float, brain_stride: int) -> None: ...
    def step(self, action: NDArray[np.float32] | NDArray[np.float64], obs: NDArray[np.float64],
             states: NDArray[np.float64], sensors: NDArray[np.float64], periods: int, age: int,
             time: float) -> int: ...
    def set_world(self, world: WorldStep, start: NDArray[np.float64]) -> None: ...
    @property
    def terms(self) -> tuple[float, float, float]: ...
    @terms.setter
    def terms(self, value: tuple[float, float, float]) -> None: ...
    def window_holds(self, age: int) -> bool: ...
    def window_push(self, time: float, x: float, y: float, age: int,
                    signal: float | None) -> int: ...
    def window_terms(self) -> tuple[float, float, float]: ...
    def window_last(self) -> tuple[float, float, float]: ...
    def window_len(self) -> int: ...
    def window_clear(self) -> None: ...

def py_hypots(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]: ...

# The rules over a World's arrays (pybullet's worlds, through compiled.Rules).
def clip_targets(targets: NDArray[np.float64], scale: float, out: NDArray[np.float64]) -> bool: ...
def servo_velocities(targets: NDArray[np.float64], joint_pos: NDArray[np.float64],
                     active: NDArray[np.intp], servo_k: float,
                     max_velocity: float) -> NDArray[np.float64]: ...
def all_calm_rows(pos: NDArray[np.float64], rot: NDArray[np.float64], vel: NDArray[np.float64],
                  spin: NDArray[np.float64], joint_pos: NDArray[np.float64],
                  joint_vel: NDArray[np.float64], diverged: NDArray[np.bool_],
                  joint_offsets: NDArray[np.intp], screen: NDArray[np.float64]) -> bool: ...
def sense_rows(out: NDArray[np.float64], input_offsets: NDArray[np.intp],
               pos: NDArray[np.float64], rot: NDArray[np.float64], vel: NDArray[np.float64],
               prev: NDArray[np.float64], spin: NDArray[np.float64], control_period: float,
               gravity: float, imu_high: NDArray[np.float64], light_dest: NDArray[np.intp],
               root_rows: NDArray[np.intp], link_pos: NDArray[np.float64],
               link_rot: NDArray[np.float64], points: NDArray[np.float64],
               facings: NDArray[np.float64], light: NDArray[np.float64],
               light_range: float) -> None: ...
def windows_push(t: float, window: float, eps: float, stride: int, insertion: int,
                 position: NDArray[np.float64], ages: NDArray[np.int64],
                 sampling: NDArray[np.bool_], ring_t: NDArray[np.float64],
                 ring_xy: NDArray[np.float64], ring_path: NDArray[np.float64],
                 first: NDArray[np.int64], last: NDArray[np.int64], seq: int, start: int,
                 w_first: NDArray[np.float64], w_last: NDArray[np.float64],
                 w_v: NDArray[np.float64], w_s: NDArray[np.float64], w_count: NDArray[np.int64],
                 w_duration: NDArray[np.float64]) -> tuple[bool, int, int, bool]: ...

PERIODS_ALL: int
PERIODS_BRAIN: int
PERIODS_WORLD: int

class PopulationPeriods:
    def __init__(self, world: WorldStep, brain_dt: float, target_scale: float,
                 control_period: float, task_kind: int, s_weight: float, limit: float,
                 cos_h: float, sin_h: float, window: float, eps: float, stride: int,
                 insertion: int, sample_from: int) -> None: ...
    def add_network(self, kinds: NDArray[np.int8], params: NDArray[np.float64],
                    src: NDArray[np.int32], dst: NDArray[np.int32], weight: NDArray[np.float64],
                    n_inputs: int, n_outputs: int, state: NDArray[np.float64],
                    time: float) -> int: ...
    def state(self, handle: int) -> NDArray[np.float64]: ...
    def time(self, handle: int) -> float: ...
    def raise_pending(self) -> None: ...
    def run(self, n: int, steps: int, time: float, targets: NDArray[np.float64],
            outputs: NDArray[np.float64], obs: NDArray[np.float64], start: NDArray[np.float64],
            states_a: NDArray[np.float64], sensors_a: NDArray[np.float64],
            states_b: NDArray[np.float64], sensors_b: NDArray[np.float64],
            ages: NDArray[np.int64], ring_t: NDArray[np.float64], ring_xy: NDArray[np.float64],
            ring_path: NDArray[np.float64], first: NDArray[np.int64], last: NDArray[np.int64],
            seq: int, seq_start: int, f: NDArray[np.float64], v: NDArray[np.float64],
            s: NDArray[np.float64], w_first: NDArray[np.float64], w_last: NDArray[np.float64],
            w_v: NDArray[np.float64], w_s: NDArray[np.float64], w_count: NDArray[np.int64],
            w_duration: NDArray[np.float64]
            ) -> tuple[int, int, int, int, int, bool, bool, float]: ...

"""MuJoCo scenes of one model stepped in ``mujoco.batch``: an isolated world of copies of one body.

:class:`MujocoBatchScenes` is :class:`~revolve_env.world.mujoco_scenes.MujocoScenes` (a robot
per scene, each its world alone) whose scenes, when they all hold the same compiled model (copies
of one robot at one start: the native vector env, a learner's candidates of one infant), are
stepped by ``mujoco.batch.Batch``: every scene's ``mjSTATE_INTEGRATION`` a row, stepped on
``threads`` threads outside the GIL, bit for bit a loop of ``mj_step`` over each scene's own
``MjData`` (MuJoCo's guarantee; tests/world/test_mujoco_batch.py holds it against the loop). The
body poses the world reads are the batch's, computed at the new state (``mjSTAGE_POS``, as
``mj_kinematics`` after the step), and a scene whose period ends non-finite or fails is replayed
alone by its own backend, as in the loop.

Scenes of different models, or any robot with touch sensors (their contacts are not among the
batch's outputs), fall back to the loop; so does everything that reads a scene's own ``MjData``
(a hinge reset, a birth, a death, a picture), after the batch's rows are written back into it.
"""

from __future__ import annotations

import hashlib

import numpy as np
from numpy.typing import NDArray

from revolve_env.world.config import WorldConfig
from revolve_env.world.model import RobotModel, TouchSensorModel
from revolve_env.world.mujoco_backend import _SAVED, MujocoBackend, _all_finite
from revolve_env.world.mujoco_gl import mujoco  # its OpenGL backend chosen first
from revolve_env.world.mujoco_scenes import MujocoScenes

__all__ = ["MujocoBatchScenes"]

_INTEGRATION = int(mujoco.mjtState.mjSTATE_INTEGRATION)
_POS = int(mujoco.mjtStage.mjSTAGE_POS)


def _digest(model: mujoco.MjModel) -> str:
    """SHA-256 of a compiled model's MJB bytes (equal digests: the same model)."""
    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return hashlib.sha256(buffer.tobytes()).hexdigest()


def _has_touch(model: RobotModel) -> bool:
    return any(isinstance(sensor, TouchSensorModel) for _, sensor in model.sensors)


class MujocoBatchScenes(MujocoScenes):
    """Scenes of one robot each, stepped in one ``mujoco.batch`` when they share a model."""

    def __init__(self, config: WorldConfig, threads: int = 1) -> None:
        """No robots yet; ``threads``: the batch's threads (1: this thread only)."""
        if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
            raise ValueError(f"threads must be an integer >= 1, got {threads!r}")
        self._threads = threads
        self._batch: mujoco.batch.Batch | None = None
        self._batch_scenes: list[MujocoBackend] = []
        self._synced = True  # every scene's MjData holds its state (not only the batch's row)
        self._batch_due = False  # the scenes changed since the batch was made (or found unfit)
        self._digests: dict[int, str] = {}  # id(scene) -> its model's digest
        self._touch: dict[int, bool] = {}  # key -> a robot with touch sensors
        super().__init__(config)

    # -- the batch's rows and the scenes' MjData ---------------------------------------------------
    def _sync(self) -> None:
        """Write the batch's rows back into every scene's MjData (and its body poses)."""
        if self._synced:
            return
        batch = self._batch
        assert batch is not None
        for i, scene in enumerate(self._batch_scenes):
            m, d = scene._model, scene._data
            mujoco.mj_setState(m, d, batch.state[i], _INTEGRATION)
            mujoco.mj_kinematics(m, d)
            scene._kinematics_fresh = True
        self._synced = True

    def add(self, model: RobotModel, position: tuple[float, float, float], yaw: float) -> int:
        self._sync()
        key = super().add(model, position, yaw)
        self._touch[key] = _has_touch(model)
        return key

    def remove(self, key: int) -> None:
        self._sync()
        self._touch.pop(key, None)
        super().remove(key)

    def reset(self) -> None:
        self._batch = None
        self._batch_scenes = []
        self._synced = True
        self._digests.clear()
        super().reset()

    def _drop_batch(self) -> None:
        """The scenes changed: the batch (if any) is made anew at the next step.

        Made at the step rather than at every change, so that N births cost O(N), not N
        batches of 1, 2, ..., N simulations.
        """
        self._sync()
        self._batch = None
        self._batch_scenes = []
        self._batch_due = True

    def render(self, width: int, height: int, target: tuple[float, float, float],
               distance: float, yaw_deg: float, pitch_deg: float) -> NDArray[np.uint8]:
        self._sync()
        return super().render(width, height, target, distance, yaw_deg, pitch_deg)

    def _layout_scenes(self) -> None:
        super()._layout_scenes()  # from the scenes' MjData: add/remove/set_hinges synced them
        self._drop_batch()

    def _grown(self, key: int) -> None:
        super()._grown(key)
        self._drop_batch()

    def set_hinges(self, key: int, hinges: NDArray[np.intp], angles: NDArray[np.float64],
                   velocities: NDArray[np.float64]) -> None:
        self._sync()
        super().set_hinges(key, hinges, angles, velocities)
        self._drop_batch()

    def _make_batch(self) -> None:
        """One ``mujoco.batch`` of every scene, when they all hold one model without touch."""
        self._batch_due = False
        scenes = self._scene_list()
        if len(scenes) < 2 or any(self._touch.values()):
            return
        m = scenes[0]._model
        sizes = (m.nq, m.nv, m.nu, m.nbody, m.ngeom)
        if any((s._model.nq, s._model.nv, s._model.nu, s._model.nbody, s._model.ngeom) != sizes
               for s in scenes):
            return  # not one model (no digest needed to say so)
        digests = set()
        for scene in scenes:
            digest = self._digests.get(id(scene))
            if digest is None:
                digest = self._digests[id(scene)] = _digest(scene._model)
            digests.add(digest)
        live = {id(s) for s in scenes}
        self._digests = {k: v for k, v in self._digests.items() if k in live}
        head = int(mujoco.mjtState.mjSTATE_TIME | mujoco.mjtState.mjSTATE_QPOS
                   | mujoco.mjtState.mjSTATE_QVEL | mujoco.mjtState.mjSTATE_ACT
                   | mujoco.mjtState.mjSTATE_HISTORY)
        if len(digests) > 1 or mujoco.mj_stateSize(m, head) != 1 + m.nq + m.nv:
            return  # not one model, or a state whose rows do not start as _SAVED's
        batch = mujoco.batch.Batch(m, nsim=len(scenes), nthread=self._threads)
        for i, scene in enumerate(scenes):
            mujoco.mj_getState(scene._model, scene._data, batch.state[i], _INTEGRATION)
        self._batch = batch
        self._batch_scenes = scenes
        self._saved = mujoco.mj_stateSize(m, _SAVED)  # time, qpos, qvel, warm start: a prefix
        self._root = int(scenes[0]._root_bodies[0])
        self._ctrl = batch.bind("ctrl")
        # outputs bound before the first call: a field bound later reads zeros until a call
        self._xmat, self._xpos = batch.bind("xmat"), batch.bind("xpos")
        self._synced = True

    # -- stepping -------------------------------------------------------------------------------
    def set_joint_velocities(self, velocities: NDArray[np.float64], max_torque: float) -> None:
        if max_torque != self._torque:
            self._sync()  # the batch holds a copy of the model: made anew with the new limit
            super().set_joint_velocities(velocities, max_torque)
            self._digests.clear()  # the models changed
            self._drop_batch()
            return
        super().set_joint_velocities(velocities, max_torque)

    def step(self, substeps: int) -> None:
        if self._batch_due:
            self._make_batch()
        batch = self._batch
        if batch is None:
            super().step(substeps)
            return
        n, k = batch.nsim, self._saved
        parity = 1 - self._parity
        start = self._states[self._parity].reshape(n, k)  # the period's start (_SAVED rows)
        if self._ctrl.shape[1]:
            self._ctrl[:] = self._velocities.reshape(n, -1)
        failed = np.zeros(0, dtype=np.intp)
        try:
            batch.step(nstep=substeps, stage=_POS)
        except mujoco.batch.SimulationError as error:  # those simulations kept the period's start
            failed = np.asarray(error.ids, dtype=np.intp)
        self._synced = False
        now = self._states[parity].reshape(n, k)
        now[:] = batch.state[:, :k]
        self._rot[:] = self._xmat[:, self._root]
        self._parity = parity
        if failed.size or not _all_finite(self._states[parity]):
            bad = set(failed.tolist()) | {i for i in range(n) if not _all_finite(now[i])}
            self._replay_alone(sorted(bad), start, substeps)

    def _replay_alone(self, rows: list[int], start: NDArray[np.float64], substeps: int) -> None:
        """Replay those scenes' period from its start, each by its own backend (as the loop)."""
        batch = self._batch
        assert batch is not None
        self._sync()
        k = self._saved
        now = self._states[self._parity].reshape(batch.nsim, k)
        diverged = self._diverged.copy()
        for i in rows:
            scene = self._batch_scenes[i]
            m = scene._model
            scene._data = d = mujoco.MjData(m)  # a failed step may have left it half-updated
            mujoco.mj_setState(m, d, batch.state[i], _INTEGRATION)  # its controls among them
            scene._replay(start[i].copy(), substeps)
            self._rebind(i, scene)  # the step plan of the loop, should the batch be dropped
            d = scene._data
            mujoco.mj_kinematics(m, d)
            mujoco.mj_getState(m, d, batch.state[i], _INTEGRATION)
            now[i] = batch.state[i, :k]
            self._rot[i] = d.xmat[self._root]
            diverged[i] = bool(scene._diverged[0])
        diverged.flags.writeable = False
        self._diverged = diverged
        batch.forward(ids=np.array(rows, dtype=np.intp), stage=_POS)  # their poses, as the rows

    # -- sensors --------------------------------------------------------------------------------
    def link_poses(self, ids: NDArray[np.intp]) -> tuple[NDArray[np.float64],
                                                         NDArray[np.float64]]:
        batch = self._batch
        if batch is None:
            return super().link_poses(ids)
        rows = self._rows  # the batch's rows are the scenes' (a change drops the batch)
        nbody = batch.model.nbody
        flat = np.array([rows[key] * nbody + inner for key, inner in
                         (self._links[i] for i in ids.tolist())], dtype=np.intp)
        pos = self._xpos.reshape(-1, 3)
        rot = self._xmat.reshape(-1, 9)
        return pos[flat], rot[flat].reshape(-1, 3, 3)

"""Opening a results folder never runs its code and never reaches outside it (issue 20).

Every kind of file a results folder holds is planted here in a malicious form: a policy that is
a pickle whose unpickling would create a marker file, a policy file whose metadata names a
dangerous class or a huge network, a snapshot that is such a pickle, and references (policy
files, snapshot and policy folders) that lead outside the folder. None may run code (the
marker never appears) and each is refused with one line. The end-to-end refusals by ``resume``
and ``reevaluate`` are in test_rl_infancy.py (they need a trained policy); damaged databases
(a stored config whose name is a path, a reference leading out) in test_damaged_db.py.
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from evolution.experiments.store import snapshot
from evolution.experiments.store.database import StoreError
from evolution.experiments.store.results_folder import PolicyReference, inside
from revolve_env.body.examples import EXAMPLES
from revolve_env.body.robot import Layer

pytest.importorskip("stable_baselines3")
pytest.importorskip("safetensors")


class _Evil:
    """Unpickled, it creates ``marker``."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[Any, ...]:
        return (open, (str(self.marker), "w"))


def _agent(action: str = "targets", normalized: bool = False, proprioception: bool = False) -> Any:
    """A PolicyAgent of an untrained PPO policy for the spider (with observation statistics,
    observing the hinges)."""
    import gymnasium as gym
    from gymnasium.spaces import Box
    from stable_baselines3 import PPO

    from evolution.learning import PolicyAgent

    robot = EXAMPLES["spider"]()
    hinges = len(robot.neurons_of(Layer.OUTPUT))
    n_in = len(robot.neurons_of(Layer.INPUT)) + (2 * hinges if proprioception else 0)
    n_out = hinges * (2 if action == "modulate" else 1)

    class Spaces(gym.Env[np.ndarray, np.ndarray]):
        observation_space = Box(-np.inf, np.inf, (n_in,), np.float64)
        action_space = Box(-1.0, 1.0, (n_out,), np.float32)

    model = PPO("MlpPolicy", Spaces(), device="cpu", seed=3, n_steps=16, batch_size=16)
    norm = None
    if normalized:
        from revolve_env.rl import ObservationNormalization

        rng = np.random.default_rng(5)
        norm = ObservationNormalization(rng.normal(size=n_in), rng.uniform(0.5, 2, n_in), 10.0,
                                        1e-8)
    return PolicyAgent(model.policy, robot, action, 1 / 60, norm,  # type: ignore[arg-type]
                       proprioception)


# -- paths ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("relative", ["/etc/passwd", "../x", "policies/../../x", "a\\b",
                                      "policies/\x00x", "", "link/x", "link"])
def test_inside_refuses_what_leads_out_of_the_folder(tmp_path: Path, relative: str) -> None:
    folder = tmp_path / "results"
    folder.mkdir()
    (tmp_path / "elsewhere").mkdir()
    (folder / "link").symlink_to(tmp_path / "elsewhere")
    with pytest.raises(StoreError) as error:
        inside(folder, relative, "policy file")
    assert "\n" not in str(error.value) and "policy file" in str(error.value)


def test_inside_accepts_paths_within_the_folder_and_refuses_links_even_within(
        tmp_path: Path) -> None:
    """A symbolic link is never followed, wherever it leads (issue 31): what a link points to
    can change after the check, and a received folder has no reason to hold one."""
    (tmp_path / "policies").mkdir()
    (tmp_path / "mine").symlink_to(tmp_path / "policies")
    assert inside(tmp_path, "policies/p.safetensors") == tmp_path / "policies/p.safetensors"
    with pytest.raises(StoreError, match="goes through the symbolic link .*mine"):
        inside(tmp_path, "mine/p.safetensors")


@pytest.mark.parametrize("text", ["[]", "{}", "x", '{"file": 1, "digest": "x"}',
                                  '{"file": "p", "digest": "x", "sha256": "not hex"}'])
def test_a_malformed_policy_reference_is_refused(text: str) -> None:
    with pytest.raises(StoreError, match="malformed policy reference"):
        PolicyReference.parse(text)


# -- policy files ---------------------------------------------------------------------------------


@pytest.mark.parametrize(("normalized", "proprioception"), [(False, False), (True, False),
                                                             (False, True), (True, True)],
                         ids=["raw", "normalized", "hinges", "normalized-hinges"])
@pytest.mark.parametrize("action", ["targets", "modulate"])
def test_a_saved_policy_loads_back_the_same_without_unpickling(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, action: str, normalized: bool,
        proprioception: bool) -> None:
    import torch

    from evolution.learning import load_policy, save_policy
    from evolution.learning.policy_file import policy_digest

    agent = _agent(action, normalized, proprioception)
    digest, sha256 = save_policy(agent, tmp_path / "p.safetensors")
    assert digest == policy_digest(agent)
    # The bytes are the policy's alone: saved again, the same file.
    assert save_policy(agent, tmp_path / "q.safetensors") == (digest, sha256)
    assert (tmp_path / "p.safetensors").read_bytes() == (tmp_path / "q.safetensors").read_bytes()

    def no_unpickling(*args: object, **kwargs: object) -> None:
        raise AssertionError("a policy file was unpickled")

    monkeypatch.setattr(pickle, "loads", no_unpickling)
    monkeypatch.setattr(pickle, "load", no_unpickling)
    monkeypatch.setattr(pickle, "Unpickler", no_unpickling)
    state = torch.random.get_rng_state()
    loaded = load_policy(tmp_path / "p.safetensors", agent.robot, digest, sha256=sha256)
    assert torch.equal(torch.random.get_rng_state(), state)  # torch's generator untouched
    assert policy_digest(loaded) == digest
    assert (loaded.action, loaded.control_period) == (agent.action, agent.control_period)
    observation = np.random.default_rng(0).normal(size=agent.n_observations)
    np.testing.assert_array_equal(loaded.policy_action(observation),
                                  agent.policy_action(observation))
    assert loaded.proprioception == proprioception
    if normalized:  # the statistics come back exactly
        for name in ("mean", "var", "clip", "epsilon"):
            np.testing.assert_array_equal(getattr(loaded.normalization, name),
                                          getattr(agent.normalization, name))
    else:
        assert loaded.normalization is None
    if normalized or proprioception:  # part of the digest (a plain policy keeps its own)
        assert policy_digest(_agent(action)) != digest
    if normalized and not proprioception:  # the statistics change what the same network sees
        raw = _agent(action)
        assert not np.array_equal(raw.policy_action(observation), loaded.policy_action(observation))


def test_a_pickled_policy_is_refused_unless_trusted(tmp_path: Path) -> None:
    from evolution.learning import PolicyFileError, load_policy
    from evolution.learning.policy_file import policy_digest

    marker = tmp_path / "marker"
    evil = tmp_path / "evil.pkl"
    evil.write_bytes(pickle.dumps({"format": 1, "agent": _Evil(marker)}))
    robot = EXAMPLES["spider"]()
    with pytest.raises(PolicyFileError, match="older pickled policy.*--trust-pickled-policies"):
        load_policy(evil, robot)
    assert not marker.exists()
    # An older file made by this package loads when the user trusts it.
    agent = _agent()
    old = tmp_path / "old.pkl"
    old.write_bytes(pickle.dumps({"format": 1, "agent": agent}))
    loaded = load_policy(old, robot, policy_digest(agent), trust_pickled=True)
    assert policy_digest(loaded) == policy_digest(agent)


def _rewritten(path: Path, change: Any) -> str:
    """Rewrite a saved policy's metadata with ``change(meta)``; the new file's SHA-256."""
    from safetensors.numpy import load, save

    blob = path.read_bytes()
    size = int.from_bytes(blob[:8], "little")
    meta = json.loads(json.loads(blob[8:8 + size])["__metadata__"]["revolve"])
    change(meta)
    new = save(load(blob), metadata={"revolve": json.dumps(meta)})
    path.write_bytes(new)
    return hashlib.sha256(new).hexdigest()


@pytest.mark.parametrize("change, message", [
    (lambda m: m.update(policy_class="os:system"), "unknown class 'os:system'"),
    (lambda m: m.update(policy_class="builtins:eval"), "unknown class 'builtins:eval'"),
    (lambda m: m.update(policy_class="subprocess:Popen"), "unknown class"),
    (lambda m: m.update(policy_class="torch.nn:Module"), "not a stable-baselines3 policy"),
    (lambda m: m["arguments"].update(activation_fn={"__class__": "os:system"}), "unknown class"),
    (lambda m: m["arguments"].update(net_arch={"pi": [10**9], "vf": [64]}), "exceeds"),
    (lambda m: m.update(format=1), "not a format-2/3 policy"),
    (lambda m: m.update(robot="{}"), "damaged"),
    (lambda m: m.update(normalization={"clip": 10.0}), "clip and epsilon"),
    (lambda m: m.update(format=2), "neither parameters, statistics nor space bounds"),
])
def test_a_policy_file_naming_dangerous_things_is_refused(
        tmp_path: Path, change: Any, message: str) -> None:
    from evolution.learning import PolicyFileError, load_policy, save_policy

    agent = _agent(normalized=True)
    path = tmp_path / "p.safetensors"
    save_policy(agent, path)
    sha256 = _rewritten(path, change)
    with pytest.raises(PolicyFileError, match=message) as error:
        load_policy(path, agent.robot, sha256=sha256)
    assert "\n" not in str(error.value) and str(path) in str(error.value)


def test_the_sha256_is_checked_before_the_file_is_parsed(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    import safetensors.numpy

    from evolution.learning import PolicyFileError, load_policy, save_policy

    agent = _agent()
    path = tmp_path / "p.safetensors"
    _, sha256 = save_policy(agent, path)
    path.write_bytes(path.read_bytes()[:-1] + b"\x00")

    def no_parsing(*args: object) -> None:
        raise AssertionError("parsed before the SHA-256 was checked")

    monkeypatch.setattr(safetensors.numpy, "load", no_parsing)
    with pytest.raises(PolicyFileError, match="SHA-256 differs"):
        load_policy(path, agent.robot, sha256=sha256)


def test_a_policy_for_another_body_is_refused_before_anything_is_built(tmp_path: Path) -> None:
    from evolution.learning import PolicyFileError, load_policy, save_policy

    agent = _agent()
    path = tmp_path / "p.safetensors"
    save_policy(agent, path)
    with pytest.raises(PolicyFileError, match="another body"):
        load_policy(path, EXAMPLES["gecko"]())


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_a_policy_file_that_is_not_a_regular_bounded_file_is_one_line_not_a_hang(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A FIFO, a folder, a device or an oversize file as the policy: refused before parsing."""
    from evolution.learning import PolicyFileError, load_policy, policy_file

    robot = EXAMPLES["spider"]()
    fifo, folder, big = (tmp_path / f"{n}.safetensors" for n in ("fifo", "folder", "big"))
    os.mkfifo(fifo)
    folder.mkdir()
    big.write_bytes(b"\0" * 4)
    # Were the FIFO opened to be read, it would wait for a writer: one comes after a minute,
    # so that a regression fails on its message instead of hanging the suite.
    rescue = threading.Timer(60, lambda: os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)))
    rescue.start()
    try:
        with pytest.raises(PolicyFileError) as error:
            load_policy(fifo, robot)
    finally:
        rescue.cancel()
    assert str(error.value) == f"policy file {fifo} is a FIFO, not a regular file"
    with pytest.raises(PolicyFileError) as error:
        load_policy(folder, robot)
    assert str(error.value) == f"policy file {folder} is a folder, not a regular file"
    monkeypatch.setattr(policy_file, "MAX_BYTES", 3)
    with pytest.raises(PolicyFileError) as error:
        load_policy(big, robot)
    assert str(error.value) == f"policy file {big} is larger than 3 bytes"
    with pytest.raises(PolicyFileError, match=r"^policy file \S+missing\S+: No such file"):
        load_policy(tmp_path / "missing.safetensors", robot)


# -- snapshots ------------------------------------------------------------------------------------


def test_a_snapshot_that_runs_code_is_refused(tmp_path: Path) -> None:
    db = tmp_path / "results.sqlite"
    path = snapshot.snapshot_path(db, 0, 5)
    path.parent.mkdir()
    marker = tmp_path / "marker"
    blob = pickle.dumps({"format": snapshot.FORMAT, "data": {"x": _Evil(marker)}})
    path.write_bytes(blob)
    ref = snapshot.reference(path, hashlib.sha256(blob).hexdigest(), 5)
    with pytest.raises(snapshot.SnapshotError, match="only plain data"):
        snapshot.read(db, 0, ref, 5)
    assert not marker.exists()


def test_a_snapshot_leading_outside_the_folder_is_refused(tmp_path: Path) -> None:
    folder = tmp_path / "results"
    folder.mkdir()
    (tmp_path / "elsewhere").mkdir()
    (folder / "checkpoints").symlink_to(tmp_path / "elsewhere")
    with pytest.raises(snapshot.SnapshotError, match="outside the results folder"):
        snapshot.snapshot_path(folder / "results.sqlite", 0, 5)
    (tmp_path / "elsewhere" / "run0.b1.snapshot").write_bytes(b"someone else's")
    snapshot.prune(folder / "results.sqlite", 0, None)  # deletes nothing out there
    assert (tmp_path / "elsewhere" / "run0.b1.snapshot").exists()

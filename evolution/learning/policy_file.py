"""Saved SB3 policies: files that load without running any code they contain.

An experiment keeps every trained policy in its results folder, and results folders are shared:
opening one must never run code from it. So a policy file holds numbers and plain data only,
and loading it never unpickles:

* one `safetensors <https://huggingface.co/docs/safetensors>`_ file
  (``<results>/policies/run<r>_robot<id>.safetensors``) whose tensors are the policy network's
  parameters (``param/<state_dict name>``) and the bounds of its observation and action spaces
  (``space/<name>/low`` and ``/high``), and whose metadata ``revolve`` is JSON: the format
  version, the SB3 policy class by name, its constructor arguments as plain data (classes by
  name, spaces by dtype and shape), the robot it was trained on (robot JSON), the action mode
  and the control period; format 3 adds whether the policy observes the hinge angles and
  velocities (metadata ``proprioception``) and, for a policy trained on normalised
  observations, its frozen statistics (tensors ``norm/mean`` and ``norm/var``, metadata
  ``normalization``: clip and epsilon, else null), without which it would see other numbers
  than it learned on;
* :func:`load_policy` checks the file's SHA-256 against the store's record *before* parsing
  anything, parses it with safetensors (bounded, no code), resolves every class name among
  classes of torch and stable-baselines3 that are already imported (an SB3 policy, a torch
  module or optimizer; nothing is imported by name), checks the spaces against the robot, builds
  the policy from those arguments (torch's global generator untouched) and loads the parameters
  strictly; then the body and the parameter digest (:func:`policy_digest`) are checked.

Policies written before this format (``.pkl``: a pickle of the :class:`PolicyAgent`) are
refused with one line, because unpickling runs whatever the file says; ``trust_pickled=True``
(``--trust-pickled-policies`` on the command line) loads them as before, for folders whose
author the user trusts.
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import re
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from evolution.learning.base import same_body
from evolution.learning.sb3 import PolicyAgent
from revolve_env.body.files import FileTooLargeError, NotARegularFileError, read_bounded
from revolve_env.body.robot import Layer, Robot
from revolve_env.body.serialize import from_json, to_json
from revolve_env.rl import ObservationNormalization

__all__ = [
    "FORMAT",
    "FORMATS",
    "PICKLED_SUFFIX",
    "SUFFIX",
    "TRUST_HINT",
    "PolicyFileError",
    "load_policy",
    "policy_digest",
    "policy_from_bytes",
    "refused_pickle",
    "save_policy",
]

FORMAT = 3
"""Version of the policy file layout written for a policy with observation statistics or
proprioception (1 was a pickle of the :class:`PolicyAgent`; 2, still written for a policy with
neither, byte for byte as before, is 3 without them)."""
FORMATS = (2, 3)
"""Versions read."""
SUFFIX = ".safetensors"
"""File suffix of a policy file of this format."""
PICKLED_SUFFIX = ".pkl"
"""File suffix of an older, pickled policy file."""
MAX_BYTES = 256 * 2**20
"""Largest policy file read (a 64 x 64 network is about 100 kB). Bytes."""
TRUST_HINT = ("re-train it by running the experiment again into a new folder, or, if you trust "
              "whoever made this results folder, pass --trust-pickled-policies (Python: "
              "trust_pickled_policies=True)")
"""What a refused pickled policy's message tells the user to do."""

_ROOTS = ("torch", "stable_baselines3")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_MODULE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*")


class PolicyFileError(ValueError):
    """A saved policy that cannot be used: unreadable, damaged, refused, or for another body."""


def refused_pickle(name: str) -> str:
    """Why the pickled policy file ``name`` is not opened, and what to do (one line)."""
    return (f"policy file {name} is an older pickled policy, which could run code when loaded, "
            f"so it is not opened; {TRUST_HINT}")


def policy_digest(agent: PolicyAgent) -> str:
    """SHA-256 of the policy's parameters (name, shape and bytes of each, in order).

    A function of the trained numbers only, so a deterministic training gives the same digest
    whatever else SB3 or torch would write into a file.
    """
    h = hashlib.sha256(f"{agent.action}:{agent.control_period!r}".encode())
    norm = agent.normalization
    # (a policy with neither keeps the digest it always had)
    if agent.proprioception:
        h.update(b"proprioception")
    if norm is not None:
        h.update(f"norm:{norm.clip!r}:{norm.epsilon!r}".encode())
        h.update(np.ascontiguousarray(norm.mean).tobytes())
        h.update(np.ascontiguousarray(norm.var).tobytes())
    state = getattr(agent.policy, "state_dict", None)
    if state is None:
        raise TypeError(f"{type(agent.policy).__name__} has no state_dict(): not an SB3 policy")
    for name, tensor in state().items():
        values = np.ascontiguousarray(tensor.detach().cpu().numpy())
        h.update(f"{name}:{values.dtype}:{values.shape}".encode())
        h.update(values.tobytes())
    return h.hexdigest()


# -- writing ------------------------------------------------------------------------------------


def _encode(value: Any, key: str, tensors: dict[str, np.ndarray]) -> Any:
    """``value`` (a constructor argument of an SB3 policy) as JSON data.

    Raises:
        TypeError: a value with no safe plain form (a class outside torch and SB3, a space other
            than a ``Box``, a function other than the learning-rate schedule).
    """
    from gymnasium.spaces import Box

    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (list, tuple)):
        return [_encode(v, key, tensors) for v in value]
    if isinstance(value, Mapping):
        if not all(isinstance(k, str) for k in value):
            raise TypeError(f"policy argument {key}: a table with keys that are not text")
        return {k: _encode(v, f"{key}.{k}", tensors) for k, v in value.items()}
    if isinstance(value, type):
        module = value.__module__
        if module.split(".")[0] not in _ROOTS or not _NAME.fullmatch(value.__qualname__):
            raise TypeError(f"policy argument {key}: class {module}.{value.__qualname__} is "
                            "not a torch or stable-baselines3 class")
        return {"__class__": f"{module}:{value.__qualname__}"}
    if isinstance(value, Box):
        tensors[f"space/{key}/low"] = np.ascontiguousarray(value.low)
        tensors[f"space/{key}/high"] = np.ascontiguousarray(value.high)
        return {"__box__": key, "dtype": str(value.dtype), "shape": list(value.shape)}
    if key == "lr_schedule" and callable(value):
        return {"__schedule__": "unused"}  # the optimizer is never stepped after training
    raise TypeError(f"policy argument {key}: {type(value).__name__} has no safe plain form")


def save_policy(agent: PolicyAgent, path: str | os.PathLike[str]) -> tuple[str, str]:
    """Write ``agent`` atomically to ``path`` (a temporary file, then a rename).

    The bytes are a function of the policy alone (no time stamp), so the same training writes
    the same file.

    Returns:
        ``(policy_digest, file SHA-256)``, both hexadecimal, for the store to keep.

    Raises:
        TypeError: the policy is not an SB3 policy whose arguments have a plain form.
        OSError: the file cannot be written.
    """
    from safetensors.numpy import save

    agent.reset()
    policy: Any = agent.policy
    arguments = getattr(policy, "_get_constructor_parameters", None)
    if arguments is None:
        raise TypeError(f"{type(policy).__name__} is not a stable-baselines3 policy")
    cls = type(policy)
    tensors: dict[str, np.ndarray] = {}
    norm = agent.normalization
    later = norm is not None or agent.proprioception
    meta: dict[str, Any] = {
        "format": FORMAT if later else 2,
        "policy_class": _encode(cls, "policy_class", tensors)["__class__"],
        "arguments": {k: _encode(v, k, tensors) for k, v in dict(arguments()).items()},
        "parameters": [],
        "robot": to_json(agent.robot, indent=None),
        "action": agent.action,
        "control_period": agent.control_period,
    }
    for name, tensor in policy.state_dict().items():
        meta["parameters"].append(name)
        tensors[f"param/{name}"] = np.ascontiguousarray(tensor.detach().cpu().numpy())
    if later:
        meta["proprioception"] = agent.proprioception
        meta["normalization"] = None
    if norm is not None:
        meta["normalization"] = {"clip": norm.clip, "epsilon": norm.epsilon}
        tensors["norm/mean"] = np.ascontiguousarray(norm.mean)
        tensors["norm/var"] = np.ascontiguousarray(norm.var)
    blob = save(tensors, metadata={"revolve": json.dumps(meta, sort_keys=True)})
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    temporary = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    try:
        temporary.unlink(missing_ok=True)  # a link planted there is replaced, never followed
        with open(temporary, "xb") as f:
            f.write(blob)
            f.flush()
            os.fsync(f.fileno())
        os.replace(temporary, target)
    finally:
        temporary.unlink(missing_ok=True)
    return policy_digest(agent), hashlib.sha256(blob).hexdigest()


# -- reading ------------------------------------------------------------------------------------


def load_policy(path: str | os.PathLike[str], robot: Robot, digest: str | None = None, *,
                sha256: str | None = None, trust_pickled: bool = False) -> PolicyAgent:
    """The :class:`PolicyAgent` saved at ``path``, checked against ``robot`` and the records.

    Args:
        path: The policy file (``.safetensors``; an older ``.pkl`` only with ``trust_pickled``).
        robot: The robot the policy must drive (same body and network structure).
        digest: The recorded :func:`policy_digest`; ``None``: not checked.
        sha256: The recorded SHA-256 of the file, checked before the file is parsed; ``None``:
            not checked.
        trust_pickled: Load an older pickled policy (unpickling runs whatever code the file
            holds: only for a folder whose author you trust).

    Raises:
        PolicyFileError: one line naming the file: missing or unreadable, too large, not the
            recorded file, damaged, a pickled policy without ``trust_pickled``, trained on
            another body or network, or parameters that differ from ``digest``.
    """
    name = os.fspath(path)
    blob = b""
    if not (Path(name).suffix == PICKLED_SUFFIX and not trust_pickled):  # refused unread
        blob = _read_bounded(name)
    return policy_from_bytes(name, blob, robot, digest, sha256=sha256,
                             trust_pickled=trust_pickled)


def _read_bounded(name: str) -> bytes:
    """The bytes of a regular file of at most :data:`MAX_BYTES` (a FIFO refused, not waited on)."""
    try:
        return read_bounded(name, MAX_BYTES)
    except NotARegularFileError as error:
        raise PolicyFileError(f"policy file {name} is {error.kind}, not a regular file") from None
    except FileTooLargeError:
        raise PolicyFileError(f"policy file {name} is larger than {MAX_BYTES} bytes") from None
    except OSError as error:
        raise PolicyFileError(f"policy file {name}: {error.strerror or error}") from error


def policy_from_bytes(name: str, blob: bytes, robot: Robot, digest: str | None = None, *,
                      sha256: str | None = None, trust_pickled: bool = False) -> PolicyAgent:
    """The :class:`PolicyAgent` held in ``blob``, the bytes of policy file ``name``.

    As :func:`load_policy`, for bytes already read (the results folder reads them:
    :func:`evolution.experiments.store.results_folder.load_policy`).

    Raises:
        PolicyFileError: as :func:`load_policy`.
    """
    suffix = Path(name).suffix
    if suffix not in (SUFFIX, PICKLED_SUFFIX):
        raise PolicyFileError(f"policy file {name} is not a {SUFFIX} file")
    if suffix == PICKLED_SUFFIX and not trust_pickled:
        raise PolicyFileError(refused_pickle(name))
    if len(blob) > MAX_BYTES:
        raise PolicyFileError(f"policy file {name} is larger than {MAX_BYTES} bytes")
    if sha256 is not None and hashlib.sha256(blob).hexdigest() != sha256:
        raise PolicyFileError(f"policy file {name} does not match its record in the store "
                              "(SHA-256 differs)")
    agent = _unpickle(name, blob) if suffix == PICKLED_SUFFIX else _read(name, blob, robot)
    if not same_body(agent.robot, robot):
        raise PolicyFileError(f"policy file {name} was trained on another body or network "
                              "than this robot's")
    try:
        found = policy_digest(agent)
    except Exception as error:  # noqa: BLE001 - a damaged network
        raise PolicyFileError(f"policy file {name} is damaged ({error})") from error
    if digest is not None and found != digest:
        raise PolicyFileError(f"policy file {name} does not match its record in the store "
                              "(parameters differ)")
    return agent


def _unpickle(name: str, blob: bytes) -> PolicyAgent:
    """An older pickled policy (format 1); the caller was told to trust it."""
    try:
        content = pickle.loads(blob)  # noqa: S301 - opted in: trust_pickled
    except Exception as error:  # noqa: BLE001 - any unpickling failure means a damaged file
        raise PolicyFileError(f"policy file {name} is damaged ({type(error).__name__}: "
                              f"{error})") from error
    agent = content.get("agent") if isinstance(content, dict) else None
    if not isinstance(agent, PolicyAgent) or content.get("format") != 1:
        raise PolicyFileError(f"policy file {name} does not hold a saved PolicyAgent")
    return agent


def _read(name: str, blob: bytes, robot: Robot) -> PolicyAgent:
    """A policy of this format from the file's bytes (already checked against the record)."""
    from safetensors import SafetensorError
    from safetensors.numpy import load

    try:
        tensors = load(blob)
        size = int.from_bytes(blob[:8], "little")
        meta = json.loads(json.loads(blob[8:8 + size])["__metadata__"]["revolve"])
        if not isinstance(meta, dict) or meta.get("format") not in FORMATS:
            raise ValueError(f"not a format-{'/'.join(map(str, FORMATS))} policy")
        action, period = meta["action"], float(meta["control_period"])
        trained_on = from_json(str(meta["robot"]))
        if not same_body(trained_on, robot):  # before anything is built for it
            raise PolicyFileError(f"policy file {name} was trained on another body or network "
                                  "than this robot's")
        names = meta["parameters"]
        if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
            raise ValueError("no list of parameter names")
        state = {n: tensors[f"param/{n}"] for n in names}
        proprioception = meta["proprioception"] if meta["format"] == FORMAT else False
        if not isinstance(proprioception, bool):
            raise ValueError("its proprioception is not true or false")
        normalization = _normalization(meta, tensors, robot, proprioception)
        norm_keys = {"norm/mean", "norm/var"} if normalization is not None else set()
        if set(tensors) - {f"param/{n}" for n in names} - norm_keys - {
                k for k in tensors if k.startswith("space/")}:
            raise ValueError("tensors that are neither parameters, statistics nor space bounds")
        _check_sizes(meta["arguments"], state)
        arguments = _decode(meta["arguments"], "arguments", tensors)
        if not isinstance(arguments, dict):
            raise ValueError("its arguments are not a table")
        _check_spaces(arguments, robot, action, proprioception)
        policy = _build(str(meta["policy_class"]), arguments, state)
        return PolicyAgent(policy, trained_on, action, period, normalization, proprioception)
    except PolicyFileError:
        raise
    except (SafetensorError, ValueError, KeyError, TypeError, IndexError, AttributeError,
            RuntimeError, OverflowError, RecursionError, UnicodeDecodeError) as error:
        raise PolicyFileError(f"policy file {name} is damaged ({type(error).__name__}: "
                              f"{str(error).splitlines()[0] if str(error) else ''})") from None


def _normalization(meta: Mapping[str, Any], tensors: Mapping[str, np.ndarray], robot: Robot,
                   proprioception: bool) -> ObservationNormalization | None:
    """The frozen observation statistics of a format-3 file (``None``: there are none).

    Raises:
        ValueError, KeyError, TypeError: missing or malformed statistics, or not one per value
            of the policy's observation.
    """
    if meta["format"] != FORMAT or meta["normalization"] is None:
        return None
    table = meta["normalization"]
    if not isinstance(table, dict) or set(table) != {"clip", "epsilon"}:
        raise ValueError("its normalization is not a table of clip and epsilon")
    mean, var = tensors["norm/mean"], tensors["norm/var"]
    if mean.shape != (_observations(robot, proprioception),):
        raise ValueError("its observation statistics do not fit this robot's observation")
    return ObservationNormalization(mean, var, float(table["clip"]), float(table["epsilon"]))


def _check_sizes(arguments: object, state: Mapping[str, np.ndarray]) -> None:
    """Refuse layer sizes larger than any stored tensor (a huge network to allocate).

    Raises:
        ValueError: an integer argument exceeds every stored dimension.
    """
    largest = max((max(a.shape, default=1) for a in state.values()), default=1)

    def walk(value: object) -> None:
        if isinstance(value, bool):
            return
        if isinstance(value, int) and value > largest:
            raise ValueError(f"an argument of {value} exceeds every stored tensor's size")
        if isinstance(value, list):
            for v in value:
                walk(v)
        elif isinstance(value, dict):
            for v in value.values():
                walk(v)

    walk(arguments.get("net_arch") if isinstance(arguments, dict) else None)


def _decode(value: Any, key: str, tensors: Mapping[str, np.ndarray]) -> Any:
    """The constructor argument that :func:`_encode` wrote as ``value``.

    Raises:
        ValueError: an unknown class or space, or bounds that do not fit.
    """
    if isinstance(value, list):
        return [_decode(v, key, tensors) for v in value]
    if not isinstance(value, dict):
        return value
    if "__class__" in value:
        return _known_class(str(value["__class__"]))
    if "__box__" in value:
        from gymnasium.spaces import Box

        where = str(value["__box__"])
        low, high = tensors[f"space/{where}/low"], tensors[f"space/{where}/high"]
        shape = tuple(int(n) for n in value["shape"])
        dtype = np.dtype(str(value["dtype"]))
        if dtype.kind not in "fiub" or low.shape != shape or high.shape != shape:
            raise ValueError(f"the space {where} does not fit its bounds")
        return Box(low=low, high=high, shape=shape, dtype=dtype)
    if "__schedule__" in value:
        return _unused_schedule
    return {k: _decode(v, f"{key}.{k}", tensors) for k, v in value.items()}


def _unused_schedule(progress_remaining: float) -> float:
    """The learning rate of a loaded policy's optimizer, which is never stepped."""
    return 0.0


def _known_class(text: str) -> type:
    """A torch or SB3 class named ``module:Name``, among the modules already imported.

    Nothing is imported by name: a file cannot make this process import a module.

    Raises:
        ValueError: the name is malformed, outside torch and SB3, not imported, or not a torch
            module, torch optimizer or SB3 policy class.
    """
    import stable_baselines3  # noqa: F401 - imports the modules of its policies and layers
    import torch
    from stable_baselines3.common.policies import BasePolicy

    module, _, qualname = text.partition(":")
    if (not _MODULE.fullmatch(module) or not _NAME.fullmatch(qualname)
            or module.split(".")[0] not in _ROOTS or module not in sys.modules):
        raise ValueError(f"unknown class {text!r}")
    cls = getattr(sys.modules[module], qualname, None)
    if not isinstance(cls, type) or not issubclass(
            cls, (torch.nn.Module, torch.optim.Optimizer, BasePolicy)):
        raise ValueError(f"{text!r} is not a torch module, optimizer or SB3 policy class")
    return cls


def _observations(robot: Robot, proprioception: bool) -> int:
    """Values a policy observes: the robot's sensors, then with proprioception 2 per hinge."""
    hinges = len(robot.neurons_of(Layer.OUTPUT))
    return len(robot.neurons_of(Layer.INPUT)) + (2 * hinges if proprioception else 0)


def _check_spaces(arguments: Mapping[str, Any], robot: Robot, action: object,
                  proprioception: bool) -> None:
    """The spaces must be the robot's: its observation in, one or two values per hinge out.

    Raises:
        ValueError: they are not.
    """
    from gymnasium.spaces import Box

    if action not in ("targets", "modulate"):
        raise ValueError(f"unknown action mode {action!r}")
    inputs = _observations(robot, proprioception)
    outputs = len(robot.neurons_of(Layer.OUTPUT)) * (2 if action == "modulate" else 1)
    obs, act = arguments.get("observation_space"), arguments.get("action_space")
    if not (isinstance(obs, Box) and obs.shape == (inputs,) and isinstance(act, Box)
            and act.shape == (outputs,)):
        raise ValueError("its spaces do not fit this robot's sensors and hinges")


def _build(class_name: str, arguments: dict[str, Any], state: Mapping[str, np.ndarray]) -> Any:
    """The SB3 policy ``class_name(**arguments)`` with the parameters ``state``, for inference.

    Raises:
        ValueError: not an SB3 policy class.
        TypeError, RuntimeError: arguments or parameters that do not fit the class.
    """
    import torch
    from stable_baselines3.common.policies import BasePolicy

    cls = _known_class(class_name)
    if not issubclass(cls, BasePolicy):
        raise ValueError(f"{class_name!r} is not a stable-baselines3 policy")
    with torch.random.fork_rng(devices=[]):  # its initial weights draw from torch's generator
        policy = cls(**arguments)
    policy.load_state_dict({k: torch.from_numpy(np.array(v)) for k, v in state.items()},
                           strict=True)
    policy.set_training_mode(False)
    return policy

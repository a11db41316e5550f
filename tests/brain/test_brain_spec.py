"""NetworkSpec construction, validation and the learnable-parameter vector."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from brain_strategies import robots
from hypothesis import given, settings
from hypothesis import strategies as st

from revolve_env.body.robot import (
    Activation,
    Connection,
    Layer,
    Neuron,
    Node,
    PartType,
    Robot,
)
from revolve_env.brain import NetworkSpec, get_params, param_bounds, param_names, set_params
from revolve_env.brain.spec import KIND_INPUT

IN, OUT, HID = Layer.INPUT, Layer.OUTPUT, Layer.HIDDEN


def small_robot() -> Robot:
    """Core (one input) -> hinge (sigmoid output, hidden oscillator); hidden linear on the core."""
    hinge = Node(
        PartType.ACTIVE_HINGE,
        neurons=(
            Neuron("m", OUT, Activation.SIGMOID, bias=0.1, gain=2.0),
            Neuron("osc", HID, Activation.OSCILLATOR, period=2.0, phase_offset=0.25, amplitude=0.5),
        ),
    )
    core = Node(
        PartType.CORE,
        neurons=(
            Neuron("lin", HID, Activation.LINEAR, bias=-0.5, gain=1.5),
            Neuron("ax", IN, Activation.INPUT),
        ),
        children=((0, hinge),),
    )
    return Robot(
        core,
        (Connection("ax", "m", 0.5), Connection("m", "m", -1.0), Connection("osc", "lin", 1.5)),
    )


def test_spec_order_inputs_outputs_hidden() -> None:
    spec = NetworkSpec.from_robot(small_robot())
    assert spec.ids == ("ax", "m", "lin", "osc")
    assert (spec.n_inputs, spec.n_outputs) == (1, 1)
    assert spec.kinds.tolist() == [0, 2, 1, 3]
    assert spec.src.tolist() == [0, 1, 3] and spec.dst.tolist() == [1, 1, 2]
    assert not spec.weight.flags.writeable and not spec.neuron_params.flags.writeable


def test_param_layout_names_and_bounds() -> None:
    r = small_robot()
    assert param_names(r) == [
        "weight:ax->m", "weight:m->m", "weight:osc->lin",
        "bias:m", "gain:m", "bias:lin", "gain:lin",
        "period:osc", "phase_offset:osc", "amplitude:osc",
    ]
    np.testing.assert_array_equal(
        get_params(r), [0.5, -1.0, 1.5, 0.1, 2.0, -0.5, 1.5, 2.0, 0.25, 0.5]
    )
    b = param_bounds(r)
    assert b.shape == (10, 2)
    np.testing.assert_array_equal(b[0], [-2.0, 2.0])  # weight
    np.testing.assert_array_equal(b[4], [0.0, 4.0])  # gain
    np.testing.assert_array_equal(b[7], [0.25, 4.0])  # period


def test_set_params_writes_into_the_tree() -> None:
    r = small_robot()
    new = set_params(r, [1.0, 1.1, 1.2, 0.2, 3.0, 0.3, 0.5, 1.0, 0.5, 0.75])
    assert [c.weight for c in new.connections] == [1.0, 1.1, 1.2]
    m, osc = new.node((0,)).neurons
    lin = new.body.neurons[0]
    assert (m.bias, m.gain, lin.bias, lin.gain) == (0.2, 3.0, 0.3, 0.5)
    assert (osc.period, osc.phase_offset, osc.amplitude) == (1.0, 0.5, 0.75)
    # Parameters that the activation ignores are left alone.
    assert m.period == r.node((0,)).neurons[0].period


@given(robots(), st.integers(0, 2**32 - 1))
@settings(max_examples=60, deadline=None)
def test_params_round_trip_through_robot(robot: Robot, seed: int) -> None:
    spec = NetworkSpec.from_robot(robot)
    p0 = get_params(robot)
    assert p0.dtype == np.float64 and p0.shape == (spec.n_params,)
    names = param_names(robot)
    assert len(names) == len(set(names)) == spec.n_params
    bounds = param_bounds(robot)
    assert ((bounds[:, 0] <= p0) & (p0 <= bounds[:, 1])).all()
    assert set_params(robot, p0) == robot  # writing back the same values changes nothing

    rng = np.random.default_rng(seed)
    p = rng.uniform(bounds[:, 0], bounds[:, 1])
    new = set_params(robot, p)
    np.testing.assert_array_equal(get_params(new), p)
    np.testing.assert_array_equal(NetworkSpec.from_robot(new).params(), p)
    np.testing.assert_array_equal(spec.with_params(p).params(), p)
    # Structure is untouched: same neurons in the same places, same connection ends.
    assert [(n.id, n.layer, n.activation) for n in new.neurons()] == [
        (n.id, n.layer, n.activation) for n in robot.neurons()
    ]
    assert [(c.src, c.dst) for c in new.connections] == [(c.src, c.dst) for c in robot.connections]
    assert new.num_parts() == robot.num_parts()


@given(robots())
@settings(max_examples=30, deadline=None)
def test_spec_io_order_matches_robot_layers(robot: Robot) -> None:
    spec = NetworkSpec.from_robot(robot)
    k, m = spec.n_inputs, spec.n_outputs
    assert list(spec.ids[:k]) == [n.id for n in robot.neurons_of(IN)]
    assert list(spec.ids[k : k + m]) == [n.id for n in robot.neurons_of(OUT)]
    assert (spec.kinds[:k] == KIND_INPUT).all() and (spec.kinds[k:] != KIND_INPUT).all()
    assert (spec.dst >= k).all()


# -- bad input ---------------------------------------------------------------------------------
def _with_core_neuron(r: Robot, **changes: object) -> Robot:
    lin = replace(r.body.neurons[0], **changes)
    return replace(r, body=replace(r.body, neurons=(lin, *r.body.neurons[1:])))


@pytest.mark.parametrize(
    ("robot", "message"),
    [
        (replace(small_robot(), connections=(Connection("ax", "ghost", 1.0),)),
         "missing neuron 'ghost'"),
        (replace(small_robot(), connections=(Connection("nope", "m", 1.0),)),
         "missing neuron 'nope'"),
        (replace(small_robot(), connections=(Connection("m", "ax", 1.0),)),
         "ends in an input neuron"),
        (replace(small_robot(), connections=(Connection("ax", "m", math.nan),)), "weight nan"),
        (replace(small_robot(), connections=(Connection("ax", "m", math.inf),)), "weight inf"),
        (_with_core_neuron(small_robot(), bias=math.nan), "'lin' has bias = nan"),
        (_with_core_neuron(small_robot(), id="ax"), "duplicate neuron id 'ax'"),
        (_with_core_neuron(small_robot(), activation=Activation.INPUT), "'lin'"),
        (_with_core_neuron(small_robot(), activation=Activation.OSCILLATOR, period=0.0), "period"),
        (_with_core_neuron(small_robot(), layer=IN), "'lin'"),
    ],
)
def test_invalid_networks_are_rejected_with_a_clear_message(robot: Robot, message: str) -> None:
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        NetworkSpec.from_robot(robot)


@pytest.mark.parametrize("bad", [[0.0] * 9, [0.0] * 11, [[0.0] * 10]])
def test_params_of_the_wrong_length_are_rejected(bad: list) -> None:
    with pytest.raises(ValueError, match=r"expected \(10,\)"):
        set_params(small_robot(), bad)


def test_params_with_nan_or_bad_period_are_rejected() -> None:
    p = get_params(small_robot())
    p[3] = np.nan
    with pytest.raises(ValueError, match=r"params\[3\] \(bias:m\) is nan"):
        set_params(small_robot(), p)
    p = get_params(small_robot())
    p[7] = -1.0
    with pytest.raises(ValueError, match="period"):
        set_params(small_robot(), p)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"kinds": [0, 257]}, "'b' has an unknown kind"),  # 257 as int8 would read as linear
        ({"src": [2**32]}, "source index out of range"),  # 2**32 as int32 would read as 0
        ({"dst": [2**32 + 1]}, "destination index out of range"),
    ],
)
def test_from_arrays_rejects_values_that_a_narrowing_cast_would_wrap(
        change: dict, message: str) -> None:
    arrays = {"ids": ["a", "b"], "kinds": [0, 1], "neuron_params": np.zeros((2, 5)), "src": [0],
              "dst": [1], "weight": [1.0], "n_inputs": 1, "n_outputs": 1}
    NetworkSpec.from_arrays(**arrays)  # valid as given
    with pytest.raises(ValueError, match=message):
        NetworkSpec.from_arrays(**{**arrays, **change})

"""Compiled BatchController against the NumPy reference and against hand-computed values."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest
from brain_strategies import robots
from hypothesis import given, settings
from hypothesis import strategies as st
from test_brain_spec import small_robot

from revolve_env import _controller
from revolve_env.body.robot import Activation, Connection, Layer, Neuron, Node, PartType, Robot
from revolve_env.brain import BatchController, NetworkSpec, ReferenceBatchController

CONTROLLERS = [BatchController, ReferenceBatchController]
DT = 0.05  # seconds
# Both do the same floating-point operations in the same order (on the development machine the
# results are bitwise equal); exp and sin may still differ in the last bit between the C library
# and NumPy on other platforms, hence a tolerance rather than equality.
TOL = {"rtol": 1e-9, "atol": 1e-9}


def run(ctrl: BatchController | ReferenceBatchController, inputs: np.ndarray) -> np.ndarray:
    """Step ``ctrl`` once per row of ``inputs``; the outputs of every tick, stacked."""
    out = np.empty(ctrl.n_outputs)
    rows = []
    for x in inputs:
        ctrl.step(np.ascontiguousarray(x), out)
        rows.append(out.copy())
    return np.array(rows).reshape(len(inputs), ctrl.n_outputs)


def sensor_values(rng: np.random.Generator, ticks: int, n: int) -> np.ndarray:
    return rng.uniform(-1.0, 1.0, size=(ticks, n))


@pytest.mark.parametrize("cls", CONTROLLERS)
def test_hand_computed_ticks(cls: type) -> None:
    """small_robot(): m = sigmoid(2 (0.5 ax - m_prev - 0.1));
    lin = clip(1.5 (1.5 osc_prev + 0.5), 0, 1).

    From the second tick on, ``lin`` would exceed 1 (up to 2.4) without the clip: the linear
    neuron's saturation is part of the hand computation.
    """
    ctrl = cls(0.1)
    h = ctrl.add(small_robot())
    out = np.zeros(1)
    m = lin = osc = 0.0
    for k in range(6):
        t = 0.1 * k
        ax = 0.3 * k
        ctrl.step(np.array([ax]), out)
        m, lin, osc = (
            1.0 / (1.0 + math.exp(-2.0 * (0.5 * ax - 1.0 * m - 0.1))),
            min(max(1.5 * (1.5 * osc + 0.5), 0.0), 1.0),
            0.5 - 0.25 + 0.5 * (math.sin(2 * math.pi / 2.0 * (t - 2.0 * 0.25)) + 1) / 2,
        )
        assert out[0] == pytest.approx(2 * m - 1, abs=1e-12)
        np.testing.assert_allclose(ctrl.get_state(h), [ax, m, lin, osc], atol=1e-12)
        assert ctrl.time(h) == pytest.approx(0.1 * (k + 1))


@pytest.mark.parametrize("cls", CONTROLLERS)
def test_outputs_are_clipped_targets(cls: type) -> None:
    """A linear output driven far past the range saturates at +-1; a bias of 0.5 maps to 0."""
    core = Node(
        PartType.CORE,
        neurons=(
            Neuron("in", Layer.INPUT, Activation.INPUT),
            Neuron("big", Layer.OUTPUT, Activation.LINEAR, gain=4.0),
            Neuron("mid", Layer.OUTPUT, Activation.LINEAR, bias=-0.5, gain=1.0),
        ),
    )
    ctrl = cls(DT)
    ctrl.add(Robot(core, (Connection("in", "big", 2.0),)))
    out = np.zeros(2)
    ctrl.step(np.array([5.0]), out)
    np.testing.assert_array_equal(out, [1.0, 0.0])
    ctrl.step(np.array([-5.0]), out)
    np.testing.assert_array_equal(out, [-1.0, 0.0])


@pytest.mark.parametrize("cls", CONTROLLERS)
def test_recurrent_linear_loop_saturates_instead_of_diverging(cls: type) -> None:
    """A linear self-loop with gain x weight = 8 > 1 (it used to double-and-more every tick until
    inf, then NaN) stays in [0, 1]: 1 when driven up, 0 when driven down, never non-finite."""
    core = Node(
        PartType.CORE,
        neurons=(
            Neuron("in", Layer.INPUT, Activation.INPUT),
            Neuron("loop", Layer.OUTPUT, Activation.LINEAR, bias=0.0, gain=4.0),
            Neuron("echo", Layer.HIDDEN, Activation.LINEAR, bias=-0.5, gain=4.0),
        ),
    )
    conns = (Connection("in", "loop", 1.0), Connection("loop", "loop", 2.0),
             Connection("echo", "echo", 2.0), Connection("loop", "echo", -2.0))
    ctrl = cls(DT)
    h = ctrl.add(Robot(core, conns))
    out = np.zeros(1)
    for _ in range(2000):  # unclamped, 8**2000 overflows within a few hundred ticks
        ctrl.step(np.array([1.0]), out)
    state = ctrl.get_state(h)
    assert out[0] == 1.0 and state[1] == 1.0
    assert 0.0 <= state[2] <= 1.0
    for _ in range(2000):  # -3 + 2 x 1 < 0: the latch lets go and stays at 0
        ctrl.step(np.array([-3.0]), out)
    assert np.isfinite(ctrl.get_state(h)).all()
    assert out[0] == -1.0


@pytest.mark.parametrize("cls", CONTROLLERS)
def test_nan_sensor_values_still_show_in_the_outputs(cls: type) -> None:
    """The clamp hides no NaN: a NaN sensor value reaches the hinge target (the world then
    reports a blow-up), in both controllers alike."""
    core = Node(
        PartType.CORE,
        neurons=(
            Neuron("in", Layer.INPUT, Activation.INPUT),
            Neuron("lin", Layer.OUTPUT, Activation.LINEAR, gain=1.0),
        ),
    )
    ctrl = cls(DT)
    ctrl.add(Robot(core, (Connection("in", "lin", 1.0),)))
    out = np.zeros(1)
    ctrl.step(np.array([np.nan]), out)
    assert np.isnan(out[0])


@given(robots(), st.integers(0, 2**32 - 1), st.sampled_from([1.0, 1e3, 1e150]))
@settings(max_examples=40, deadline=None)
def test_every_value_stays_in_unit_interval_and_matches_reference(
    robot: Robot, seed: int, scale: float
) -> None:
    """Any network within the parameter bounds, fed sensor values up to ``scale`` in size, keeps
    every non-input neuron in [0, 1] (linear ones by their clamp, the others by their formulas)
    and every output finite, identically in the compiled controller and the reference."""
    ticks = 150
    fast, ref = BatchController(DT), ReferenceBatchController(DT)
    hf, hr = fast.add(robot), ref.add(robot)
    x = scale * sensor_values(np.random.default_rng(seed), ticks, fast.n_inputs)
    yf, yr = run(fast, x), run(ref, x)
    np.testing.assert_allclose(yf, yr, rtol=TOL["rtol"], atol=TOL["atol"])
    assert np.isfinite(yf).all()
    n_in = fast.n_inputs
    for ctrl, h in ((fast, hf), (ref, hr)):
        values = ctrl.get_state(h)[n_in:]
        assert ((values >= 0.0) & (values <= 1.0)).all(), values


@given(robots(), st.integers(0, 2**32 - 1))
@settings(max_examples=60, deadline=None)
def test_compiled_equals_reference(robot: Robot, seed: int) -> None:
    ticks = 300  # 15 s of robot time: many oscillator periods, recurrence well exercised
    fast, ref = BatchController(DT), ReferenceBatchController(DT)
    hf, hr = fast.add(robot), ref.add(robot)
    x = sensor_values(np.random.default_rng(seed), ticks, fast.n_inputs)
    np.testing.assert_allclose(run(fast, x), run(ref, x), **TOL)
    np.testing.assert_allclose(fast.get_state(hf), ref.get_state(hr), **TOL)
    assert fast.time(hf) == ref.time(hr)


@given(st.lists(robots(), min_size=1, max_size=5), st.integers(0, 2**32 - 1))
@settings(max_examples=30, deadline=None)
def test_batch_equals_each_alone(batch: list[Robot], seed: int) -> None:
    ticks = 60
    for cls in CONTROLLERS:
        together = cls(DT)
        handles = [together.add(r) for r in batch]
        x = sensor_values(np.random.default_rng(seed), ticks, together.n_inputs)
        y = run(together, x)
        for h, r in zip(handles, batch, strict=True):
            alone = cls(DT)
            alone.add(r)
            np.testing.assert_array_equal(
                run(alone, x[:, together.input_slice(h)]), y[:, together.output_slice(h)]
            )


@given(st.lists(robots(), min_size=4, max_size=4), st.integers(0, 2**32 - 1))
@settings(max_examples=20, deadline=None)
def test_add_and_remove_between_ticks(four: list[Robot], seed: int) -> None:
    """Population changes keep every survivor's state, time and slot contents."""
    for cls in CONTROLLERS:
        _check_add_remove(cls, four, np.random.default_rng(seed))


def _check_add_remove(cls: type, four: list[Robot], rng: np.random.Generator) -> None:
    batch = cls(DT)
    alone: dict[int, BatchController | ReferenceBatchController] = {}

    def add(r: Robot) -> None:
        single = cls(DT)
        single.add(r)
        alone[batch.add(r)] = single

    def tick() -> None:
        x = rng.uniform(-1, 1, batch.n_inputs)
        y = np.full(batch.n_outputs, np.nan)
        batch.step(x, y)
        for h, single in alone.items():
            want = np.empty(single.n_outputs)
            single.step(np.ascontiguousarray(x[batch.input_slice(h)]), want)
            np.testing.assert_array_equal(y[batch.output_slice(h)], want)

    for r in four[:3]:
        add(r)
    tick(), tick()
    first, middle = batch.handles[0], batch.handles[1]
    batch.remove(middle)
    del alone[middle]
    tick()
    add(four[3])
    tick()
    batch.remove(first)
    del alone[first]
    tick(), tick()
    assert batch.handles == list(alone)
    assert middle not in batch.handles and max(batch.handles) == 3  # handles are never reused
    assert batch.n_inputs == sum(s.n_inputs for s in alone.values())


@pytest.mark.parametrize("cls", CONTROLLERS)
def test_reset_restarts_state_and_time(cls: type) -> None:
    x = sensor_values(np.random.default_rng(1), 20, 1)
    ctrl = cls(DT)
    h = ctrl.add(small_robot())
    first = run(ctrl, x)
    ctrl.reset(h)
    assert ctrl.time(h) == 0.0 and not ctrl.get_state(h).any()
    np.testing.assert_array_equal(run(ctrl, x), first)
    ctrl.reset()
    np.testing.assert_array_equal(run(ctrl, x), first)


@given(st.lists(robots(), min_size=3, max_size=3), st.integers(0, 2**32 - 1))
@settings(max_examples=20, deadline=None)
def test_set_state_continues_a_saved_network_bit_for_bit(three: list[Robot], seed: int) -> None:
    """A checkpoint's controller: state and time copied into a rebuilt batch (the survivors
    added again in the same order) tick exactly as the original batch goes on."""
    rng = np.random.default_rng(seed)
    for cls in CONTROLLERS:
        original = cls(DT)
        handles = [original.add(r) for r in three]
        run(original, sensor_values(rng, 7, original.n_inputs))
        original.remove(handles[0])
        run(original, sensor_values(rng, 3, original.n_inputs))
        rebuilt = cls(DT)
        for h, r in zip(handles[1:], three[1:], strict=True):
            twin = rebuilt.add(r)
            rebuilt.set_state(twin, original.get_state(h), original.time(h))
            assert rebuilt.time(twin) == original.time(h)
            np.testing.assert_array_equal(rebuilt.get_state(twin), original.get_state(h))
        x = sensor_values(rng, 20, original.n_inputs)
        np.testing.assert_array_equal(run(rebuilt, x), run(original, x))


@pytest.mark.parametrize("cls", CONTROLLERS)
def test_set_state_refuses_bad_values(cls: type) -> None:
    ctrl = cls(DT)
    h = ctrl.add(small_robot())
    n = len(ctrl.get_state(h))
    with pytest.raises(ValueError, match="neuron values"):
        ctrl.set_state(h, np.zeros(n + 1), 0.0)
    with pytest.raises(ValueError, match="finite"):
        ctrl.set_state(h, np.zeros(n), math.nan)
    with pytest.raises(KeyError):
        ctrl.set_state(h + 1, np.zeros(n), 0.0)


@given(robots(), st.integers(0, 2**32 - 1))
@settings(max_examples=30, deadline=None)
def test_set_params_mid_run_matches_reference_and_keeps_state(robot: Robot, seed: int) -> None:
    rng = np.random.default_rng(seed)
    fast, ref = BatchController(DT), ReferenceBatchController(DT)
    hf, hr = fast.add(robot), ref.add(robot)
    x = sensor_values(rng, 40, fast.n_inputs)
    run(fast, x[:20]), run(ref, x[:20])
    before = fast.get_state(hf)
    b = fast.param_bounds(hf)
    p = rng.uniform(b[:, 0], b[:, 1])
    fast.set_params(hf, p)
    ref.set_params(hr, p)
    np.testing.assert_array_equal(fast.get_params(hf), p)
    np.testing.assert_array_equal(fast.get_state(hf), before)
    assert fast.param_names(hf) == NetworkSpec.from_robot(robot).param_names()
    np.testing.assert_allclose(run(fast, x[20:]), run(ref, x[20:]), **TOL)


def test_step_writes_in_place_and_leaves_inputs_alone() -> None:
    ctrl = BatchController(DT)
    ctrl.add(small_robot())
    ctrl.add(small_robot())
    x = np.array([0.2, -0.4])
    x.setflags(write=False)  # read-only inputs are fine
    out = np.full(2, 7.0)
    ctrl.step(x, out)
    assert (out != 7.0).all() and np.abs(out).max() <= 1.0
    np.testing.assert_array_equal(x, [0.2, -0.4])


def _chain(n: int) -> NetworkSpec:
    """One input feeding a chain of ``n - 1`` linear neurons (the first is the output)."""
    params = np.zeros((n, 5))
    params[:, 1] = 1.0  # gain
    return NetworkSpec.from_arrays(
        ids=[f"n{i}" for i in range(n)], kinds=[0] + [1] * (n - 1), neuron_params=params,
        src=np.arange(n - 1), dst=np.arange(1, n), weight=np.full(n - 1, 0.5),
        n_inputs=1, n_outputs=1,
    )


def test_population_changes_from_another_thread_wait_for_a_released_step() -> None:
    """A large batch steps with the GIL released; add/set_params/remove from another thread are
    serialised with it (unserialised, a repack would free the state arrays under the step)."""
    ctrl = BatchController(DT)
    big = ctrl.add(_chain(1500))  # 1500 neurons + 1499 connections: above the release threshold
    stop = threading.Event()
    ticks = 0
    unexpected: list[Exception] = []

    def stepper() -> None:
        nonlocal ticks
        while not stop.is_set():
            x, y = np.zeros(ctrl.n_inputs), np.empty(ctrl.n_outputs)
            try:
                ctrl.step(x, y)
                ticks += 1
            except ValueError as e:  # sizes read before another thread changed the population
                if "length" not in str(e) and "changed" not in str(e):
                    unexpected.append(e)

    thread = threading.Thread(target=stepper)
    thread.start()
    try:
        for _ in range(300):
            h = ctrl.add(small_robot())
            ctrl.set_params(h, ctrl.get_params(h))
            ctrl.remove(h)
    finally:
        stop.set()
        thread.join()
    assert not unexpected and ticks > 0
    assert ctrl.handles == [big]
    assert ctrl.time(big) == pytest.approx(ticks * DT)  # every step counted once, none lost


# -- bad input ---------------------------------------------------------------------------------
@pytest.mark.parametrize("cls", CONTROLLERS)
def test_bad_step_arrays_raise_value_error(cls: type) -> None:
    ctrl = cls(DT)
    ctrl.add(small_robot())
    ctrl.add(small_robot())
    good_in, good_out = np.zeros(2), np.zeros(2)
    read_only = np.zeros(2)
    read_only.setflags(write=False)
    bad_pairs = [
        (np.zeros(3), good_out),
        (good_in, np.zeros(1)),
        (np.zeros((2, 1)), good_out),
        (np.zeros(2, np.float32), good_out),
        (good_in, np.zeros(2, np.float32)),
        (np.zeros(4)[::2], good_out),
        (good_in, np.zeros(4)[::2]),
        ([0.0, 0.0], good_out),
        (good_in, read_only),
    ]
    for x, y in bad_pairs:
        with pytest.raises(ValueError):
            ctrl.step(x, y)  # type: ignore[arg-type]


@pytest.mark.parametrize("cls", CONTROLLERS)
def test_unknown_handles_and_bad_params(cls: type) -> None:
    ctrl = cls(DT)
    h = ctrl.add(small_robot())
    ctrl.remove(h)
    for call in (ctrl.remove, ctrl.reset, ctrl.get_params, ctrl.input_slice, ctrl.output_slice):
        with pytest.raises(KeyError):
            call(h)
    h = ctrl.add(small_robot())
    with pytest.raises(ValueError, match="expected"):
        ctrl.set_params(h, np.zeros(3))
    p = ctrl.get_params(h)
    p[0] = np.inf
    with pytest.raises(ValueError, match="inf"):
        ctrl.set_params(h, p)
    np.testing.assert_array_equal(
        ctrl.get_params(h), NetworkSpec.from_robot(small_robot()).params())
    with pytest.raises(ValueError, match="dt"):
        cls(0.0)
    with pytest.raises(TypeError):
        ctrl.add("robot")  # type: ignore[arg-type]


def _raw_args() -> dict:
    spec = NetworkSpec.from_robot(small_robot())
    return {
        "kinds": np.array(spec.kinds), "neuron_params": np.array(spec.neuron_params),
        "src": np.array(spec.src), "dst": np.array(spec.dst), "weight": np.array(spec.weight),
        "n_inputs": spec.n_inputs, "n_outputs": spec.n_outputs,
    }


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"src": np.array([0, 1, 9], np.int32)}, "missing source"),
        ({"dst": np.array([1, 1, -1], np.int32)}, "missing destination"),
        ({"dst": np.array([1, 0, 2], np.int32)}, "input neuron"),
        ({"weight": np.array([0.0, np.nan, 0.0])}, "weight"),
        ({"weight": np.zeros(2)}, "same length"),
        ({"kinds": np.array([0, 2, 1, 7], np.int8)}, "unknown kind"),
        ({"kinds": np.array([0, 0, 1, 3], np.int8)}, "input neurons"),
        ({"neuron_params": np.zeros((4, 4))}, "shape"),
        ({"neuron_params": np.zeros((4, 5))}, "period"),  # oscillator with period 0
        ({"n_inputs": 3, "n_outputs": 2}, "sizes"),
    ],
)
def test_compiled_module_validates_raw_networks(change: dict, message: str) -> None:
    """Calling the C++ module directly with broken arrays raises instead of crashing."""
    ctrl = _controller.BatchController(DT)
    with pytest.raises(ValueError, match=message):
        ctrl.add(**{**_raw_args(), **change})
    assert len(ctrl) == 0
    h = ctrl.add(**_raw_args())
    with pytest.raises(ValueError):
        ctrl.set_params(h, np.zeros((3, 5)), np.zeros(3))
    with pytest.raises(ValueError, match="period"):
        ctrl.set_params(h, np.zeros((4, 5)), np.zeros(3))


def test_vectorised_exp_is_within_two_ulp_of_numpy() -> None:
    """The compiled sigmoid uses its own vectorised exp; it must be as accurate as libm's."""
    rng = np.random.default_rng(3)
    x = np.concatenate([
        rng.uniform(-40, 40, 200_000), rng.uniform(-745.5, 710, 200_000),
        [0.0, -0.0, 1e-300, 709.78, 709.79, -745.0, -745.2, 1000.0, -1000.0,
         np.inf, -np.inf, np.nan],
    ])
    out = np.empty_like(x)
    _controller.exp_into(x, out)
    with np.errstate(over="ignore"):
        want = np.exp(x)
    np.testing.assert_array_equal(np.isnan(out), np.isnan(want))
    np.testing.assert_array_equal(np.isinf(out), np.isinf(want))
    finite = np.isfinite(want) & (want > 0)
    ulps = np.abs(out[finite].view(np.int64) - want[finite].view(np.int64))
    assert ulps.max() <= 2
    np.testing.assert_array_equal(out[want == 0], 0.0)


def test_vectorised_sin_matches_numpy() -> None:
    """The compiled oscillators use their own vectorised sin (libm beyond |x| = 1e6)."""
    rng = np.random.default_rng(4)
    x = np.concatenate([
        rng.uniform(-10, 10, 200_000), rng.uniform(-1e6, 1e6, 200_000),
        rng.uniform(-1e9, 1e9, 1000), np.arange(-2000, 2000) * (np.pi / 2),
        [0.0, -0.0, 1e-300, np.inf, -np.inf, np.nan],
    ])
    out = np.empty_like(x)
    _controller.sin_into(x, out)
    with np.errstate(invalid="ignore"):  # sin(+-inf) is NaN on purpose here
        want = np.sin(x)
    np.testing.assert_array_equal(np.isnan(out), np.isnan(want))
    np.testing.assert_allclose(out, want, rtol=0, atol=2e-15)
    small = np.abs(x) < 1.0  # no cancellation in the reduction: relative accuracy too
    np.testing.assert_allclose(out[small], want[small], rtol=4e-16, atol=1e-300)

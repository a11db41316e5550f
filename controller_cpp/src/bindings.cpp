// Python bindings of the compiled controller (module revolve_env._controller).
//
// Everything coming from Python is checked here or in BatchController::add/set_params before any
// pointer is used, so bad input raises a Python exception and never crashes the interpreter.
// Use it through revolve_env.brain.BatchController, which adds NetworkSpec handling.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <mutex>
#include <optional>

#include "revolve/batch_controller.hpp"
#include "revolve/fast_math.hpp"
#include "revolve/network_view.hpp"

namespace nb = nanobind;
using revolve::BatchController;

namespace {

template <typename T>
using Vec = nb::ndarray<const T, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using Mat = nb::ndarray<const double, nb::ndim<2>, nb::c_contig, nb::device::cpu>;

// Above this many (neurons + connections) the step releases the GIL; below it the release and
// re-acquisition would cost more than the work.
constexpr std::int64_t kReleaseGilAbove = 2000;

// The controller and the lock that serialises every call on it. A large step runs with the GIL
// released, so another Python thread may call into the same object meanwhile; without the lock an
// add, remove or set_params (which repack, reallocating the state arrays) would free memory under
// the running step, and two steps would race on the state.
struct Locked {
    explicit Locked(double dt) : c(dt) {}
    BatchController c;
    std::mutex mu;
};
using Guard = std::lock_guard<std::mutex>;

template <typename Array>
void check_vector(const Array& a, const char* name, std::int64_t n) {
    if (a.device_type() != nb::device::cpu::value || a.dtype() != nb::dtype<double>() || a.ndim() != 1) {
        throw nb::value_error((std::string(name) + " must be a 1-D float64 NumPy array").c_str());
    }
    if (static_cast<std::int64_t>(a.shape(0)) != n) {
        throw nb::value_error((std::string(name) + " has length " + std::to_string(a.shape(0)) +
                               ", expected " + std::to_string(n)).c_str());
    }
    if (n > 1 && a.stride(0) != 1) throw nb::value_error((std::string(name) + " must be contiguous").c_str());
}

void step(Locked& l, nb::ndarray<nb::ro> inputs, nb::ndarray<> outputs) {
    // inputs may be read-only; outputs may not (nanobind rejects read-only arrays without nb::ro).
    // The ndarray handles keep both arrays alive while the GIL is released.
    const double* in = static_cast<const double*>(inputs.data());
    double* out = static_cast<double*>(outputs.data());
    bool release = false;
    {
        Guard g(l.mu);  // sizes checked under the lock: no repack between the check and the step
        check_vector(inputs, "inputs", l.c.n_inputs());
        check_vector(outputs, "outputs", l.c.n_outputs());
        release = l.c.work() > kReleaseGilAbove;
        if (!release) {
            l.c.step(in, out);
            return;
        }
    }
    // Lock taken after the release: this thread never waits for the lock while holding the GIL
    // another thread needs to finish a call and unlock. Sizes are re-checked, since another thread
    // may have changed the population between the two locks.
    nb::gil_scoped_release unlocked;
    Guard g(l.mu);
    if (l.c.n_inputs() != static_cast<std::int64_t>(inputs.shape(0)) ||
        l.c.n_outputs() != static_cast<std::int64_t>(outputs.shape(0))) {
        throw std::invalid_argument("the population changed in another thread during step");
    }
    l.c.step(in, out);
}

std::int64_t add(Locked& l, Vec<std::int8_t> kinds, Mat neuron_params, Vec<std::int32_t> src,
                 Vec<std::int32_t> dst, Vec<double> weight, std::int64_t n_inputs, std::int64_t n_outputs) {
    const revolve::NetworkView v = revolve::network_view(kinds, neuron_params, src, dst, weight, n_inputs, n_outputs);
    Guard g(l.mu);
    return l.c.add(v);
}

void set_params(Locked& l, std::int64_t handle, Mat neuron_params, Vec<double> weight) {
    Guard g(l.mu);
    l.c.set_params(handle, neuron_params.data(), static_cast<std::int64_t>(neuron_params.size()), weight.data(),
                 static_cast<std::int64_t>(weight.shape(0)));
}

void set_state(Locked& l, std::int64_t handle, Vec<double> values, double time) {
    Guard g(l.mu);
    l.c.set_state(handle, values.data(), static_cast<std::int64_t>(values.shape(0)), time);
}

}  // namespace

// The population env's per-agent reports (reports.cpp, the one user of NumPy's C API).
void register_reports(nb::module_& m);

NB_MODULE(_controller, m) {
    m.doc() = "revolve-env compiled neural controller (use revolve_env.brain.BatchController)";
    m.attr("ABI_VERSION") = 2;
    m.attr("KIND_INPUT") = static_cast<int>(revolve::kInput);
    m.attr("KIND_LINEAR") = static_cast<int>(revolve::kLinear);
    m.attr("KIND_SIGMOID") = static_cast<int>(revolve::kSigmoid);
    m.attr("KIND_OSCILLATOR") = static_cast<int>(revolve::kOscillator);

    m.def(
        "exp_into",
        [](Vec<double> x, nb::ndarray<double, nb::ndim<1>, nb::c_contig, nb::device::cpu> out) {
            if (x.shape(0) != out.shape(0)) throw nb::value_error("x and out must have the same length");
            revolve::exp_array(x.data(), out.data(), x.shape(0));
        },
        nb::arg("x"), nb::arg("out").noconvert(),
        "out[:] = exp(x) with the controller's vectorised exp (exposed for its accuracy test).");

    m.def(
        "sin_into",
        [](Vec<double> x, nb::ndarray<double, nb::ndim<1>, nb::c_contig, nb::device::cpu> out) {
            if (x.shape(0) != out.shape(0)) throw nb::value_error("x and out must have the same length");
            revolve::sin_array(x.data(), out.data(), x.shape(0));
        },
        nb::arg("x"), nb::arg("out").noconvert(),
        "out[:] = sin(x) with the controller's vectorised sin (exposed for its accuracy test).");

    register_reports(m);

    nb::register_exception_translator([](const std::exception_ptr& p, void*) {
        try {
            std::rethrow_exception(p);
        } catch (const revolve::UnknownHandle& e) {
            PyErr_SetString(PyExc_KeyError, e.what());
        }
    });

    nb::class_<Locked>(m, "BatchController", "Networks of many robots stepped in one call.")
        .def(nb::init<double>(), nb::arg("dt"), "dt: control period, seconds (> 0).")
        .def("add", &add, nb::arg("kinds"), nb::arg("neuron_params"), nb::arg("src"), nb::arg("dst"),
             nb::arg("weight"), nb::arg("n_inputs"), nb::arg("n_outputs"),
             "Add a network (spec order: inputs, outputs, hidden); returns its handle.")
        .def(
            "remove", [](Locked& l, std::int64_t h) { Guard g(l.mu); l.c.remove(h); }, nb::arg("handle"))
        .def(
            "reset",
            [](Locked& l, std::optional<std::int64_t> h) {
                Guard g(l.mu);
                if (h) l.c.reset(*h); else l.c.reset_all();
            },
            nb::arg("handle") = nb::none(), "State 0 and time 0 for one network, or all.")
        .def("set_params", &set_params, nb::arg("handle"), nb::arg("neuron_params"), nb::arg("weight"))
        .def("step", &step, nb::arg("inputs"), nb::arg("outputs"),
             "Advance every network one tick, writing hinge targets in [-1, 1] into outputs in place.")
        .def_prop_ro("dt", [](Locked& l) { return l.c.dt(); })
        .def_prop_ro("n_inputs", [](Locked& l) { Guard g(l.mu); return l.c.n_inputs(); })
        .def_prop_ro("n_outputs", [](Locked& l) { Guard g(l.mu); return l.c.n_outputs(); })
        .def("__len__", [](Locked& l) { Guard g(l.mu); return l.c.size(); })
        .def("handles", [](Locked& l) { Guard g(l.mu); return l.c.handles(); })
        .def(
            "input_offset", [](Locked& l, std::int64_t h) { Guard g(l.mu); return l.c.input_offset(h); },
            nb::arg("handle"))
        .def(
            "output_offset", [](Locked& l, std::int64_t h) { Guard g(l.mu); return l.c.output_offset(h); },
            nb::arg("handle"))
        .def("state", [](Locked& l, std::int64_t h) { Guard g(l.mu); return l.c.state(h); }, nb::arg("handle"))
        .def("time", [](Locked& l, std::int64_t h) { Guard g(l.mu); return l.c.time(h); }, nb::arg("handle"))
        .def("set_state", &set_state, nb::arg("handle"), nb::arg("values"), nb::arg("time"),
             "Overwrite one network's neuron values (spec order) and time (seconds).");
}

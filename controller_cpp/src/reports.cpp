// The living robots' part of a population env step's five dicts, in one call
// (revolve_env/envs/reports.py, report_step): what the Python loop did per agent (slices of the
// observation copy, position rows, trajectory views, a copy of each info template with the values
// of the period written in, the rewards as floats), with the same objects as a result: the arrays
// are views made as NumPy's slicing makes them (same base, dtype, strides and flags), the values
// Python floats, bools and ints of the same bits.
//
// Only this file uses NumPy's C API (its table is static here); everything is checked before a
// pointer is used, so a wrong argument raises TypeError/ValueError, never a crash.
#include <nanobind/nanobind.h>

#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
// Built against NumPy 2's headers, it runs on the numpy>=1.26 the package asks for: the C API
// of 1.25/1.26 named, not left to the headers' default (which follows NumPy's own support).
#define NPY_TARGET_VERSION NPY_1_25_API_VERSION
#include <numpy/arrayobject.h>

#include <cstdint>
#include <string>

namespace nb = nanobind;

namespace {

// A 1-D array of `type` (native byte order, aligned) and length `n`, any strides: its first
// element and its stride in bytes.
struct Column {
    const char* data;
    npy_intp stride;
};

PyArrayObject* as_array(nb::handle h, const char* name) {
    if (!PyArray_Check(h.ptr())) throw nb::type_error((std::string(name) + " must be a numpy array").c_str());
    return reinterpret_cast<PyArrayObject*>(h.ptr());
}

Column column(nb::handle h, int type, npy_intp n, const char* name) {
    PyArrayObject* a = as_array(h, name);
    if (!PyArray_EquivTypenums(PyArray_TYPE(a), type) || PyArray_NDIM(a) != 1 || !PyArray_ISNOTSWAPPED(a) ||
        !PyArray_ISALIGNED(a))
        throw nb::type_error((std::string(name) + " must be a 1-D, native, aligned array of its dtype").c_str());
    if (PyArray_DIM(a, 0) != n)
        throw nb::value_error((std::string(name) + " must have one entry per agent").c_str());
    return {PyArray_BYTES(a), PyArray_STRIDE(a, 0)};
}

template <typename T>
T at(const Column& c, npy_intp i) {
    return *reinterpret_cast<const T*>(c.data + i * c.stride);
}

nb::object steal(PyObject* o) {
    if (o == nullptr) throw nb::python_error();
    return nb::steal(o);
}

nb::list new_list(npy_intp n) {
    PyObject* o = PyList_New(n);
    if (o == nullptr) throw nb::python_error();
    return nb::steal<nb::list>(o);
}

// base[start:stop] (axis 0) or, with stop < 0, base[start] (one row): a view with base's flags,
// made as NumPy's basic indexing makes it (its base collapses to the array owning the memory).
PyObject* view(PyArrayObject* base, npy_intp start, npy_intp stop) {
    const int nd = PyArray_NDIM(base);
    const bool row = stop < 0;
    npy_intp dims[NPY_MAXDIMS];
    npy_intp strides[NPY_MAXDIMS];
    for (int d = 1; d < nd; ++d) {
        dims[d - (row ? 1 : 0)] = PyArray_DIM(base, d);
        strides[d - (row ? 1 : 0)] = PyArray_STRIDE(base, d);
    }
    if (!row) {
        dims[0] = stop - start;
        strides[0] = PyArray_STRIDE(base, 0);
    }
    PyArray_Descr* descr = PyArray_DESCR(base);
    Py_INCREF(descr);  // stolen by PyArray_NewFromDescr
    // An empty slice points at the array's start, as NumPy's basic indexing makes it.
    const npy_intp offset = !row && stop == start ? 0 : start * PyArray_STRIDE(base, 0);
    PyObject* out = PyArray_NewFromDescr(&PyArray_Type, descr, row ? nd - 1 : nd, dims, strides,
                                         PyArray_BYTES(base) + offset,
                                         PyArray_FLAGS(base), nullptr);
    if (out == nullptr) return nullptr;
    Py_INCREF(base);  // stolen by PyArray_SetBaseObject
    if (PyArray_SetBaseObject(reinterpret_cast<PyArrayObject*>(out), reinterpret_cast<PyObject*>(base)) < 0) {
        Py_DECREF(out);
        return nullptr;
    }
    return out;
}

// Every agent's base[start[i]:stop[i]], checked within base's first axis.
nb::list slices(nb::handle base_h, nb::handle start_h, nb::handle stop_h, npy_intp n, const char* name) {
    PyArrayObject* base = as_array(base_h, name);
    if (PyArray_NDIM(base) < 1) throw nb::type_error((std::string(name) + " must have an axis to slice").c_str());
    const Column start = column(start_h, NPY_INTP, n, "starts");
    const Column stop = column(stop_h, NPY_INTP, n, "stops");
    const npy_intp rows = PyArray_DIM(base, 0);
    nb::list out = new_list(n);
    for (npy_intp i = 0; i < n; ++i) {
        const npy_intp a = at<npy_intp>(start, i), b = at<npy_intp>(stop, i);
        if (a < 0 || b < a || b > rows)
            throw nb::value_error((std::string(name) + ": a slice outside the array").c_str());
        PyObject* v = view(base, a, b);
        if (v == nullptr) throw nb::python_error();
        PyList_SET_ITEM(out.ptr(), i, v);
    }
    return out;
}

// Every row of a 2-D array, as iterating over it gives them.
nb::list rows(nb::handle base_h, npy_intp n) {
    PyArrayObject* base = as_array(base_h, "position");
    if (PyArray_NDIM(base) != 2 || PyArray_DIM(base, 0) != n)
        throw nb::value_error("position must be 2-D with one row per agent");
    nb::list out = new_list(n);
    for (npy_intp i = 0; i < n; ++i) {
        PyObject* v = view(base, i, -1);
        if (v == nullptr) throw nb::python_error();
        PyList_SET_ITEM(out.ptr(), i, v);
    }
    return out;
}

nb::tuple step_reports(nb::list agents, nb::list templates, nb::tuple keys, nb::handle ages_h, double dt,
                       std::int64_t insertion_steps, std::int64_t maturity_steps, nb::handle f_h,
                       nb::handle v_h, nb::handle s_h, nb::handle rewards_h, nb::handle position,
                       nb::handle trajectories, nb::handle trajectory_starts, nb::handle trajectory_stops,
                       nb::handle view_copy, nb::handle view_starts, nb::handle view_stops) {
    const npy_intp n = static_cast<npy_intp>(nb::len(agents));
    if (static_cast<npy_intp>(nb::len(templates)) != n)
        throw nb::value_error("templates must have one entry per agent");
    if (nb::len(keys) != 8) throw nb::value_error("keys must name the eight values of a period");
    const Column ages = column(ages_h, NPY_INT64, n, "ages");
    const Column f = column(f_h, NPY_FLOAT64, n, "f");
    const Column v = column(v_h, NPY_FLOAT64, n, "v");
    const Column s = column(s_h, NPY_FLOAT64, n, "s");
    const Column rewards = column(rewards_h, NPY_FLOAT64, n, "rewards");
    PyArrayObject* pos = as_array(position, "position");
    PyArrayObject* traj = as_array(trajectories, "trajectories");
    PyArrayObject* obs = as_array(view_copy, "view");
    if (PyArray_TYPE(pos) != NPY_FLOAT64 || PyArray_TYPE(traj) != NPY_FLOAT64 || PyArray_TYPE(obs) != NPY_FLOAT64)
        throw nb::type_error("position, trajectories and view must be float64 arrays");
    for (npy_intp i = 0; i < n; ++i) {
        if (!PyUnicode_Check(PyList_GET_ITEM(agents.ptr(), i))) throw nb::type_error("agents must be str");
        if (!PyDict_Check(PyList_GET_ITEM(templates.ptr(), i))) throw nb::type_error("templates must be dicts");
    }

    // The columns, in the order of StepStatuses: age, inserting, mature, f, v, s, position,
    // trajectory, age_steps.
    nb::list age = new_list(n), inserting = new_list(n), mature = new_list(n);
    nb::list fl = new_list(n), vl = new_list(n), sl = new_list(n);
    nb::list steps = new_list(n);
    nb::list positions = rows(position, n);
    nb::list trajectory = slices(trajectories, trajectory_starts, trajectory_stops, n, "trajectories");
    nb::list views = slices(view_copy, view_starts, view_stops, n, "view");
    nb::dict obs_d, reward_d, info_d;
    PyObject* const* key = &PyTuple_GET_ITEM(keys.ptr(), 0);
    for (npy_intp i = 0; i < n; ++i) {
        const std::int64_t a = at<std::int64_t>(ages, i);
        PyObject* values[8] = {
            PyFloat_FromDouble(static_cast<double>(a) * dt),  // NumPy's int64 * float: the same bits
            PyBool_FromLong(a < insertion_steps),
            PyBool_FromLong(a >= maturity_steps),
            PyFloat_FromDouble(at<double>(f, i)),
            PyFloat_FromDouble(at<double>(v, i)),
            PyFloat_FromDouble(at<double>(s, i)),
            PyList_GET_ITEM(positions.ptr(), i),
            PyList_GET_ITEM(trajectory.ptr(), i),
        };
        PyObject* lists[6] = {age.ptr(), inserting.ptr(), mature.ptr(), fl.ptr(), vl.ptr(), sl.ptr()};
        bool ok = true;
        for (int k = 0; k < 6; ++k) {  // the lists own the new values
            ok = ok && values[k] != nullptr;
            PyList_SET_ITEM(lists[k], i, values[k] != nullptr ? values[k] : Py_NewRef(Py_None));
        }
        PyList_SET_ITEM(steps.ptr(), i, PyLong_FromLongLong(a));
        if (!ok || PyList_GET_ITEM(steps.ptr(), i) == nullptr) throw nb::python_error();
        nb::object info = steal(PyDict_Copy(PyList_GET_ITEM(templates.ptr(), i)));
        for (int k = 0; k < 8; ++k)
            if (PyDict_SetItem(info.ptr(), key[k], values[k]) < 0) throw nb::python_error();
        PyObject* agent = PyList_GET_ITEM(agents.ptr(), i);
        nb::object reward = steal(PyFloat_FromDouble(at<double>(rewards, i)));
        if (PyDict_SetItem(obs_d.ptr(), agent, PyList_GET_ITEM(views.ptr(), i)) < 0 ||
            PyDict_SetItem(reward_d.ptr(), agent, reward.ptr()) < 0 ||
            PyDict_SetItem(info_d.ptr(), agent, info.ptr()) < 0)
            throw nb::python_error();
    }
    return nb::make_tuple(obs_d, reward_d, info_d,
                          nb::make_tuple(age, inserting, mature, fl, vl, sl, positions, trajectory, steps));
}

}  // namespace

void register_reports(nb::module_& m) {
    if (_import_array() < 0) throw nb::python_error();
    m.def("step_reports", &step_reports, nb::arg("agents"), nb::arg("templates"), nb::arg("keys"),
          nb::arg("ages"), nb::arg("dt"), nb::arg("insertion_steps"), nb::arg("maturity_steps"), nb::arg("f"),
          nb::arg("v"), nb::arg("s"), nb::arg("rewards"), nb::arg("position"), nb::arg("trajectories"),
          nb::arg("trajectory_starts"), nb::arg("trajectory_stops"), nb::arg("view"), nb::arg("view_starts"),
          nb::arg("view_stops"),
          "The living agents' observations, rewards and infos of a population step, and the status columns "
          "(revolve_env.envs.reports.report_step).");
}

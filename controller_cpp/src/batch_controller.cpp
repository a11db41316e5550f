// Batched neural controller: see revolve/batch_controller.hpp for the semantics.
#include "revolve/batch_controller.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace revolve {
namespace {

constexpr double kTwoPi = 6.283185307179586;  // == 2.0 * numpy.pi exactly

std::string at(const char* what, std::int64_t i) { return std::string(what) + " " + std::to_string(i); }

}  // namespace

BatchController::BatchController(double dt) : dt_(dt) {
    if (!(std::isfinite(dt) && dt > 0.0)) {
        throw std::invalid_argument("dt must be a positive number of seconds, got " + std::to_string(dt));
    }
}

void BatchController::check_params(const std::int8_t* kinds, std::int64_t n, const double* params,
                                   const double* weight, std::int64_t m) {
    static const char* names[kParamColumns] = {"bias", "gain", "period", "phase_offset", "amplitude"};
    for (std::int64_t i = 0; i < n; ++i) {
        for (int c = 0; c < kParamColumns; ++c) {
            if (!std::isfinite(params[i * kParamColumns + c])) {
                throw std::invalid_argument(at("neuron", i) + " has a non-finite " + names[c]);
            }
        }
        if (kinds[i] == kOscillator && !(params[i * kParamColumns + 2] > 0.0)) {
            throw std::invalid_argument(at("oscillator neuron", i) + " has a period <= 0");
        }
    }
    for (std::int64_t k = 0; k < m; ++k) {
        if (!std::isfinite(weight[k])) throw std::invalid_argument(at("connection", k) + " has a non-finite weight");
    }
}

void BatchController::load_params(Network& net, const std::int8_t* kinds, const double* params,
                                  const double* weight) {
    for (std::int64_t i = net.n_in; i < net.n; ++i) {
        const double* p = params + i * kParamColumns;
        Neuron& nr = net.neurons[static_cast<std::size_t>(i - net.n_in)];
        nr.kind = kinds[i];
        nr.bias = p[0];
        nr.gain = p[1];
        // Same expressions as the NumPy reference, so the results agree bit for bit.
        nr.omega = kTwoPi / p[2];
        nr.shift = p[2] * p[3];
        nr.amp = p[4];
    }
    for (std::size_t k = 0; k < net.csr_of.size(); ++k) net.w[static_cast<std::size_t>(net.csr_of[k])] = weight[k];
}

std::int64_t BatchController::add(const NetworkView& v) {
    const std::int64_t n = v.n_neurons, m = v.n_connections;
    if (n < 0 || m < 0 || v.n_inputs < 0 || v.n_outputs < 0 || v.n_inputs + v.n_outputs > n) {
        throw std::invalid_argument("inconsistent network sizes: " + std::to_string(n) + " neurons, " +
                                    std::to_string(v.n_inputs) + " inputs, " + std::to_string(v.n_outputs) +
                                    " outputs, " + std::to_string(m) + " connections");
    }
    if (n > INT32_MAX) throw std::invalid_argument("too many neurons");
    if ((n > 0 && (!v.kinds || !v.neuron_params)) || (m > 0 && (!v.src || !v.dst || !v.weight))) {
        throw std::invalid_argument("missing network array");
    }
    for (std::int64_t i = 0; i < n; ++i) {
        const std::int8_t k = v.kinds[i];
        if (k < kInput || k > kOscillator) throw std::invalid_argument(at("neuron", i) + " has an unknown kind");
        if ((k == kInput) != (i < v.n_inputs)) {
            throw std::invalid_argument("the first n_inputs neurons, and only they, must be input neurons (" +
                                        at("neuron", i) + ")");
        }
    }
    for (std::int64_t k = 0; k < m; ++k) {
        if (v.src[k] < 0 || v.src[k] >= n) throw std::invalid_argument(at("connection", k) + " has a missing source neuron");
        if (v.dst[k] < 0 || v.dst[k] >= n) throw std::invalid_argument(at("connection", k) + " has a missing destination neuron");
        if (v.dst[k] < v.n_inputs) throw std::invalid_argument(at("connection", k) + " ends in an input neuron");
    }
    check_params(v.kinds, n, v.neuron_params, v.weight, m);

    Network net;
    net.handle = next_handle_;
    net.n = n;
    net.n_in = v.n_inputs;
    net.n_out = v.n_outputs;
    const std::int64_t rows = n - v.n_inputs;
    net.neurons.resize(static_cast<std::size_t>(rows));
    // CSR by destination, keeping the original order within a row (a stable counting sort).
    net.row.assign(static_cast<std::size_t>(rows + 1), 0);
    for (std::int64_t k = 0; k < m; ++k) ++net.row[static_cast<std::size_t>(v.dst[k] - v.n_inputs + 1)];
    std::partial_sum(net.row.begin(), net.row.end(), net.row.begin());
    std::vector<std::int64_t> fill(net.row.begin(), net.row.end() - 1);
    net.col.resize(static_cast<std::size_t>(m));
    net.w.resize(static_cast<std::size_t>(m));
    net.csr_of.resize(static_cast<std::size_t>(m));
    for (std::int64_t k = 0; k < m; ++k) {
        const std::int64_t e = fill[static_cast<std::size_t>(v.dst[k] - v.n_inputs)]++;
        net.col[static_cast<std::size_t>(e)] = v.src[k];
        net.csr_of[static_cast<std::size_t>(k)] = e;
    }
    load_params(net, v.kinds, v.neuron_params, v.weight);
    net.x.assign(static_cast<std::size_t>(n), 0.0);
    net.next.assign(static_cast<std::size_t>(rows), 0.0);

    nets_.push_back(std::move(net));
    ++next_handle_;
    relayout();
    return nets_.back().handle;
}

std::size_t BatchController::index_of(std::int64_t handle) const {
    auto it = index_.find(handle);
    if (it == index_.end()) throw UnknownHandle("no live network with handle " + std::to_string(handle));
    return it->second;
}

void BatchController::remove(std::int64_t handle) {
    nets_.erase(nets_.begin() + static_cast<std::ptrdiff_t>(index_of(handle)));
    relayout();
}

void BatchController::relayout() {
    index_.clear();
    n_inputs_ = n_outputs_ = n_connections_ = 0;
    for (std::size_t i = 0; i < nets_.size(); ++i) {
        Network& net = nets_[i];
        index_[net.handle] = i;
        net.in_offset = n_inputs_;
        net.out_offset = n_outputs_;
        n_inputs_ += net.n_in;
        n_outputs_ += net.n_out;
        n_connections_ += static_cast<std::int64_t>(net.col.size()) + net.n;
    }
}

void BatchController::reset_all() {
    for (Network& net : nets_) {
        std::fill(net.x.begin(), net.x.end(), 0.0);
        net.t = 0.0;
    }
}

void BatchController::reset(std::int64_t handle) {
    Network& net = nets_[index_of(handle)];
    std::fill(net.x.begin(), net.x.end(), 0.0);
    net.t = 0.0;
}

void BatchController::set_params(std::int64_t handle, const double* neuron_params, std::int64_t n_params,
                                 const double* weight, std::int64_t n_weights) {
    Network& net = nets_[index_of(handle)];
    const std::int64_t m = static_cast<std::int64_t>(net.col.size());
    if (n_params != net.n * kParamColumns || n_weights != m) {
        throw std::invalid_argument("set_params expects " + std::to_string(net.n * kParamColumns) +
                                    " neuron parameters and " + std::to_string(m) + " weights, got " +
                                    std::to_string(n_params) + " and " + std::to_string(n_weights));
    }
    std::vector<std::int8_t> kinds(static_cast<std::size_t>(net.n), kInput);
    for (std::int64_t i = net.n_in; i < net.n; ++i) kinds[static_cast<std::size_t>(i)] = net.neurons[static_cast<std::size_t>(i - net.n_in)].kind;
    check_params(kinds.data(), net.n, neuron_params, weight, m);
    load_params(net, kinds.data(), neuron_params, weight);
}

void BatchController::step(const double* inputs, double* outputs) noexcept {
    for (Network& net : nets_) {
        double* x = net.x.data();
        std::copy(inputs + net.in_offset, inputs + net.in_offset + net.n_in, x);
        const std::int64_t rows = net.n - net.n_in;
        const std::int64_t* row = net.row.data();
        const std::int32_t* col = net.col.data();
        const double* w = net.w.data();
        const Neuron* nr = net.neurons.data();
        double* next = net.next.data();
        const double t = net.t;
        for (std::int64_t r = 0; r < rows; ++r) {
            const Neuron& q = nr[r];
            if (q.kind == kOscillator) {
                next[r] = 0.5 - q.amp / 2.0 + q.amp * (std::sin(q.omega * (t - q.shift)) + 1.0) / 2.0;
                continue;
            }
            double a = 0.0;
            for (std::int64_t e = row[r]; e < row[r + 1]; ++e) a += w[e] * x[col[e]];
            const double l = q.gain * (a - q.bias);
            next[r] = q.kind == kLinear ? l : 1.0 / (1.0 + std::exp(-l));
        }
        std::copy(next, next + rows, x + net.n_in);
        double* out = outputs + net.out_offset;
        for (std::int64_t j = 0; j < net.n_out; ++j) {
            const double v = 2.0 * x[net.n_in + j] - 1.0;
            out[j] = v < -1.0 ? -1.0 : (v > 1.0 ? 1.0 : v);  // NaN passes through, as np.clip
        }
        net.t += dt_;
    }
}

std::vector<std::int64_t> BatchController::handles() const {
    std::vector<std::int64_t> h;
    h.reserve(nets_.size());
    for (const Network& net : nets_) h.push_back(net.handle);
    return h;
}

std::int64_t BatchController::input_offset(std::int64_t handle) const { return nets_[index_of(handle)].in_offset; }
std::int64_t BatchController::output_offset(std::int64_t handle) const { return nets_[index_of(handle)].out_offset; }
std::vector<double> BatchController::state(std::int64_t handle) const { return nets_[index_of(handle)].x; }
double BatchController::time(std::int64_t handle) const { return nets_[index_of(handle)].t; }

}  // namespace revolve

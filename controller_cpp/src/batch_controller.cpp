// Batched neural controller: see revolve/batch_controller.hpp for the semantics and layout.
#include "revolve/batch_controller.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "revolve/fast_math.hpp"

namespace revolve {

#if defined(__x86_64__) && defined(__linux__) && (defined(__clang__) || defined(__GNUC__)) && \
    (!defined(__clang__) || __clang_major__ >= 14)
#define REVOLVE_MULTIVERSION __attribute__((target_clones("avx2", "default")))
#else
#define REVOLVE_MULTIVERSION
#endif

REVOLVE_MULTIVERSION void exp_array(const double* x, double* out, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) out[i] = exp_one(x[i]);
}

REVOLVE_MULTIVERSION static void sin_kernel(const double* x, double* out, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) out[i] = sin_one(x[i]);
}

void sin_array(const double* x, double* out, std::size_t n) {
    // The reduction is exact only for |x| < 2^20 pi/2; larger (or non-finite) inputs, which need
    // robots older than about ten hours, go to libm.
    bool large = false;
    for (std::size_t i = 0; i < n; ++i) large |= !(std::fabs(x[i]) < 1e6);
    if (!large) {
        sin_kernel(x, out, n);
        return;
    }
    for (std::size_t i = 0; i < n; ++i) out[i] = std::fabs(x[i]) < 1e6 ? sin_one(x[i]) : std::sin(x[i]);
}

namespace {

constexpr double kTwoPi = 6.283185307179586;  // == 2.0 * numpy.pi exactly

std::string at(const char* what, std::int64_t i) { return std::string(what) + " " + std::to_string(i); }

template <typename T>
std::vector<T> copy_of(const T* p, std::int64_t n) {
    return n > 0 ? std::vector<T>(p, p + n) : std::vector<T>();
}

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

std::int64_t BatchController::add(const NetworkView& v) {
    const std::int64_t n = v.n_neurons, m = v.n_connections;
    if (n < 0 || m < 0 || v.n_inputs < 0 || v.n_outputs < 0 || v.n_inputs + v.n_outputs > n) {
        throw std::invalid_argument("inconsistent network sizes: " + std::to_string(n) + " neurons, " +
                                    std::to_string(v.n_inputs) + " inputs, " + std::to_string(v.n_outputs) +
                                    " outputs, " + std::to_string(m) + " connections");
    }
    constexpr std::int64_t kMax = std::numeric_limits<std::int32_t>::max();
    if (n > kMax || m > kMax || static_cast<std::int64_t>(x_.size()) + n > kMax) {
        throw std::invalid_argument("too many neurons or connections for one controller");
    }
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

    save_state();
    Network net;
    net.handle = next_handle_++;
    net.n = n;
    net.n_in = v.n_inputs;
    net.n_out = v.n_outputs;
    net.kinds = copy_of(v.kinds, n);
    net.params = copy_of(v.neuron_params, n * kParamColumns);
    net.src = copy_of(v.src, m);
    net.dst = copy_of(v.dst, m);
    net.weight = copy_of(v.weight, m);
    net.saved.assign(static_cast<std::size_t>(n), 0.0);
    nets_.push_back(std::move(net));
    pack();
    return nets_.back().handle;
}

std::size_t BatchController::index_of(std::int64_t handle) const {
    auto it = index_.find(handle);
    if (it == index_.end()) throw UnknownHandle("no live network with handle " + std::to_string(handle));
    return it->second;
}

void BatchController::remove(std::int64_t handle) {
    const std::size_t k = index_of(handle);
    save_state();
    nets_.erase(nets_.begin() + static_cast<std::ptrdiff_t>(k));
    pack();
}

std::int64_t BatchController::global(const Network& net, std::int64_t i) const {
    if (i < net.n_in) return net.in_off + i;
    if (i < net.n_in + net.n_out) return n_in_ + net.out_off + (i - net.n_in);
    return n_in_ + n_out_ + net.hid_off + (i - net.n_in - net.n_out);
}

void BatchController::save_state() {
    for (std::size_t k = 0; k < nets_.size(); ++k) {
        Network& net = nets_[k];
        for (std::int64_t i = 0; i < net.n; ++i) net.saved[static_cast<std::size_t>(i)] = x_[static_cast<std::size_t>(global(net, i))];
        net.saved_t = t_[k];
    }
}

void BatchController::pack() {
    // Offsets of every network inside the three blocks.
    std::int64_t n_in = 0, n_out = 0, n_hid = 0;
    index_.clear();
    for (std::size_t k = 0; k < nets_.size(); ++k) {
        Network& net = nets_[k];
        index_[net.handle] = k;
        net.in_off = n_in;
        net.out_off = n_out;
        net.hid_off = n_hid;
        n_in += net.n_in;
        n_out += net.n_out;
        n_hid += net.n - net.n_in - net.n_out;
    }
    n_in_ = n_in;
    n_out_ = n_out;
    const std::size_t rows = static_cast<std::size_t>(n_out + n_hid);
    x_.assign(static_cast<std::size_t>(n_in) + rows, 0.0);
    next_.assign(rows, 0.0);
    gain_.assign(rows, 0.0);
    bias_.assign(rows, 0.0);
    row_.assign(rows + 1, 0);
    lin_rows_.clear();
    sig_rows_.clear();
    osc_rows_.clear();
    osc_net_.clear();
    osc_omega_.clear();
    osc_shift_.clear();
    osc_amp_.clear();
    t_.assign(nets_.size(), 0.0);

    // Row lengths first, then a stable counting sort of every network's connections by
    // destination: each row keeps the connections' original order (as the NumPy reference).
    for (const Network& net : nets_) {
        for (std::int32_t d : net.dst) ++row_[static_cast<std::size_t>(global(net, d) - n_in_ + 1)];
    }
    for (std::size_t r = 0; r < rows; ++r) row_[r + 1] += row_[r];
    col_.assign(static_cast<std::size_t>(row_[rows]), 0);
    w_.assign(col_.size(), 0.0);
    std::vector<std::int64_t> fill(row_.begin(), row_.end() - 1);
    for (std::size_t k = 0; k < nets_.size(); ++k) {
        const Network& net = nets_[k];
        for (std::size_t c = 0; c < net.dst.size(); ++c) {
            const std::int64_t e = fill[static_cast<std::size_t>(global(net, net.dst[c]) - n_in_)]++;
            col_[static_cast<std::size_t>(e)] = static_cast<std::int32_t>(global(net, net.src[c]));
            w_[static_cast<std::size_t>(e)] = net.weight[c];
        }
        for (std::int64_t i = 0; i < net.n; ++i) {
            const std::int64_t g = global(net, i);
            x_[static_cast<std::size_t>(g)] = net.saved[static_cast<std::size_t>(i)];
            if (i < net.n_in) continue;
            const std::size_t r = static_cast<std::size_t>(g - n_in_);
            const double* p = net.params.data() + i * kParamColumns;
            bias_[r] = p[0];
            gain_[r] = p[1];
            if (net.kinds[static_cast<std::size_t>(i)] == kLinear) lin_rows_.push_back(static_cast<std::int32_t>(r));
            if (net.kinds[static_cast<std::size_t>(i)] == kSigmoid) sig_rows_.push_back(static_cast<std::int32_t>(r));
            if (net.kinds[static_cast<std::size_t>(i)] == kOscillator) {
                osc_rows_.push_back(static_cast<std::int32_t>(r));
                osc_net_.push_back(static_cast<std::int32_t>(k));
                // Same expressions as the NumPy reference, so they round the same way.
                osc_omega_.push_back(kTwoPi / p[2]);
                osc_shift_.push_back(p[2] * p[3]);
                osc_amp_.push_back(p[4]);
            }
        }
        t_[k] = net.saved_t;
    }
    sig_buf_.assign(sig_rows_.size(), 0.0);
    osc_buf_.assign(osc_rows_.size(), 0.0);
}

void BatchController::reset_all() {
    std::fill(x_.begin(), x_.end(), 0.0);
    std::fill(t_.begin(), t_.end(), 0.0);
}

void BatchController::reset(std::int64_t handle) {
    const std::size_t k = index_of(handle);
    const Network& net = nets_[k];
    for (std::int64_t i = 0; i < net.n; ++i) x_[static_cast<std::size_t>(global(net, i))] = 0.0;
    t_[k] = 0.0;
}

void BatchController::set_params(std::int64_t handle, const double* neuron_params, std::int64_t n_params,
                                 const double* weight, std::int64_t n_weights) {
    Network& net = nets_[index_of(handle)];
    const std::int64_t m = static_cast<std::int64_t>(net.weight.size());
    if (n_params != net.n * kParamColumns || n_weights != m) {
        throw std::invalid_argument("set_params expects " + std::to_string(net.n * kParamColumns) +
                                    " neuron parameters and " + std::to_string(m) + " weights, got " +
                                    std::to_string(n_params) + " and " + std::to_string(n_weights));
    }
    check_params(net.kinds.data(), net.n, neuron_params, weight, m);
    save_state();
    net.params = copy_of(neuron_params, n_params);
    net.weight = copy_of(weight, m);
    pack();
}

void BatchController::step(const double* inputs, double* outputs) noexcept {
    double* x = x_.data();
    double* next = next_.data();
    if (n_in_ > 0) std::memcpy(x, inputs, static_cast<std::size_t>(n_in_) * sizeof(double));

    // Weighted sums and gain * (a - bias) for every row (oscillator rows are overwritten below).
    const std::size_t rows = next_.size();
    const std::int64_t* row = row_.data();
    const std::int32_t* col = col_.data();
    const double* w = w_.data();
    for (std::size_t r = 0; r < rows; ++r) {
        double a = 0.0;
        for (std::int64_t e = row[r]; e < row[r + 1]; ++e) a += w[e] * x[col[e]];
        next[r] = gain_[r] * (a - bias_[r]);
    }

    // Linear neurons saturate at [0, 1], the range of a motor command (see the header for why).
    // NaN passes through, as np.clip.
    for (const std::int32_t r : lin_rows_) {
        const double v = next[r];
        next[r] = v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v);
    }

    // Sigmoids: one vectorised exp over all of them.
    const std::size_t ns = sig_rows_.size();
    double* buf = sig_buf_.data();
    const std::int32_t* sig = sig_rows_.data();
    for (std::size_t k = 0; k < ns; ++k) buf[k] = -next[sig[k]];
    exp_array(buf, buf, ns);
    for (std::size_t k = 0; k < ns; ++k) next[sig[k]] = 1.0 / (1.0 + buf[k]);

    // Oscillators: functions of each network's own time only; one vectorised sin over all.
    const double* t = t_.data();
    const std::size_t no = osc_rows_.size();
    double* phase = osc_buf_.data();
    for (std::size_t k = 0; k < no; ++k) phase[k] = osc_omega_[k] * (t[osc_net_[k]] - osc_shift_[k]);
    sin_array(phase, phase, no);
    for (std::size_t k = 0; k < no; ++k) {
        const double amp = osc_amp_[k];
        next[osc_rows_[k]] = 0.5 - amp / 2.0 + amp * (phase[k] + 1.0) / 2.0;
    }

    if (rows > 0) std::memcpy(x + n_in_, next, rows * sizeof(double));
    const double* o = x + n_in_;
    for (std::int64_t j = 0; j < n_out_; ++j) {
        const double v = 2.0 * o[j] - 1.0;
        outputs[j] = v < -1.0 ? -1.0 : (v > 1.0 ? 1.0 : v);  // NaN passes through, as np.clip
    }
    for (double& tk : t_) tk += dt_;
}

std::vector<std::int64_t> BatchController::handles() const {
    std::vector<std::int64_t> h;
    h.reserve(nets_.size());
    for (const Network& net : nets_) h.push_back(net.handle);
    return h;
}

std::int64_t BatchController::input_offset(std::int64_t handle) const { return nets_[index_of(handle)].in_off; }
std::int64_t BatchController::output_offset(std::int64_t handle) const { return nets_[index_of(handle)].out_off; }

std::vector<double> BatchController::state(std::int64_t handle) const {
    const Network& net = nets_[index_of(handle)];
    std::vector<double> s(static_cast<std::size_t>(net.n));
    for (std::int64_t i = 0; i < net.n; ++i) s[static_cast<std::size_t>(i)] = x_[static_cast<std::size_t>(global(net, i))];
    return s;
}

double BatchController::time(std::int64_t handle) const { return t_[index_of(handle)]; }

void BatchController::set_state(std::int64_t handle, const double* values, std::int64_t n, double time) {
    const std::size_t k = index_of(handle);
    const Network& net = nets_[k];
    if (n != net.n) {
        throw std::invalid_argument("set_state expects " + std::to_string(net.n) + " neuron values, got " +
                                    std::to_string(n));
    }
    if (!std::isfinite(time)) throw std::invalid_argument("set_state: the time must be finite");
    for (std::int64_t i = 0; i < net.n; ++i) x_[static_cast<std::size_t>(global(net, i))] = values[i];
    t_[k] = time;
}

}  // namespace revolve

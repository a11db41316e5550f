// Batched neural controller for RoboGen/Revolve robot brains (pure C++, no Python).
//
// Semantics are those of revolve_env/brain/reference.py (RoboGen NeuralNetwork.c, double
// buffered): each tick the input neurons take the sensor values; every other neuron sums
// w * value over its incoming connections, reading the current tick's value of input neurons and
// the previous tick's value of all others, then applies its activation:
//   linear      clip(gain * (a - bias), 0, 1)
//   sigmoid     1 / (1 + exp(-gain * (a - bias)))
//   oscillator  0.5 - amp/2 + amp * (sin(2 pi / period * (t - period * phase)) + 1) / 2
// Output o becomes the normalised hinge target clip(2 o - 1, -1, 1).
//
// Why linear neurons saturate: RoboGen (lis-epfl/robogen, src/brain/NeuralNetwork.c) leaves its
// linear ("SIMPLE") neurons unbounded and bounds only what a motor receives: ServoMotor::setPosition
// and ::setVelocity (src/model/motors/ServoMotor.cpp) clamp the command to [0, 1] before mapping it
// to an angle or speed; its sigmoid and oscillator neurons lie in [0, 1] by their formulas. Here
// that [0, 1] clamp is applied to every linear neuron's value too, so each non-input value lies in
// [0, 1] (oscillator amplitudes are at most 1), a recurrent loop of linear neurons with
// gain * weight > 1 saturates instead of growing to infinity, and the outputs stay finite for
// finite sensor values and weights within bounds (sums that do not overflow). An output's hinge target is unchanged by the clamp (the motor
// clamp gave the same target); only what other neurons read from a linear neuron changes.
// NaN passes through the clamp (as np.clip), so a NaN sensor value still shows downstream.
//
// Neuron order in a network (spec order): inputs, outputs, hidden. Connections are summed per
// destination in their original order starting from 0, as the NumPy reference does; exp and sin
// are the vectorised ones of fast_math.hpp (within rounding of libm), so both agree to rounding.
//
// Layout: all networks are packed into one state vector [all inputs | all outputs | all hidden],
// each block in order of addition, so a tick copies the inputs in with one memcpy, runs one loop
// over a global CSR matrix, one vectorised exp over all sigmoid neurons, and writes the outputs
// from one contiguous block. Adding or removing a network repacks (O(total size)).
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

namespace revolve {

enum NeuronKind : std::int8_t { kInput = 0, kLinear = 1, kSigmoid = 2, kOscillator = 3 };

// Columns of the (n_neurons x 5) neuron parameter matrix.
constexpr int kParamColumns = 5;  // bias, gain, period [s], phase_offset [fraction], amplitude

// Raised for a handle that names no live network.
class UnknownHandle : public std::out_of_range {
   public:
    using std::out_of_range::out_of_range;
};

// Borrowed view of one network's arrays (spec order). Validated by BatchController::add.
struct NetworkView {
    std::int64_t n_neurons = 0;
    std::int64_t n_inputs = 0;
    std::int64_t n_outputs = 0;
    const std::int8_t* kinds = nullptr;    // n_neurons
    const double* neuron_params = nullptr;  // n_neurons * kParamColumns, row-major
    std::int64_t n_connections = 0;
    const std::int32_t* src = nullptr;  // n_connections
    const std::int32_t* dst = nullptr;  // n_connections
    const double* weight = nullptr;     // n_connections
};

class BatchController {
   public:
    // dt: control period in seconds (> 0).
    explicit BatchController(double dt);

    // Adds a network with state 0 and time 0; returns a handle that is never reused.
    // Throws std::invalid_argument if the network is inconsistent.
    std::int64_t add(const NetworkView& net);
    void remove(std::int64_t handle);
    void reset_all();
    void reset(std::int64_t handle);
    // Replaces weights (original connection order) and the neuron parameter matrix, keeping the
    // state and time. Throws std::invalid_argument on bad sizes or values.
    void set_params(std::int64_t handle, const double* neuron_params, std::int64_t n_params,
                    const double* weight, std::int64_t n_weights);

    // Advances every network one tick. inputs: n_inputs() values, outputs: n_outputs() values.
    void step(const double* inputs, double* outputs) noexcept;

    double dt() const { return dt_; }
    std::int64_t n_inputs() const { return n_in_; }
    std::int64_t n_outputs() const { return n_out_; }
    // Neurons plus connections over all networks: the size of a tick's work.
    std::int64_t work() const { return static_cast<std::int64_t>(x_.size() + col_.size()); }
    std::size_t size() const { return nets_.size(); }
    std::vector<std::int64_t> handles() const;
    std::int64_t input_offset(std::int64_t handle) const;
    std::int64_t output_offset(std::int64_t handle) const;
    std::vector<double> state(std::int64_t handle) const;
    double time(std::int64_t handle) const;
    // Overwrites one network's neuron values (spec order, n values) and time (seconds): with
    // state(handle) and time(handle) of a saved network, its next tick is bit for bit the one
    // the saved network would have made. Throws std::invalid_argument on a wrong length or a
    // non-finite time.
    void set_state(std::int64_t handle, const double* values, std::int64_t n, double time);

   private:
    struct Network {  // one robot's network, as given (spec order), plus its packed offsets
        std::int64_t handle;
        std::int64_t n, n_in, n_out;
        std::vector<std::int8_t> kinds;
        std::vector<double> params;  // n * kParamColumns
        std::vector<std::int32_t> src, dst;
        std::vector<double> weight;
        std::int64_t in_off = 0, out_off = 0, hid_off = 0;  // within each block
        std::vector<double> saved;                          // state while repacking
        double saved_t = 0.0;
    };

    static void check_params(const std::int8_t* kinds, std::int64_t n, const double* params,
                             const double* weight, std::int64_t m);
    std::size_t index_of(std::int64_t handle) const;
    std::int64_t global(const Network& net, std::int64_t i) const;  // spec index -> state index
    void save_state();  // copy each network's packed state into Network::saved
    void pack();        // rebuild the packed arrays from nets_ and their saved state

    double dt_;
    std::int64_t next_handle_ = 0;
    std::vector<Network> nets_;
    std::unordered_map<std::int64_t, std::size_t> index_;

    // Packed arrays. Rows are the non-input neurons, row r is state index n_in_ + r.
    std::int64_t n_in_ = 0, n_out_ = 0;
    std::vector<double> x_;                // state, n_in_ + rows
    std::vector<double> next_;             // next values of the rows
    std::vector<std::int64_t> row_;        // CSR row pointers
    std::vector<std::int32_t> col_;        // state index of each entry's source
    std::vector<double> w_;                // weight of each entry
    std::vector<double> gain_, bias_;      // per row (linear and sigmoid rows)
    std::vector<std::int32_t> lin_rows_;   // rows with a linear activation (clamped to [0, 1])
    std::vector<std::int32_t> sig_rows_;   // rows with a sigmoid
    std::vector<double> sig_buf_;          // scratch for the vectorised exp
    std::vector<std::int32_t> osc_rows_, osc_net_;
    std::vector<double> osc_omega_, osc_shift_, osc_amp_;  // rad/s, s, dimensionless
    std::vector<double> osc_buf_;          // scratch for the vectorised sin
    std::vector<double> t_;                // time of each network, seconds
};

}  // namespace revolve

// Batched neural controller for RoboGen/Revolve robot brains (pure C++, no Python).
//
// Semantics are those of revolve_env/brain/reference.py (RoboGen NeuralNetwork.c, double
// buffered): each tick the input neurons take the sensor values; every other neuron sums
// w * value over its incoming connections, reading the current tick's value of input neurons and
// the previous tick's value of all others, then applies its activation:
//   linear      gain * (a - bias)
//   sigmoid     1 / (1 + exp(-gain * (a - bias)))
//   oscillator  0.5 - amp/2 + amp * (sin(2 pi / period * (t - period * phase)) + 1) / 2
// Output o becomes the normalised hinge target clip(2 o - 1, -1, 1).
//
// Neuron order in a network: inputs, outputs, hidden. The floating-point operations are done in
// the same order as the NumPy reference (connections summed per destination in their original
// order, starting from 0), so both agree to rounding of exp/sin.
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
    std::int64_t n_inputs() const { return n_inputs_; }
    std::int64_t n_outputs() const { return n_outputs_; }
    std::int64_t n_connections() const { return n_connections_; }
    std::size_t size() const { return nets_.size(); }
    std::vector<std::int64_t> handles() const;
    std::int64_t input_offset(std::int64_t handle) const;
    std::int64_t output_offset(std::int64_t handle) const;
    std::vector<double> state(std::int64_t handle) const;
    double time(std::int64_t handle) const;

   private:
    struct Neuron {  // a non-input neuron, with its parameters pre-combined
        std::int8_t kind;
        double gain, bias;          // linear, sigmoid
        double omega, shift, amp;   // oscillator: 2 pi / period [rad/s], period * phase [s]
    };
    struct Network {
        std::int64_t handle;
        std::int64_t n, n_in, n_out;
        std::int64_t in_offset = 0, out_offset = 0;
        std::vector<Neuron> neurons;            // n - n_in, spec order
        std::vector<std::int64_t> row;          // CSR row pointers, n - n_in + 1
        std::vector<std::int32_t> col;          // source neuron of each CSR entry
        std::vector<double> w;                  // weight of each CSR entry
        std::vector<std::int64_t> csr_of;       // original connection index -> CSR entry
        std::vector<double> x;                  // neuron values, n
        std::vector<double> next;               // scratch, n - n_in
        double t = 0.0;
    };

    static void check_params(const std::int8_t* kinds, std::int64_t n, const double* params,
                             const double* weight, std::int64_t m);
    static void load_params(Network& net, const std::int8_t* kinds, const double* params,
                            const double* weight);
    std::size_t index_of(std::int64_t handle) const;
    void relayout();

    double dt_;
    std::int64_t next_handle_ = 0;
    std::int64_t n_inputs_ = 0, n_outputs_ = 0, n_connections_ = 0;
    std::vector<Network> nets_;
    std::unordered_map<std::int64_t, std::size_t> index_;
};

}  // namespace revolve

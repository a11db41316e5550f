// A brain's network arrays as the batch controller's view of them: the one home of that
// conversion for both extensions' bindings (revolve_env._controller's BatchController.add, and
// revolve_env._rollout's robots and env step, which build their own BatchController).
//
// The arrays are NetworkSpec's, in as_spec's order (kinds, neuron_params, src, dst, weight), of
// any type with shape(i) and data() (the bindings pass nanobind ndarrays of any flavour); their
// shapes are checked here, what the shapes do not say (kinds, indices, parameter values) by
// BatchController::add. Both throw std::invalid_argument, which nanobind raises as ValueError;
// the header is plain C++ (no nanobind), like the controller's. The view borrows their data: it
// is valid while the arrays are.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include "revolve/batch_controller.hpp"

namespace revolve {

template <typename Kinds, typename Params, typename Index, typename Weights>
NetworkView network_view(const Kinds& kinds, const Params& neuron_params, const Index& src, const Index& dst,
                         const Weights& weight, std::int64_t n_inputs, std::int64_t n_outputs) {
    const auto n = static_cast<std::int64_t>(kinds.shape(0));
    if (static_cast<std::int64_t>(neuron_params.shape(0)) != n ||
        static_cast<std::int64_t>(neuron_params.shape(1)) != kParamColumns) {
        throw std::invalid_argument("neuron_params must have shape (" + std::to_string(n) + ", 5)");
    }
    if (src.shape(0) != dst.shape(0) || src.shape(0) != weight.shape(0)) {
        throw std::invalid_argument("src, dst and weight must have the same length");
    }
    NetworkView v;
    v.n_neurons = n;
    v.n_inputs = n_inputs;
    v.n_outputs = n_outputs;
    v.kinds = kinds.data();
    v.neuron_params = neuron_params.data();
    v.n_connections = static_cast<std::int64_t>(src.shape(0));
    v.src = src.data();
    v.dst = dst.data();
    v.weight = weight.data();
    return v;
}

}  // namespace revolve

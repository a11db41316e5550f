// Python bindings of the compiled controller (filled in by the controller work).
#include <nanobind/nanobind.h>

namespace nb = nanobind;

NB_MODULE(_controller, m) {
    m.doc() = "revolve-env compiled neural controller";
    m.attr("ABI_VERSION") = 1;
}

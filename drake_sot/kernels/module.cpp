// The compiled core's entry point: one pybind11 module, drake_sot.kernels._compiled, whose
// functions each file of this folder binds (bind_<file>). Each kernel's numpy version, in the pure
// module that calls it, is its oracle (tests/test_kernels*.py) and its fallback (drake_sot.kernels).
#include <pybind11/pybind11.h>

#include "kernels.h"

#ifndef DRAKE_SOT_SOURCE_HASH
#define DRAKE_SOT_SOURCE_HASH "unknown"
#endif

PYBIND11_MODULE(_compiled, m) {
  m.doc() = "drake_sot's compiled kernels (C++ over Eigen); see drake_sot.kernels.";
  m.attr("SOURCE_HASH") = DRAKE_SOT_SOURCE_HASH;
  drake_sot::bind_features(m);
  drake_sot::bind_preview(m);
  drake_sot::bind_inequalities(m);
  drake_sot::bind_stabilization(m);
  drake_sot::bind_generalized(m);
  drake_sot::bind_hqp(m);
}

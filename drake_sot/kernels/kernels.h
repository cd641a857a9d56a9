// Declarations shared by the compiled core's files: each binds its kernels into the module.
#pragma once

#include <pybind11/pybind11.h>

namespace drake_sot {

void bind_features(pybind11::module_& m);
void bind_preview(pybind11::module_& m);
void bind_inequalities(pybind11::module_& m);
void bind_stabilization(pybind11::module_& m);
void bind_generalized(pybind11::module_& m);
void bind_hqp(pybind11::module_& m);

}  // namespace drake_sot

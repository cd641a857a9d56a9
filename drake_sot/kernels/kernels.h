// Declarations shared by the compiled core's files: each binds its kernels into the module.
#pragma once

#include <pybind11/pybind11.h>

namespace drake_sot {

void bind_hqp(pybind11::module_& m);
void bind_so3(pybind11::module_& m);

}  // namespace drake_sot

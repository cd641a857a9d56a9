// The cart-table ZMP preview servo of Kajita et al. 2003, one tick and a whole plan. Oracle:
// drake_sot.preview.PreviewController (step_numpy, plan_numpy). One (5, 4 + N) matrix maps
// [x (3 rows); s (1 row); window (N rows)] to [x_next; s_next; zmp], both axes (columns) at once.
#include <Eigen/Dense>
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>

#include "kernels.h"

namespace py = pybind11;
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using Columns2 = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;
using State = Eigen::Matrix<double, 3, 2, Eigen::RowMajor>;
using Row2 = Eigen::Matrix<double, 1, 2>;

namespace drake_sot {
namespace {

// out (5, 2) = tick z with z = [x; s; reference[k..k+N-1]] ((4 + N, 2), the reference's last row
// held past its end), z built in place: one product of the same shapes for a tick of step_at and
// of plan, so that a plan is its ticks repeated bit for bit.
void tick_at(const Eigen::Ref<const RowMatrix>& tick, const State& x, const Row2& s,
             const Eigen::Ref<const Columns2>& reference, Eigen::Index k, Columns2& z,
             Eigen::Matrix<double, 5, 2>& out) {
  const Eigen::Index N = tick.cols() - 4, K = reference.rows();
  z.resize(4 + N, 2);
  z.topRows<3>() = x;
  z.row(3) = s;
  const Eigen::Index inside = std::max<Eigen::Index>(0, std::min(N, K - k));
  if (inside) z.middleRows(4, inside) = reference.middleRows(k, inside);
  for (Eigen::Index j = inside; j < N; ++j) z.row(4 + j) = reference.row(K - 1);
  out.noalias() = tick.lazyProduct(z);  // coefficient-wise: no GEMM blocking for 5 x 2 outputs
}

void check(const Eigen::Ref<const RowMatrix>& tick, const Eigen::Ref<const Columns2>& reference) {
  if (tick.rows() != 5 || tick.cols() < 5)
    throw py::value_error("preview tick matrix must be (5, 4 + N), N >= 1");
  if (reference.rows() < 1) throw py::value_error("the ZMP reference needs at least one sample");
}

// PreviewController.step over the window of samples k..k+N-1 of reference (K, 2).
py::tuple step_at(const Eigen::Ref<const RowMatrix>& tick, const State& x, const Row2& s,
                  const Eigen::Ref<const Columns2>& reference, Eigen::Index k) {
  check(tick, reference);
  if (k < 0) throw py::value_error("preview sample index must be >= 0");
  Eigen::Matrix<double, 5, 2> out;
  Columns2 z;
  tick_at(tick, x, s, reference, k, z, out);
  const State x_next = out.topRows<3>();
  const Eigen::Vector2d s_next = out.row(3).transpose(), zmp = out.row(4).transpose();
  return py::make_tuple(x_next, s_next, zmp);
}

// PreviewController.plan's loop: the state before each sample (K, 3, 2 as K x 6 rows) and the
// model ZMP of each.
py::tuple plan(const Eigen::Ref<const RowMatrix>& tick, const Eigen::Ref<const Columns2>& reference, State x,
               Row2 s) {
  check(tick, reference);
  const Eigen::Index K = reference.rows();
  RowMatrix states(K, 6);
  Columns2 zmp(K, 2);
  Eigen::Matrix<double, 5, 2> out;
  Columns2 z;
  for (Eigen::Index k = 0; k < K; ++k) {
    states.row(k) = Eigen::Map<const Eigen::Matrix<double, 1, 6>>(x.data());
    tick_at(tick, x, s, reference, k, z, out);
    x = out.topRows<3>();
    s = out.row(3);
    zmp.row(k) = out.row(4);
  }
  return py::make_tuple(states, zmp);
}

}  // namespace

void bind_preview(py::module_& m) {
  m.def("preview_step_at", &step_at, py::arg("tick"), py::arg("x"), py::arg("error_sum"), py::arg("reference"),
        py::arg("k"), "PreviewController.step on the window of reference at sample k: (x_next, s_next, zmp).");
  m.def("preview_plan", &plan, py::arg("tick"), py::arg("reference"), py::arg("x0"), py::arg("error_sum"),
        "PreviewController.plan's loop: (states (K, 6) row-major [c, c', c''] x [x, y], zmp (K, 2)).");
}

}  // namespace drake_sot

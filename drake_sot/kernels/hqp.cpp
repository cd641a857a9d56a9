// The strict hierarchy of equalities and inequalities (Escande, Mansard, Wieber 2014): the primal
// active set of drake_sot.hqp, level by level in the null-space basis form of Mansard et al. 2009
// (eq. 8-9), and its shortcut for a control tick whose rows at a bound are guessed. The numpy
// version in drake_sot/hqp.py is the oracle: each function here is its namesake there (the same
// decisions in the same order, the same rank floors as drake_sot.linalg.SvdSplit and the same
// certificate as full_rank_lstsq), so that both agree to rounding wherever the rank decisions
// coincide. Nothing here throws for a numeric reason: a level whose active set does not settle is
// named in `unsettled`, as in Python.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <Eigen/Dense>
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "kernels.h"

namespace py = pybind11;
using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace drake_sot {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = std::numeric_limits<double>::epsilon();

using Rows = std::vector<Index>;

// One level (J, lower, upper); `same`: the caller gave it as (J, target), or with `lower is upper`.
struct Level {
  MatrixXd J;
  VectorXd lower, upper;
  bool same = false;
};

// The guess of the rows at a bound: per level index, its rows (increasing) and their sides (+1 upper,
// -1 lower). Empty: no row at a bound (Python's None).
using Binding = std::map<int, std::pair<std::vector<Index>, std::vector<double>>>;

MatrixXd take_rows(const MatrixXd& A, const Rows& rows) { return A(rows, Eigen::all); }
VectorXd take(const VectorXd& v, const Rows& rows) { return v(rows); }

// The upper triangle of a square block, inverted; false when its diagonal has an exact zero (LAPACK's
// dtrtri info > 0).
bool upper_inverse(const Eigen::Ref<const MatrixXd>& R, MatrixXd& R_inv) {
  const Index k = R.rows();
  for (Index i = 0; i < k; ++i)
    if (R(i, i) == 0.0) return false;
  // Back substitution column by column (the blocked solver's set-up outweighs it at these sizes).
  R_inv.setZero(k, k);
  for (Index j = 0; j < k; ++j) {
    R_inv(j, j) = 1.0 / R(j, j);
    for (Index i = j - 1; i >= 0; --i) {
      double sum = 0.0;
      for (Index l = i + 1; l <= j; ++l) sum += R(i, l) * R_inv(l, j);
      R_inv(i, j) = -sum / R(i, i);
    }
  }
  return true;
}

// drake_sot.linalg.SvdSplit's decisions on A (m, k), from the cheapest factorisation that certifies
// them: singular values <= max(rank_threshold, max(m, k) eps s_max) are zero. When A certainly has full
// rank by that rule (full_rank_lstsq's certificate: with a Householder QR of A or Aᵀ, σ_min >= 1 /
// ||R⁻¹||_F is above max(rank_threshold, max(m, k) eps ||A||_F), which bounds the floor, as σ_max <=
// ||A||_F), the QR is the factorisation (a few times cheaper than the SVD on the working sets of the
// active set); otherwise the SVD decides, as in Python. Either gives the same A⁺ b, the same kernel and
// the same multipliers (to rounding): only the basis of the kernel differs, which no answer depends on.
class Split {
 public:
  static Split of(const MatrixXd& A, double rank_threshold) {
    Split out;
    const Index m = A.rows(), k = A.cols();
    out.m_ = m;
    out.k_ = k;
    if (m && k) {
      const double floor = std::max(rank_threshold, double(std::max(m, k)) * kEps * A.norm());
      out.wide_ = m <= k;
      out.qr_.compute(out.wide_ ? MatrixXd(A.transpose()) : A);
      const Index p = std::min(m, k);
      if (upper_inverse(out.qr_.matrixQR().topRows(p), out.R_inv_) && out.R_inv_.norm() * floor < 1.0) {
        out.kind_ = Kind::kQr;
        out.rank = p;
        return out;
      }
      if (out.wide_ && out.complete_orthogonal(A, rank_threshold)) return out;
      Eigen::BDCSVD<MatrixXd> svd(A, Eigen::ComputeThinU | Eigen::ComputeFullV);
      out.U_ = svd.matrixU();
      out.s_ = svd.singularValues();
      out.V_ = svd.matrixV();
    } else {
      out.U_ = MatrixXd::Zero(m, 0);
      out.s_ = VectorXd(0);
      out.V_ = MatrixXd::Identity(k, k);
    }
    const double floor =
        out.s_.size() ? std::max(rank_threshold, double(std::max(m, k)) * kEps * out.s_(0)) : rank_threshold;
    out.rank = (out.s_.array() > floor).count();
    out.kind_ = Kind::kSvd;
    return out;
  }

  // A⁺ b (k,).
  VectorXd solve(const VectorXd& b) const {
    const Index r = rank;
    if (kind_ == Kind::kSvd) return V_.leftCols(r) * ((U_.leftCols(r).transpose() * b).cwiseQuotient(s_.head(r)));
    if (kind_ == Kind::kCod) {  // A = P Tᵀ Q₁ᵀ, Tᵀ = Q₂ R₂: A⁺ = Q₁ R₂⁻¹ Q₂ᵀ Pᵀ
      const VectorXd q2 = qr2_.householderQ().transpose() * (cp_.colsPermutation().transpose() * b);
      VectorXd y = VectorXd::Zero(k_);
      y.head(r).noalias() = R_inv_ * q2.head(r);
      y.applyOnTheLeft(cp_.householderQ());
      return y;
    }
    if (wide_) {  // Aᵀ = Q R: A⁺ = Q₁ R⁻ᵀ
      VectorXd y = VectorXd::Zero(k_);
      y.head(m_).noalias() = R_inv_.transpose() * b;
      y.applyOnTheLeft(qr_.householderQ());
      return y;
    }
    VectorXd Qtb = qr_.householderQ().transpose() * b;  // A = Q R: A⁺ = R⁻¹ Q₁ᵀ
    return R_inv_ * Qtb.head(k_);
  }

  // (Aᵀ)⁺ g (m,): the multipliers λ of min ||g + Aᵀ λ|| are (Aᵀ)⁺ (-g).
  VectorXd solve_transposed(const VectorXd& g) const {
    const Index r = rank;
    if (kind_ == Kind::kSvd) return U_.leftCols(r) * ((V_.leftCols(r).transpose() * g).cwiseQuotient(s_.head(r)));
    if (kind_ == Kind::kCod) {  // Aᵀ = Q₁ T Pᵀ: (Aᵀ)⁺ = P Q₂ R₂⁻ᵀ Q₁ᵀ
      const VectorXd qg = cp_.householderQ().transpose() * g;
      VectorXd w = VectorXd::Zero(m_);
      w.head(r).noalias() = R_inv_.transpose() * qg.head(r);
      w.applyOnTheLeft(qr2_.householderQ());
      return cp_.colsPermutation() * w;
    }
    if (wide_) {  // Aᵀ = Q R: (Aᵀ)⁺ = R⁻¹ Q₁ᵀ
      VectorXd Qtg = qr_.householderQ().transpose() * g;
      return R_inv_ * Qtg.head(m_);
    }
    VectorXd y = VectorXd::Zero(m_);  // A = Q R: (Aᵀ)⁺ = Q₁ R⁻ᵀ
    y.head(k_).noalias() = R_inv_.transpose() * g;
    y.applyOnTheLeft(qr_.householderQ());
    return y;
  }

  // An orthonormal basis of ker A (k, k - rank).
  MatrixXd null_basis() const {
    if (kind_ == Kind::kSvd) return V_.rightCols(V_.cols() - rank);
    if (!wide_) return MatrixXd(k_, 0);
    MatrixXd N = MatrixXd::Zero(k_, k_ - rank);  // the last columns of the complete Q of Aᵀ (P) = Q R
    N.bottomRows(k_ - rank).setIdentity();
    if (kind_ == Kind::kCod)
      N.applyOnTheLeft(cp_.householderQ());
    else
      N.applyOnTheLeft(qr_.householderQ());
    return N;
  }

  // M N (M has k columns) with N = null_basis(), without forming N when it is the last columns of a
  // Householder Q: (M Q)[:, m:].
  MatrixXd times_null(const MatrixXd& M) const {
    if (kind_ == Kind::kSvd) return M * V_.rightCols(V_.cols() - rank);
    if (!wide_) return MatrixXd(M.rows(), 0);
    MatrixXd MQ = kind_ == Kind::kCod ? MatrixXd(M * cp_.householderQ()) : MatrixXd(M * qr_.householderQ());
    return MQ.rightCols(k_ - rank);
  }

  // N y (k,) for y (k - rank,), N = null_basis().
  VectorXd null_times(const VectorXd& y) const {
    if (kind_ == Kind::kSvd) return V_.rightCols(V_.cols() - rank) * y;
    VectorXd v = VectorXd::Zero(k_);
    if (!wide_) return v;
    v.tail(k_ - rank) = y;
    if (kind_ == Kind::kCod)
      v.applyOnTheLeft(cp_.householderQ());
    else
      v.applyOnTheLeft(qr_.householderQ());
    return v;
  }

  Index rank = 0;

 private:
  // A wide A whose rows depend on one another to rounding (a row repeated, doubled, or the sum of
  // two others, as degenerate hierarchies have): its rank r certified from a QR with column
  // pivoting, Aᵀ P = Q [R11 R12; 0 R22], as SvdSplit would decide it (σ_r >= 1 / ||R11⁻¹||_F is above
  // the floor, σ_{r+1} <= ||R22||_F below it), and R22 at rounding's level: A is taken as
  // P [R11 R12; 0 0]ᵀ Qᵀ, a complete orthogonal decomposition (Golub and Van Loan 2013, 5.4.2), the
  // SVD's truncation to rounding. False (nothing certified) for the SVD.
  bool complete_orthogonal(const MatrixXd& A, double rank_threshold) {
    const Index m = m_, k = k_;
    cp_.compute(A.transpose());
    const MatrixXd& R = cp_.matrixQR();  // (k, m): R in its upper triangle
    const double a_norm = A.norm();      // ||A||_F >= s_max >= ||A||_F / sqrt(m)
    const double below = std::min(std::max(rank_threshold, double(k) * kEps * a_norm / std::sqrt(double(m))),
                                  10.0 * double(k) * kEps * a_norm);
    std::vector<double> tail(m + 1, 0.0);  // tail[i] = ||R22||_F² for r = i
    for (Index i = m - 1; i >= 0; --i) tail[i] = tail[i + 1] + R.row(i).segment(i, m - i).squaredNorm();
    Index r = 0;
    while (r < m && std::sqrt(tail[r]) > below) ++r;
    if (r == 0 || r == m) return false;
    const double floor = std::max(rank_threshold, double(k) * kEps * a_norm);
    MatrixXd R11_inv;
    if (!upper_inverse(R.topLeftCorner(r, r), R11_inv) || !(R11_inv.norm() * floor < 1.0)) return false;
    MatrixXd T = R.topRows(r);  // [R11 R12], the Householder vectors below its diagonal cleared
    for (Index i = 1; i < r; ++i) T.row(i).head(i).setZero();
    qr2_.compute(T.transpose());
    if (!upper_inverse(qr2_.matrixQR().topRows(r), R_inv_)) return false;
    kind_ = Kind::kCod;
    rank = r;
    return true;
  }

  enum class Kind { kSvd, kQr, kCod };
  Kind kind_ = Kind::kSvd;
  Index m_ = 0, k_ = 0;
  bool wide_ = false;
  Eigen::HouseholderQR<MatrixXd> qr_;  // of Aᵀ when wide_, else of A
  Eigen::ColPivHouseholderQR<MatrixXd> cp_;  // kCod: of Aᵀ
  Eigen::HouseholderQR<MatrixXd> qr2_;       // kCod: of Tᵀ = [R11 R12]ᵀ
  MatrixXd R_inv_;                           // kQr: R⁻¹; kCod: R₂⁻¹
  MatrixXd U_;
  VectorXd s_;
  MatrixXd V_;
};

// drake_sot.linalg.full_rank_lstsq: A⁺ b by Householder QR for a tall A (m >= k) when its full column
// rank is certain by SvdSplit's rule (σ_min >= 1 / ||R⁻¹||_F above the floor with σ_max <= ||A||_F).
std::optional<VectorXd> full_rank_lstsq(const MatrixXd& A, const VectorXd& b, double rank_threshold) {
  const Index m = A.rows(), k = A.cols();
  if (m < k || !k) return std::nullopt;
  Eigen::HouseholderQR<MatrixXd> qr(A);
  MatrixXd R_inv;
  if (!upper_inverse(qr.matrixQR().topRows(k), R_inv)) return std::nullopt;
  const double floor = std::max(rank_threshold, double(std::max(m, k)) * kEps * A.norm());
  if (R_inv.triangularView<Eigen::Upper>().toDenseMatrix().norm() * floor >= 1.0) return std::nullopt;
  VectorXd Qtb = qr.householderQ().transpose() * b;
  return VectorXd(qr.matrixQR().topRows(k).triangularView<Eigen::Upper>().solve(Qtb.head(k)));
}

VectorXd row_norms(const MatrixXd& M) { return M.rowwise().norm(); }

struct Block {
  Index row;
  double step;
  int bound;
};

// hqp._first_block: the first of the rows lower <= M q̇ <= upper that the step x + α d leaves, (row,
// α >= 0, +1 upper / -1 lower), or (-1, inf, 0). `lowest`: Bland's rule among the rows that block at
// the shortest step (to 1e-12), the one of smallest index. `skip`: when given, the rows i with
// skip[i] != 0 are left out (held in the working set), as numpy leaves them out of its copy.
Block first_block(const MatrixXd& M, const VectorXd& lower, const VectorXd& upper, const VectorXd& x,
                  const VectorXd& d, const VectorXd& eps, bool lowest,
                  const std::vector<signed char>* skip = nullptr) {
  const Index m = M.rows();
  const auto out = [&](Index i) { return skip && (*skip)[i]; };
  const VectorXd after = M * (x + d);
  bool inside = true;
  for (Index i = 0; i < m && inside; ++i) inside = out(i) || (after(i) <= upper(i) && after(i) >= lower(i));
  if (inside) return {-1, kInf, 0};
  const VectorXd rate = M * d;
  const VectorXd value = M * x;
  bool any = false;
  Index k = -1;
  VectorXd steps = VectorXd::Constant(m, kInf);
  for (Index i = 0; i < m; ++i) {
    if (out(i)) continue;
    if (k < 0) k = i;
    if (rate(i) > eps(i)) {
      steps(i) = (upper(i) - value(i)) / rate(i);
      any = true;
    } else if (rate(i) < -eps(i)) {
      steps(i) = (lower(i) - value(i)) / rate(i);
      any = true;
    }
  }
  if (!any) return {-1, kInf, 0};
  for (Index i = k + 1; i < m; ++i)
    if (!out(i) && steps(i) < steps(k)) k = i;  // the first of the smallest, as numpy's argmin
  const double step = std::max(steps(k), 0.0);
  if (lowest) {
    for (Index i = 0; i < m; ++i) {
      if (!out(i) && steps(i) <= step + 1e-12) {
        k = i;
        break;
      }
    }
  }
  return {k, step, rate(k) > eps(k) ? 1 : -1};
}

// A candidate to leave the working set: how wrong its multiplier is, whether it is a hard row (else a
// row of the level), and its row.
struct Candidate {
  double wrong;
  bool hard;
  Index row;
};

// hqp._leaving: among held rows (`rows` increasing) whose multiplier is wrong by `wrong` (> tol), the
// most wrong, or under Bland's rule the first.
std::optional<Candidate> leaving_of(const VectorXd& wrong, const Rows& rows, bool hard, double tol, bool bland) {
  if (!wrong.size()) return std::nullopt;
  if (bland) {
    for (Index i = 0; i < wrong.size(); ++i)
      if (wrong(i) > tol) return Candidate{wrong(i), hard, rows[i]};
    return std::nullopt;
  }
  Index k = 0;
  for (Index i = 1; i < wrong.size(); ++i)
    if (wrong(i) > wrong(k)) k = i;
  if (wrong(k) > tol) return Candidate{wrong(k), hard, rows[k]};
  return std::nullopt;
}

Rows nonzero(const std::vector<signed char>& v) {
  Rows out;
  for (Index i = 0; i < Index(v.size()); ++i)
    if (v[i]) out.push_back(i);
  return out;
}

// The first iteration of a level's active set when the caller has it (the SVD and the step).
struct First {
  Split split;
  VectorXd d;
};

// The SVD of the last least squares of a level when it ran with no hard row held, and its row count.
struct Last {
  Index rows;
  Split split;
};

struct Options {
  double rank_threshold;
  double tolerance;
  int bland_after;
  int iterations_per_row;
};

// hqp._ActiveSet: q̇ so far, the basis Z of what the fixed rows leave free (identity: `z_identity`),
// and the hard rows lo <= C q̇ <= hi.
class ActiveSet {
 public:
  ActiveSet(Index n, const Options& options)
      : n_(n), rt_(options.rank_threshold), tol_(options.tolerance), bland_after_(options.bland_after),
        iterations_per_row_(options.iterations_per_row), x_(VectorXd::Zero(n)), C_(0, n) {}

  Index free_dims() const { return z_identity_ ? n_ : Z_.cols(); }
  const VectorXd& x() const { return x_; }
  int iterations() const { return iterations_; }
  const std::vector<std::string>& unsettled() const { return unsettled_; }

  // hqp._ActiveSet.level: one level, then its equality and violated rows fixed, the others hard.
  void level(const Level& level, const std::string& name, double damping) {
    if (!z_identity_ && !Z_.cols()) return;  // nothing left to move
    const MatrixXd& J0 = level.J;
    const Index m0 = J0.rows();
    if (level.same) {
      std::optional<First> first;
      if (!damping) {
        first = equality_step(J0, level.upper);
        if (!first) return;
      }
      std::vector<bool> equality(m0, true);
      std::vector<signed char> side(m0, 2);
      finish(J0, level.lower, level.upper, equality, side, Rows(), name, std::move(first), damping);
      return;
    }
    const VectorXd &lower0 = level.lower, &upper0 = level.upper;
    bool any_equality = false, all_equality = true;
    for (Index i = 0; i < m0; ++i) {
      const bool e = lower0(i) == upper0(i);
      any_equality = any_equality || e;
      all_equality = all_equality && e;
    }
    if (!any_equality) {
      bool holds;
      if (x_zero_) {
        holds = (lower0.array() <= tol_).all() && (upper0.array() >= -tol_).all();
      } else {
        const VectorXd value = J0 * x_;
        holds = ((value.array() <= upper0.array() + tol_) && (value.array() >= lower0.array() - tol_)).all();
      }
      if (holds) {  // inequalities that all hold: met where q̇ stands, they turn hard
        ++iterations_;
        add_hard(J0, lower0, upper0);
        return;
      }
    }
    Rows keep;
    for (Index i = 0; i < m0; ++i) {
      bool k = (J0.row(i).array() != 0.0).any();
      if (!all_equality) k = k && (lower0(i) > -kInf || upper0(i) < kInf);
      if (k) keep.push_back(i);
    }
    MatrixXd J;
    VectorXd lower, upper;
    if (Index(keep.size()) != m0) {
      if (keep.empty()) return;
      J = take_rows(J0, keep);
      lower = take(lower0, keep);
      upper = take(upper0, keep);
    } else {
      J = J0;
      lower = lower0;
      upper = upper0;
    }
    const Index m = J.rows();
    std::vector<bool> equality(m);
    bool all_eq = true;
    for (Index i = 0; i < m; ++i) {
      equality[i] = lower(i) == upper(i);
      all_eq = all_eq && equality[i];
    }
    std::optional<First> first;
    if (all_eq && !damping) {
      first = equality_step(J, upper);
      if (!first) return;
    }
    Rows soft;
    for (Index i = 0; i < m; ++i)
      if (!equality[i]) soft.push_back(i);
    std::vector<signed char> side(m, 2);  // 2: equality; ±1: held at upper/lower; 0: free
    for (Index i : soft) {
      const double value = J.row(i).dot(x_);
      side[i] = value > upper(i) + tol_ ? 1 : (value < lower(i) - tol_ ? -1 : 0);
    }
    finish(J, lower, upper, equality, side, soft, name, std::move(first), damping);
  }

  // hqp._ActiveSet.equality_run: consecutive equality levels solved from one QR of their stacked rows
  // while each keeps its full row rank in what the levels above leave; returns how many it solved.
  int equality_run(const std::vector<const Level*>& levels, std::vector<Index>& free_dims) {
    const Index k = this->free_dims();
    int count = 0;
    Index total = 0;
    for (const Level* level : levels) {
      if (total + level->J.rows() > k) break;
      total += level->J.rows();
      ++count;
    }
    if (count < 2) return 0;
    MatrixXd J_all(total, n_);
    VectorXd target(total);
    std::vector<Index> sizes(count), starts(count);
    for (Index i = 0, at = 0; i < count; ++i) {
      const Index m = levels[i]->J.rows();
      J_all.middleRows(at, m) = levels[i]->J;
      target.segment(at, m) = levels[i]->upper;
      sizes[i] = m;
      starts[i] = at;
      at += m;
    }
    const MatrixXd A = times_Z(J_all);
    Eigen::HouseholderQR<MatrixXd> householder(A.transpose());
    const MatrixXd& qr = householder.matrixQR();  // (k, total): R in its upper triangle
    const MatrixXd Q = householder.householderQ() * MatrixXd::Identity(k, k);
    const MatrixXd V = z_identity_ ? Q : MatrixXd(Z_ * Q);  // the levels' row spaces, then what they leave
    VectorXd c = x_zero_ ? target : VectorXd(target - J_all * x_);
    if (equality_run_at_once(sizes, starts, qr, V, c, k, free_dims)) return count;
    for (int i = 0; i < count; ++i) {
      const Index start = starts[i], size = sizes[i], end = start + size;
      MatrixXd R_inv;
      const auto R_ii = qr.block(start, start, size, size);
      if (!upper_inverse(R_ii, R_inv)) {
        set_Z(V.rightCols(k - start));
        return i;
      }
      const double R_norm = R_ii.triangularView<Eigen::Upper>().toDenseMatrix().norm();
      const double floor = std::max(rt_, double(std::max(size, k - start)) * kEps * R_norm);
      const VectorXd y = R_inv.transpose() * c.segment(start, size);
      if (R_inv.norm() * floor >= 1.0 || !step(V.middleCols(start, size) * y)) {
        set_Z(V.rightCols(k - start));
        return i;
      }
      // The later levels' targets seen from the new q̇: c_j -= L_ji y_i.
      if (end < total) c.tail(total - end) -= qr.block(start, end, size, total - end).transpose() * y;
      ++iterations_;
      free_dims.push_back(k - end);
    }
    set_Z(V.rightCols(k - total));
    return count;
  }

  // hqp._ActiveSet.regularise: the last level I q̇ = 0, unless every level took one minimum-norm step.
  void regularise() {
    if (!min_norm_ && free_dims()) {
      const VectorXd zeros = VectorXd::Zero(n_);
      std::vector<signed char> side(n_, 2);
      minimise(MatrixXd::Identity(n_, n_), zeros, zeros, side, Rows(), "regularisation I q̇ = 0", std::nullopt);
    }
  }

 private:
  MatrixXd times_Z(const MatrixXd& M) const { return z_identity_ ? M : MatrixXd(M * Z_); }
  VectorXd Z_times(const VectorXd& y) const { return z_identity_ ? y : VectorXd(Z_ * y); }
  MatrixXd Z_times(const MatrixXd& N) const { return z_identity_ ? N : MatrixXd(Z_ * N); }
  void set_Z(const MatrixXd& Z) {
    Z_ = Z;
    z_identity_ = false;
  }

  // hqp._ActiveSet._finish: the level's active set, then its rows fixed or made hard (Escande, Mansard,
  // Wieber 2014: the equality and violated rows keep their values below, those that hold keep holding). With damping
  // μ > 0, the rows μ Zᵀ (q̇ - q̇_start) = 0 join its least squares (Nakamura and Hanafusa 1986), for
  // its active set only.
  void finish(const MatrixXd& J, const VectorXd& lower, const VectorXd& upper, const std::vector<bool>& equality,
              std::vector<signed char>& side, const Rows& soft, const std::string& name, std::optional<First> first,
              double damping) {
    const Index m = J.rows();
    std::optional<Last> last;
    int iterations;
    if (damping) {
      min_norm_ = false;
      const MatrixXd D =
          z_identity_ ? MatrixXd(damping * MatrixXd::Identity(n_, n_)) : MatrixXd(damping * Z_.transpose());
      const VectorXd start = D * x_;
      MatrixXd A(m + D.rows(), n_);
      A << J, D;
      VectorXd lo(m + D.rows()), hi(m + D.rows());
      lo << lower, start;
      hi << upper, start;
      std::vector<signed char> side_damped(side);
      side_damped.resize(m + D.rows(), 2);
      iterations = minimise(A, lo, hi, side_damped, soft, name, std::nullopt).second;
      std::copy(side_damped.begin(), side_damped.begin() + m, side.begin());
    } else {
      auto result = minimise(J, lower, upper, side, soft, name, std::move(first));
      last = std::move(result.first);
      iterations = result.second;
    }
    // The level's optimum: its equality rows and violated rows keep their values below.
    std::vector<bool> fixed(equality);
    Rows hard, fixed_rows;
    if (!soft.empty()) {
      for (Index i : soft) {
        const signed char held = side[i];
        const double residual = J.row(i).dot(x_) - (held == -1 ? lower(i) : upper(i));
        if (held != 0 && std::abs(residual) > tol_)
          fixed[i] = true;
        else
          hard.push_back(i);
      }
    } else {
      std::fill(fixed.begin(), fixed.end(), true);
    }
    for (Index i = 0; i < m; ++i)
      if (fixed[i]) fixed_rows.push_back(i);
    const Index n_fixed = fixed_rows.size();
    // One step whose least squares held exactly the rows now fixed: a minimum-norm step.
    const bool single = !last || n_fixed == last->rows;
    if (iterations > 1 || !single) min_norm_ = false;
    if (n_fixed) {  // Z N, N the kernel of the fixed rows in Z (applied, not built, when it is a Q's)
      std::optional<Split> fresh;
      if (!(last && single)) {
        const MatrixXd F = Index(fixed_rows.size()) == m ? J : take_rows(J, fixed_rows);
        fresh = Split::of(times_Z(F), rt_);
      }
      const Split& split = fresh ? *fresh : last->split;
      set_Z(z_identity_ ? split.null_basis() : split.times_null(Z_));
    }
    if (!hard.empty()) add_hard(take_rows(J, hard), take(lower, hard), take(upper, hard));
  }

  // hqp._ActiveSet._equality_step: the minimum-norm step of an equality level, taken when no hard row
  // blocks it (nullopt); otherwise nothing changes and the SVD and step come back for the active set.
  std::optional<First> equality_step(const MatrixXd& J, const VectorXd& target) {
    const MatrixXd A = times_Z(J);
    const VectorXd b = x_zero_ ? target : VectorXd(target - J * x_);
    const Index m = A.rows(), k = A.cols();
    std::optional<VectorXd> y;
    if (m >= k) y = full_rank_lstsq(A, b, rt_);  // a tall level that takes all the freedom left
    std::optional<Split> split;
    VectorXd d;
    MatrixXd basis;
    if (!y) {
      split = Split::of(A, rt_);
      d = Z_times(split->solve(b));
      basis = z_identity_ ? split->null_basis() : split->times_null(Z_);
    } else {
      d = Z_times(*y);
      basis = MatrixXd(n_, 0);
    }
    if (!step(d)) return First{split ? std::move(*split) : Split::of(A, rt_), d};
    ++iterations_;
    set_Z(basis);
    return std::nullopt;
  }

  // hqp._ActiveSet._step: q̇ += d unless a hard row blocks it (then false, nothing changes).
  bool step(const VectorXd& d) {
    const double d_norm = d.norm();
    if (!(d_norm > 1e-15 * (1.0 + x_.norm()))) return true;
    double reach = d_norm * c_norm_max_;
    if (reach >= room_) {
      if (!c_l1_max_) c_l1_max_ = C_.rows() ? C_.cwiseAbs().rowwise().sum().maxCoeff() : 0.0;
      reach = std::min(reach, d.cwiseAbs().maxCoeff() * *c_l1_max_);
    }
    if (reach < room_) {  // no hard row within reach: no ratio test
      room_ -= reach;
      x_ += d;
    } else {
      const Block block = first_block(C_, lo_, hi_, x_, d, 1e-10 * d_norm * c_norms_, false);
      if (block.step < 1.0) return false;
      x_ += d;
      room_ = room_of(C_, lo_, hi_);
    }
    x_zero_ = false;
    return true;
  }

  // hqp._ActiveSet._equality_run_at_once: the run's steps in one triangular solve when every level is
  // certified and no hard row leaves its bounds at any of the loop's corners; false (nothing changed)
  // otherwise.
  bool equality_run_at_once(const std::vector<Index>& sizes, const std::vector<Index>& starts, const MatrixXd& qr,
                            const MatrixXd& V, const VectorXd& c, Index k, std::vector<Index>& free_dims) {
    const Index count = sizes.size(), total = c.size();
    for (Index size : sizes)
      if (!size) return false;
    for (Index i = 0; i < total; ++i)
      if (qr(i, i) == 0.0) return false;  // dtrtri's info
    for (Index i = 0; i < count; ++i) {  // σ_min(R_ii) >= 1 / ||R_ii⁻¹||_F against the level's floor
      MatrixXd R_inv;
      const auto R_ii = qr.block(starts[i], starts[i], sizes[i], sizes[i]);
      upper_inverse(R_ii, R_inv);
      const double norm = R_ii.triangularView<Eigen::Upper>().toDenseMatrix().norm();
      const double floor = std::max(rt_, double(std::max(sizes[i], k - starts[i])) * kEps * norm);
      if (!(R_inv.squaredNorm() * floor * floor < 1.0)) return false;
    }
    // Rᵀ y = c: the forward substitution of L y = c, L = Rᵀ.
    const VectorXd y = qr.topLeftCorner(total, total).triangularView<Eigen::Upper>().transpose().solve(c);
    double reach = 0.0;
    for (Index i = 0; i < count; ++i) reach += y.segment(starts[i], sizes[i]).norm();
    reach *= c_norm_max_;
    VectorXd x;
    if (reach < room_) {
      room_ -= reach;
      x = x_ + V.leftCols(total) * y;
    } else {
      // The hard rows hold along the loop's path iff they hold at its corners (they are convex).
      MatrixXd corners(n_, count);
      VectorXd corner = x_;
      for (Index i = 0; i < count; ++i) {
        corner += V.middleCols(starts[i], sizes[i]) * y.segment(starts[i], sizes[i]);
        corners.col(i) = corner;
      }
      const MatrixXd after = C_ * corners;
      for (Index j = 0; j < count; ++j)
        if (!((after.col(j).array() <= hi_.array()) && (after.col(j).array() >= lo_.array())).all()) return false;
      x = corners.col(count - 1);
      room_ = C_.rows() ? (after.col(count - 1) - lo_).cwiseMin(hi_ - after.col(count - 1)).minCoeff() : kInf;
    }
    x_ = x;
    x_zero_ = x_zero_ && !(y.array() != 0.0).any();
    iterations_ += count;
    for (Index i = 0; i < count; ++i) free_dims.push_back(k - starts[i] - sizes[i]);
    set_Z(V.rightCols(k - total));
    return true;
  }

  // hqp._ActiveSet._add_hard: rows that hold at this level's optimum stay holding below.
  void add_hard(const MatrixXd& rows, const VectorXd& lower, const VectorXd& upper) {
    const VectorXd norms = row_norms(rows);
    room_ = std::min(room_, room_of(rows, lower, upper));
    if (norms.size()) c_norm_max_ = std::max(c_norm_max_, norms.maxCoeff());
    c_l1_max_.reset();
    const Index old = C_.rows(), m = rows.rows();
    C_.conservativeResize(old + m, n_);
    C_.bottomRows(m) = rows;
    lo_.conservativeResize(old + m);
    lo_.tail(m) = lower;
    hi_.conservativeResize(old + m);
    hi_.tail(m) = upper;
    c_norms_.conservativeResize(old + m);
    c_norms_.tail(m) = norms;
  }

  // hqp._ActiveSet._room: the smallest distance of rows q̇ to the nearer bound (inf without rows).
  double room_of(const MatrixXd& rows, const VectorXd& lower, const VectorXd& upper) const {
    if (!rows.rows()) return kInf;
    if (x_zero_) return (-lower).cwiseMin(upper).minCoeff();
    const VectorXd value = rows * x_;
    return (value - lower).cwiseMin(upper - value).minCoeff();
  }

  // hqp._ActiveSet._minimise: the primal active set of one level (Escande, Mansard, Wieber 2014: the
  // level's own inequality rows soft, those of the levels above that held hard, each working set one
  // least squares in the basis of what the levels above leave); updates x_ and `side` in place.
  // `side`: 2 equality, ±1 held at upper/lower, 0 free; `soft` the inequality rows. Anti-cycling:
  // Bland's smallest-index rule after bland_after iterations that do not move q̇, and a last-resort
  // guard after iterations_per_row iterations per row that names the level in `unsettled`.
  std::pair<std::optional<Last>, int> minimise(const MatrixXd& A, const VectorXd& lower, const VectorXd& upper,
                                               std::vector<signed char>& side, const Rows& soft,
                                               const std::string& name, std::optional<First> first) {
    const MatrixXd& C = C_;
    const Index n_hard = C.rows();
    std::vector<signed char> hard(n_hard, 0);  // 0 free, ±1 held at upper/lower
    Rows held;
    const int limit = iterations_per_row_ * int(A.rows() + n_hard + 1);
    VectorXd x = x_;
    int still = 0;
    bool bland = false;
    std::optional<Last> last;
    Split constraint;
    Rows constraint_rows;  // the held rows `constraint` factorises
    // The level's rows and the hard rows seen in Z, once for the level (neither changes in its active
    // set): each iteration then works in the k coordinates of Z, and only its step goes back to q̇.
    const MatrixXd AZ = times_Z(A);
    const VectorXd A_norms = soft.empty() ? VectorXd() : row_norms(A);
    MatrixXd CZ, AWZ;
    Index N_cols = 0;  // the directions left by the held hard rows
    bool has_N = false;
    Rows rows;
    MatrixXd AW;
    VectorXd target;
    for (int iteration = 1; iteration <= limit; ++iteration) {
      ++iterations_;
      if (!held.empty()) {  // the directions of Z that keep the held hard rows where they are
        if (!CZ.size()) CZ = times_Z(C);
        if (held != constraint_rows) {  // the same rows as the last iteration: the same factorisation
          constraint = Split::of(take_rows(CZ, held), rt_);
          constraint_rows = held;
        }
        N_cols = CZ.cols() - constraint.rank;
        has_N = true;
      } else {
        has_N = false;
      }
      if (!soft.empty()) {
        rows.clear();
        for (Index i = 0; i < Index(side.size()); ++i)
          if (side[i]) rows.push_back(i);
        AW = take_rows(A, rows);
        AWZ = take_rows(AZ, rows);
        target.resize(rows.size());
        for (Index j = 0; j < Index(rows.size()); ++j)
          target(j) = side[rows[j]] == -1 ? lower(rows[j]) : upper(rows[j]);
      } else {
        AW = A;
        AWZ = AZ;
        target = upper;
      }
      last.reset();
      bool moved = false;
      if (AW.rows() && (has_N ? N_cols : free_dims())) {
        Split split;
        VectorXd d;
        if (!first) {
          split = Split::of(has_N ? constraint.times_null(AWZ) : AWZ, rt_);
          const VectorXd y = split.solve(target - AW * x);
          d = Z_times(has_N ? constraint.null_times(y) : y);
        } else {  // the first iteration, already computed (the same least squares)
          split = std::move(first->split);
          d = std::move(first->d);
          first.reset();
        }
        if (held.empty()) last = Last{AW.rows(), std::move(split)};
        const double d_norm = d.norm();
        if (d_norm > 1e-15 * (1.0 + x.norm())) {
          // Ratio test: the free soft rows and the free hard rows stay within their bounds.
          double alpha = 1.0;
          int blocker_kind = 0;  // 0 none, 1 a row of the level, 2 a hard row
          Index blocker_row = -1;
          int blocker_bound = 0;
          if (!soft.empty()) {  // the level's free rows: side 0 (2 marks its equality rows)
            bool any_free = false;
            for (Index i : soft) any_free = any_free || side[i] == 0;
            if (any_free) {
              const Block b = first_block(A, lower, upper, x, d, 1e-10 * d_norm * A_norms, bland, &side);
              if (b.step < alpha) {
                alpha = b.step;
                blocker_kind = 1;
                blocker_row = b.row;
                blocker_bound = b.bound;
              }
            }
          }
          if (n_hard) {
            const Block b = first_block(C, lo_, hi_, x, d, 1e-10 * d_norm * c_norms_, bland, &hard);
            if (b.step < alpha) {
              alpha = b.step;
              blocker_kind = 2;
              blocker_row = b.row;
              blocker_bound = b.bound;
            }
          }
          moved = alpha * d_norm > 1e-15 * (1.0 + x.norm());
          x += alpha * d;
          if (blocker_kind) {
            if (blocker_kind == 1) {
              side[blocker_row] = blocker_bound;
            } else {
              hard[blocker_row] = blocker_bound;
              held = nonzero(hard);
            }
            still = moved ? 0 : still + 1;
            bland = bland || still >= bland_after_;
            continue;
          }
        }
      }
      // A full step (or none possible): the least squares is optimal on this working set.
      std::optional<Candidate> leaving;
      if (AW.rows() && (!soft.empty() || !held.empty())) {
        std::optional<Candidate> from_soft, from_hard;
        const VectorXd residual = AW * x - target;
        if (!soft.empty()) {
          Rows inequality;
          std::vector<double> wrong;
          for (Index j = 0; j < Index(rows.size()); ++j) {
            const signed char s = side[rows[j]];
            if (s != 2) {
              inequality.push_back(rows[j]);
              wrong.push_back(-s * residual(j));  // < 0: pulled outward, fine
            }
          }
          const Eigen::Map<const VectorXd> wrong_map(wrong.data(), wrong.size());
          from_soft = leaving_of(wrong_map, inequality, false, tol_, bland);
        }
        if (!held.empty() && !(bland && from_soft)) {
          VectorXd g = AW.transpose() * residual;
          if (!z_identity_) g = Z_.transpose() * g;
          const VectorXd multiplier = constraint.solve_transposed(-g);
          VectorXd wrong(held.size());
          for (Index j = 0; j < Index(held.size()); ++j) wrong(j) = -hard[held[j]] * multiplier(j);
          from_hard = leaving_of(wrong, held, true, tol_, bland);
        }
        if (from_soft && from_hard)  // Python's max keeps the first of equals: the level's row
          leaving = bland || from_soft->wrong >= from_hard->wrong ? from_soft : from_hard;
        else
          leaving = from_soft ? from_soft : from_hard;
      }
      if (!leaving) {
        x_ = x;
        x_zero_ = false;
        room_ = room_of(C, lo_, hi_);
        return {std::move(last), iteration};
      }
      if (leaving->hard) {
        hard[leaving->row] = 0;
        held = nonzero(hard);
      } else {  // free the row, unless it has crossed to its other bound
        const Index row = leaving->row;
        const double value = A.row(row).dot(x);
        side[row] = value > upper(row) + tol_ ? 1 : (value < lower(row) - tol_ ? -1 : 0);
      }
      still = moved ? 0 : still + 1;
      bland = bland || still >= bland_after_;
    }
    // The guard: q̇ stays where the active set stands (it keeps every hard row).
    x_ = x;
    x_zero_ = x_zero_ && !(x.array() != 0.0).any();
    room_ = room_of(C, lo_, hi_);
    unsettled_.push_back(name);
    return {std::nullopt, limit};
  }

  Index n_;
  double rt_, tol_;
  int bland_after_, iterations_per_row_;
  VectorXd x_;
  bool z_identity_ = true;
  MatrixXd Z_;
  MatrixXd C_;
  VectorXd lo_, hi_, c_norms_;
  // A lower bound of every hard row's distance to its nearer bound, and the largest 2-norm and 1-norm
  // of a hard row: a step with min(||d||₂ c_norm_max, ||d||∞ c_l1_max) < room needs no ratio test.
  double room_ = kInf;
  double c_norm_max_ = 0.0;
  std::optional<double> c_l1_max_ = 0.0;  // nullopt: not computed since rows were added
  int iterations_ = 0;
  std::vector<std::string> unsettled_;
  bool x_zero_ = true;    // q̇ is still the zero vector
  bool min_norm_ = true;  // every level took one minimum-norm step: q̇ is orthogonal to Z
};

// hqp._Refusal: the kept guessed rows per level, the rows found outside (-excess, level, row, side),
// and how many rows a guess may hold.
struct Refusal {
  Binding kept;
  std::vector<std::tuple<double, int, Index, double>> added;
  Index room;
};

bool all_less(const VectorXd& a, const VectorXd& b) { return (a.array() < b.array()).all(); }
bool all_equal(const VectorXd& a, const VectorXd& b) { return (a.array() == b.array()).all(); }

struct Idle {
  VectorXd x;
  std::vector<Index> free_dims;
};

// hqp._inequalities_idle: q̇ and the free dimensions when the inequality rows (those of `binding` at
// their bounds) change nothing, certified as the equality hierarchy's steps and by the signs of the
// guessed rows' multipliers; nullopt otherwise, with the refusal in `following` when one is asked for.
std::optional<Idle> inequalities_idle(const std::vector<Level>& levels, double rank_threshold, double tolerance,
                                      const Binding& binding, std::vector<Refusal>* following) {
  const Index n = levels[0].J.cols();
  struct Equality {
    MatrixXd J;
    VectorXd target;
  };
  struct Inequality {
    int index;
    MatrixXd J;
    VectorXd lower, upper;
    Rows of_level;  // empty with `all` set: every row of the level
    bool all;
  };
  struct Guessed {
    Index start;
    int index;
    std::vector<Index> rows;
    std::vector<double> sides;
  };
  std::vector<Equality> equalities, guessed_rows;
  std::vector<Inequality> inequalities;
  std::vector<Guessed> guessed;
  std::vector<Index> free_dims;
  Index total = 0, fixed = 0;
  bool last_is_equality = false;
  Index last_index = 0, last_rows = 0;
  for (int index = 0; index < int(levels.size()); ++index) {
    const Level& level = levels[index];
    const Index m = level.J.rows();
    if (!level.same && all_less(level.lower, level.upper)) {
      const auto bound = binding.find(index);
      if (bound == binding.end()) {
        inequalities.push_back({index, level.J, level.lower, level.upper, {}, true});
      } else {
        const auto& [rows, sides] = bound->second;
        VectorXd at(rows.size());
        for (Index j = 0; j < Index(rows.size()); ++j) {
          at(j) = sides[j] > 0 ? level.upper(rows[j]) : level.lower(rows[j]);
          if (!std::isfinite(at(j))) return std::nullopt;
        }
        guessed_rows.push_back({take_rows(level.J, rows), at});
        guessed.push_back({total - fixed, index, rows, sides});
        total += rows.size();
        std::vector<bool> in(m, false);
        for (Index r : rows) in[r] = true;
        Rows rest;
        for (Index i = 0; i < m; ++i)
          if (!in[i]) rest.push_back(i);
        inequalities.push_back(
            {index, take_rows(level.J, rest), take(level.lower, rest), take(level.upper, rest), rest, false});
        last_is_equality = false;
      }
    } else if (level.same || all_equal(level.lower, level.upper)) {
      if (m) {
        equalities.push_back({level.J, level.upper});
        total += m;
        fixed += m;
        last_is_equality = true;
        last_index = index;
        last_rows = m;
      }
    } else {
      return std::nullopt;
    }
    free_dims.push_back(std::max(n - fixed, Index(0)));
  }
  if (total > n && !last_is_equality) return std::nullopt;  // a tall block of guessed rows
  std::optional<Equality> last;
  if (total > n) {  // a tall last level
    last = std::move(equalities.back());
    equalities.pop_back();
  }
  const Index head = fixed - (last ? last_rows : 0);  // the equality rows stacked before the guessed
  for (auto& g : guessed) g.start += head;
  for (auto& g : guessed_rows) equalities.push_back(std::move(g));
  const Index rows = total - (last ? last->J.rows() : 0);
  if (rows >= n && last) return std::nullopt;
  VectorXd x = VectorXd::Zero(n);
  bool z_identity = true;
  MatrixXd Z, Q, R_inv;
  VectorXd y;
  if (!equalities.empty()) {
    MatrixXd A(rows, n);
    VectorXd target(rows);
    for (Index i = 0, at = 0; i < Index(equalities.size()); ++i) {
      const Index m = equalities[i].J.rows();
      A.middleRows(at, m) = equalities[i].J;
      target.segment(at, m) = equalities[i].target;
      at += m;
    }
    Eigen::HouseholderQR<MatrixXd> householder(A.transpose());
    const auto R = householder.matrixQR().topRows(rows);
    if (!upper_inverse(R, R_inv)) return std::nullopt;
    R_inv = R_inv.triangularView<Eigen::Upper>().toDenseMatrix();
    const double floor = std::max(rank_threshold, double(n) * kEps * A.norm());  // ||R||_F = ||A||_F
    if (R_inv.norm() * floor >= 1.0) return std::nullopt;
    y = R_inv.transpose() * target;  // Rᵀ y = t, with R⁻¹ at hand
    Q = householder.householderQ() * MatrixXd::Identity(n, last ? n : rows);
    x = Q.leftCols(rows) * y;
    Z = Q.rightCols(Q.cols() - rows);
    z_identity = false;
  }
  if (last) {
    const MatrixXd JZ = z_identity ? last->J : MatrixXd(last->J * Z);
    const auto u = full_rank_lstsq(JZ, last->target - last->J * x, rank_threshold);
    if (!u) return std::nullopt;
    x += z_identity ? *u : VectorXd(Z * *u);
  }
  std::vector<std::tuple<double, int, Index, double>> added;
  for (const Inequality& ineq : inequalities) {
    const VectorXd value = ineq.J * x;
    for (Index k = 0; k < value.size(); ++k) {
      const bool above = value(k) > ineq.upper(k), below = value(k) < ineq.lower(k);
      if (!(above || below)) continue;
      if (!following) return std::nullopt;
      const double excess = above ? value(k) - ineq.upper(k) : ineq.lower(k) - value(k);
      added.emplace_back(-excess, ineq.index, ineq.all ? k : ineq.of_level[k], above ? 1.0 : -1.0);
    }
  }
  Binding kept;
  bool dropped = false;
  if (!guessed.empty()) {
    VectorXd nu;
    double wrong;
    if (!last) {
      nu = R_inv * y;  // q̇* = Q₁ y = Aᵀ ν with R ν = y
      wrong = tolerance;
    } else {
      // A zero multiplier would leave its row free to move in the last level's optimal set, where the
      // least norm decides: only rows that the last level strictly holds on.
      nu = R_inv * (Q.leftCols(rows).transpose() * (last->J.transpose() * (last->J * x - last->target)));
      wrong = -tolerance;
    }
    for (const Guessed& g : guessed) {
      std::vector<Index> kept_rows;
      std::vector<double> kept_sides;
      for (Index j = 0; j < Index(g.rows.size()); ++j) {
        if (g.sides[j] * nu(g.start + j) < wrong) {
          kept_rows.push_back(g.rows[j]);
          kept_sides.push_back(g.sides[j]);
        } else {
          if (!following) return std::nullopt;
          dropped = true;
        }
      }
      if (!kept_rows.empty()) kept[g.index] = {std::move(kept_rows), std::move(kept_sides)};
    }
  }
  if (!added.empty() || dropped) {
    following->push_back({std::move(kept), std::move(added), n - 1 - (fixed - last_rows)});
    return std::nullopt;
  }
  if (!guessed.empty() && last) {
    // The last level fixes its rows in what the equality rows above it leave (the guessed rows hold,
    // they fix nothing): that space is wider than Z, its rank there is counted.
    const MatrixXd J = last->J * Q.rightCols(n - head);
    const Index left = J.cols() - Split::of(J, rank_threshold).rank;
    std::fill(free_dims.begin() + last_index, free_dims.end(), left);
  }
  return Idle{std::move(x), std::move(free_dims)};
}

// hqp._next_guess: the kept rows, and the `count` farthest out of the rows found outside that fit.
Binding next_guess(const Refusal& refusal, Index count) {
  Binding guess = refusal.kept;
  Index held = 0;
  for (const auto& [index, rs] : guess) held += rs.first.size();
  const Index space = std::max(std::min(count, refusal.room - held), Index(0));
  auto added = refusal.added;
  std::sort(added.begin(), added.end());
  for (Index i = 0; i < std::min(space, Index(added.size())); ++i) {
    const auto& [excess, index, row, side] = added[i];
    auto& [rows, sides] = guess[index];
    rows.push_back(row);
    sides.push_back(side);
  }
  for (auto& [index, rs] : guess) {  // rows increasing
    auto& [rows, sides] = rs;
    std::vector<Index> order(rows.size());
    for (Index i = 0; i < Index(order.size()); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](Index a, Index b) { return rows[a] < rows[b]; });
    std::vector<Index> r(rows.size());
    std::vector<double> s(rows.size());
    for (Index i = 0; i < Index(order.size()); ++i) {
      r[i] = rows[order[i]];
      s[i] = sides[order[i]];
    }
    rows = std::move(r);
    sides = std::move(s);
  }
  return guess;
}

struct Guesses {
  int guesses;
  int all_at_once;
};

// hqp._guessed: the shortcut from the guess `binding`, then from those each refusal gives, up to
// `guesses` equality solves; nullopt for the active set.
std::optional<Idle> guessed(const std::vector<Level>& levels, double rank_threshold, double tolerance,
                            Binding binding, const Guesses& options) {
  std::set<std::vector<double>> seen;
  std::optional<Refusal> first;
  int all_at_once = options.all_at_once;
  for (int attempt = 0; attempt < options.guesses; ++attempt) {
    std::vector<double> key;
    for (const auto& [index, rs] : binding) {
      key.push_back(index);
      key.push_back(rs.first.size());
      key.insert(key.end(), rs.first.begin(), rs.first.end());
      key.insert(key.end(), rs.second.begin(), rs.second.end());
    }
    if (!seen.insert(key).second) return std::nullopt;  // the guesses cycle
    std::vector<Refusal> following;
    auto fast = inequalities_idle(levels, rank_threshold, tolerance, binding, &following);
    if (fast || following.empty()) return fast;
    if (!first) {
      first = following[0];
      Index held = 0;
      for (const auto& [index, rs] : first->kept) held += rs.first.size();
      if (Index(first->added.size()) + held > first->room) all_at_once = 0;  // one at a time
    }
    const int tried = seen.size();
    if (tried < all_at_once)
      binding = next_guess(following[0], following[0].added.size());
    else if (tried == std::max(all_at_once, 1))  // from the first refusal, one row at a time
      binding = next_guess(*first, 1);
    else
      binding = next_guess(following[0], 1);
  }
  return std::nullopt;
}

using Result = std::tuple<VectorXd, std::vector<Index>, int, std::vector<std::string>>;

// hqp.solve_hqp after validation: the shortcut (without damping), else the level loop with its runs
// of equality levels, then the regularisation.
Result solve_hqp(const std::vector<MatrixXd>& Js, const std::vector<VectorXd>& lowers,
                 const std::vector<VectorXd>& uppers, const std::vector<bool>& same,
                 const std::vector<std::string>& names, const std::vector<double>& dampings, double rank_threshold,
                 double tolerance, const std::optional<Binding>& binding, int bland_after, int iterations_per_row,
                 int guesses, int all_at_once) {
  const Index count = Js.size();
  if (!count) return {VectorXd(0), {}, 0, {}};
  std::vector<Level> levels(count);
  for (Index i = 0; i < count; ++i) levels[i] = {Js[i], lowers[i], uppers[i], bool(same[i])};
  bool damped = false;
  for (double mu : dampings) damped = damped || mu;
  if (!damped) {
    auto fast = guessed(levels, rank_threshold, tolerance, binding.value_or(Binding()), {guesses, all_at_once});
    if (fast) return {std::move(fast->x), std::move(fast->free_dims), int(count), {}};
  }
  ActiveSet solver(Js[0].cols(), {rank_threshold, tolerance, bland_after, iterations_per_row});
  std::vector<Index> free_dims;
  Index i = 0;
  while (i < count) {
    Index run = i;
    while (run < count && levels[run].same && !dampings[run]) ++run;  // exact equality levels
    if (run - i >= 2) {
      std::vector<const Level*> slice;
      for (Index j = i; j < run; ++j) slice.push_back(&levels[j]);
      i += solver.equality_run(slice, free_dims);
      if (i == run) continue;
    }
    solver.level(levels[i], names[i], dampings[i]);
    free_dims.push_back(solver.free_dims());
    ++i;
  }
  solver.regularise();
  return {solver.x(), std::move(free_dims), solver.iterations(), solver.unsettled()};
}

// Whether levels given as float64 arrays hold what hqp._validate_hqp checks: J 2-D and finite, the
// same column count throughout; lower and upper 1-D of J's row count, no NaN, lower < +inf,
// upper > -inf, lower <= upper. One call in place of a few numpy calls per level; false sends the
// caller to _validate_hqp, which names what fails.
bool levels_hold(const std::vector<py::array_t<double>>& Js, const std::vector<py::array_t<double>>& lowers,
                 const std::vector<py::array_t<double>>& uppers) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  if (Js.size() != lowers.size() || Js.size() != uppers.size()) return false;
  for (std::size_t k = 0; k < Js.size(); ++k) {
    const auto& J = Js[k];
    if (J.ndim() != 2 || J.shape(1) != Js[0].shape(1)) return false;
    const auto j = J.unchecked<2>();
    for (py::ssize_t r = 0; r < j.shape(0); ++r)
      for (py::ssize_t c = 0; c < j.shape(1); ++c)
        if (!std::isfinite(j(r, c))) return false;
    if (lowers[k].ndim() != 1 || uppers[k].ndim() != 1 || lowers[k].shape(0) != j.shape(0) ||
        uppers[k].shape(0) != j.shape(0))
      return false;
    const auto lo = lowers[k].unchecked<1>();
    const auto hi = uppers[k].unchecked<1>();
    for (py::ssize_t r = 0; r < lo.shape(0); ++r)
      if (!(lo(r) < inf && hi(r) > -inf && lo(r) <= hi(r))) return false;  // NaN fails every test
  }
  return true;
}

}  // namespace

void bind_hqp(py::module_& m) {
  m.def("levels_hold", &levels_hold, py::arg("J"), py::arg("lower"), py::arg("upper"),
        "Whether float64 levels hold hqp._validate_hqp's checks (false: let it name what fails).");
  m.def("solve_hqp", &solve_hqp, py::arg("J"), py::arg("lower"), py::arg("upper"), py::arg("same"),
        py::arg("names"), py::arg("damping"), py::arg("rank_threshold"), py::arg("tolerance"), py::arg("binding"),
        py::arg("bland_after"), py::arg("iterations_per_row"), py::arg("guesses"), py::arg("all_at_once"),
        "hqp.solve_hqp's solver on validated levels (J (m_k, n), lower and upper (m_k,), `same`: the "
        "level was given as (J, target)), with the warm start's rows at a bound {level: (rows, sides)}; "
        "returns (qdot (n,), free_dims, iterations, unsettled names). Never raises for numeric reasons.",
        py::call_guard<py::gil_scoped_release>());
}

}  // namespace drake_sot

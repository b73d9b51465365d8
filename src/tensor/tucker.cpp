#include "strata/tensor/tucker.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/SVD>

#include "strata/tensor/ttm.hpp"
#include "tensor/decompose_kernel.hpp"

namespace strata::tensor {

void check_ranks(const Dims3& dims, const Ranks3& ranks, const char* context) {
  for (std::size_t n = 0; n < 3; ++n) {
    if (ranks[n] < 1 || ranks[n] > dims[n]) {
      throw Error(std::string(context) + ": rank R" + std::to_string(n + 1) + " = " + std::to_string(ranks[n]) +
                  " must be in [1, " + std::to_string(dims[n]) + "] for a " + to_string(dims) + " tensor");
    }
  }
}

namespace {

using MatrixD = Matrix<double>;
using detail::DecomposeKernels;
using detail::DGemmArgs;
using detail::DGramArgs;

// A grow-only double buffer: a loop over equally sized bricks allocates nothing.
class Buffer {
 public:
  double* get(std::size_t n) {
    if (values_.size() < n) values_.resize(n);
    return values_.data();
  }

 private:
  std::vector<double> values_;
};

// A dense tensor, first index fastest (like BasicTensor3): a double product in workspace memory,
// or (input set, data null) the float tensor being decomposed, which the kernels read as float
// and widen exactly on the fly.
struct TensorD {
  double* data = nullptr;
  Dims3 d{0, 0, 0};
  const float* input = nullptr;
  std::int64_t dim(int mode) const { return d[std::size_t(mode - 1)]; }
  std::int64_t size() const { return d[0] * d[1] * d[2]; }
  double at(std::int64_t i) const { return input ? double(input[i]) : data[i]; }
};

// A column-major I x R factor matrix (or R x R rotation) in workspace memory.
struct FactorD {
  double* data = nullptr;
  std::int64_t rows = 0, cols = 0;
};
using FactorsD = std::array<FactorD, 3>;

// Scratch of one thread's decompositions. The roles never overlap within one call:
// leading_left_singular_vectors uses gram/eig_*; the sweep and projections use the tensors.
struct Workspace {
  std::array<Buffer, 6> tensors;                 // intermediate products
  std::array<Buffer, 3> factors, rotations, rotated;
  Buffer transposed;                             // U^T for mode-1 products
  Buffer gram, eig_work;
};

Workspace& workspace() {
  thread_local Workspace ws;
  return ws;
}

// Bricks keep their scratch between calls; a decomposition of a large tensor (a whole volume)
// hands its buffers back when it ends instead of holding them for the thread's lifetime.
struct ReleaseLargeWorkspace {
  Workspace& ws;
  bool large;
  ~ReleaseLargeWorkspace() {
    if (large) ws = Workspace{};
  }
};
constexpr std::int64_t kLargeTensor = std::int64_t(1) << 22;  // elements

TensorD tensor_in(Buffer& b, const Dims3& d) { return {b.get(std::size_t(d[0] * d[1] * d[2])), d}; }

// Y = X ×n U^T (U is I_n x J): one GEMM for modes 1 and 3, one per frontal slice for mode 2.
TensorD ttm_transposed(const DecomposeKernels& k, const TensorD& x, int mode, const FactorD& u, Buffer& out,
                       Buffer& transposed) {
  Dims3 od = x.d;
  od[std::size_t(mode - 1)] = u.cols;
  const TensorD y = tensor_in(out, od);
  const std::int64_t i1 = x.d[0], i2 = x.d[1], i3 = x.d[2], j = u.cols;
  DGemmArgs g;
  if (mode == 1) {
    // Y (J x I2 I3) = U^T (J x I1) · X (I1 x I2 I3); U^T copied so that its columns are contiguous.
    double* ut = transposed.get(std::size_t(j * i1));
    for (std::int64_t c = 0; c < j; ++c)
      for (std::int64_t r = 0; r < i1; ++r) ut[c + r * j] = u.data[r + c * i1];
    g = DGemmArgs{j, i2 * i3, i1, ut, j, x.data, 1, i1, y.data, j};
    g.r_f = x.input;
  } else if (mode == 2) {
    // Y(:, :, i3) (I1 x J) = X(:, :, i3) (I1 x I2) · U (I2 x J), for each i3.
    g = DGemmArgs{i1, j, i2, x.data, i1, u.data, 1, i2, y.data, i1};
    g.l_f = x.input;
    g.batch = i3;
    g.l_step = i1 * i2;
    g.out_step = i1 * j;
  } else {
    // Y (I1 I2 x J) = X (I1 I2 x I3) · U (I3 x J).
    g = DGemmArgs{i1 * i2, j, i3, x.data, i1 * i2, u.data, 1, i3, y.data, i1 * i2};
    g.l_f = x.input;
  }
  k.gemm(g);
  return y;
}

// X_(n) X_(n)^T (I_n x I_n, column-major) without forming the unfolding.
void gram(const DecomposeKernels& k, const TensorD& x, int mode, double* g) {
  detail::mode_gram(k, x.d, x.data, x.input, mode, g);
}

// Makes each column's largest-magnitude entry positive (the first one on ties): singular vectors
// are defined only up to sign, and a fixed choice makes results reproducible across platforms.
void fix_signs(FactorD& u) {
  for (std::int64_t c = 0; c < u.cols; ++c) {
    double* col = u.data + c * u.rows;
    double largest = 0;  // branch-free passes: the largest magnitude, then its first position
    for (std::int64_t i = 0; i < u.rows; ++i) largest = std::max(largest, std::abs(col[i]));
    std::int64_t at = 0;
    while (at + 1 < u.rows && std::abs(col[at]) != largest) ++at;
    if (col[at] < 0)
      for (std::int64_t i = 0; i < u.rows; ++i) col[i] = -col[i];
  }
}

MatrixD unfold(const TensorD& x, int mode) {
  const Dims3& d = x.d;
  MatrixD m(x.dim(mode), x.size() / std::max<std::int64_t>(x.dim(mode), 1));
  for (std::int64_t i3 = 0; i3 < d[2]; ++i3)
    for (std::int64_t i2 = 0; i2 < d[1]; ++i2)
      for (std::int64_t i1 = 0; i1 < d[0]; ++i1) {
        const double v = x.at(i1 + d[0] * (i2 + d[1] * i3));
        if (mode == 1) m(i1, i2 + d[1] * i3) = v;
        else if (mode == 2) m(i2, i1 + d[0] * i3) = v;
        else m(i3, i1 + d[0] * i2) = v;
      }
  return m;
}

// The r leading left singular vectors of the mode-n unfolding X_(n) (I_n x J), into `out`.
// Wide unfolding (I_n <= J, every brick): the I_n x I_n Gram matrix costs I_n^2 J and its
// eigen-decomposition I_n^3, far less than an SVD of the I_n x J matrix. Tall unfolding with
// r <= J: a thin SVD of X_(n) costs I_n J^2 and avoids squaring the condition number. Tall with
// r > J: X_(n) has rank <= J, so any orthonormal completion is optimal; the Gram eigenvectors
// provide one.
FactorD leading_left_singular_vectors(const DecomposeKernels& k, Workspace& ws, const TensorD& x, int mode, int r,
                                      Buffer& out) {
  const std::int64_t rows = x.dim(mode);
  const std::int64_t cols = rows == 0 ? 0 : x.size() / rows;
  FactorD u{out.get(std::size_t(rows * r)), rows, r};
  if (rows > cols && r <= cols) {
    Eigen::BDCSVD<MatrixD> svd(unfold(x, mode), Eigen::ComputeThinU);
    Eigen::Map<MatrixD>(u.data, rows, r) = svd.matrixU().leftCols(r);
  } else {
    double* g = ws.gram.get(std::size_t(rows * rows));
    gram(k, x, mode, g);
    if (!k.leading_eigen(g, rows, r, u.data, ws.eig_work.get(std::size_t(detail::leading_eigen_work(rows)))))
      throw Error("hosvd: eigen-decomposition of the Gram matrix failed");
  }
  fix_signs(u);
  return u;
}

// ‖A - Ã‖ = sqrt(‖A‖² - ‖B‖²) when the factors are orthonormal and B is the projection of A.
// The difference is clamped at 0 because rounding can make it slightly negative at full rank.
double fit_from_norms(double norm_a, double norm_core) {
  if (norm_a == 0) return 1.0;
  const double residual_sq = std::max(norm_a * norm_a - norm_core * norm_core, 0.0);
  return 1.0 - std::sqrt(residual_sq) / norm_a;
}

double norm(const DecomposeKernels& k, const TensorD& x) {
  return std::sqrt(x.input ? k.sum_squares_f(x.input, x.size()) : k.sum_squares(x.data, x.size()));
}

Tucker to_float_model(const TensorD& core, const FactorsD& u, double fit, int iterations) {
  Tucker t;
  t.core = Tensor3(core.d);
  std::transform(core.data, core.data + core.size(), t.core.data(), [](double v) { return float(v); });
  for (std::size_t n = 0; n < 3; ++n)
    t.factors[n] = Eigen::Map<const MatrixD>(u[n].data, u[n].rows, u[n].cols).cast<float>();
  t.fit = fit;
  t.iterations = iterations;
  return t;
}

// The float input as an operand of the kernels.
TensorD input_tensor(const Tensor3& a) { return TensorD{nullptr, a.dims(), a.data()}; }

// A ×1 U1^T ×2 U2^T ×3 U3^T; each product shrinks the tensor, so the intermediates stay small
// when R_n < I_n. Uses tensors[3..5]; the result lives in tensors[5].
TensorD project(const DecomposeKernels& k, Workspace& ws, const TensorD& a, const FactorsD& u) {
  const TensorD t1 = ttm_transposed(k, a, 1, u[0], ws.tensors[3], ws.transposed);
  const TensorD t2 = ttm_transposed(k, t1, 2, u[1], ws.tensors[4], ws.transposed);
  return ttm_transposed(k, t2, 3, u[2], ws.tensors[5], ws.transposed);
}

// One HOOI sweep: each factor becomes the leading left singular vectors of A projected on the
// other two (current) factors. A ×3 U3^T is shared by the updates of U1 and U2, because U3 only
// changes last. Returns the core of the updated factors (in tensors[5]).
TensorD hooi_sweep(const DecomposeKernels& k, Workspace& ws, const TensorD& a, const Ranks3& ranks, FactorsD& u,
                   bool a3_ready) {
  auto& t = ws.tensors;
  const TensorD a3 = a3_ready ? TensorD{t[0].get(0), {a.d[0], a.d[1], u[2].cols}}
                              : ttm_transposed(k, a, 3, u[2], t[0], ws.transposed);
  u[0] = leading_left_singular_vectors(k, ws, ttm_transposed(k, a3, 2, u[1], t[1], ws.transposed), 1, ranks[0],
                                       ws.factors[0]);
  u[1] = leading_left_singular_vectors(k, ws, ttm_transposed(k, a3, 1, u[0], t[1], ws.transposed), 2, ranks[1],
                                       ws.factors[1]);
  const TensorD a1 = ttm_transposed(k, a, 1, u[0], t[0], ws.transposed);
  const TensorD a12 = ttm_transposed(k, a1, 2, u[1], t[1], ws.transposed);
  u[2] = leading_left_singular_vectors(k, ws, a12, 3, ranks[2], ws.factors[2]);
  return ttm_transposed(k, a12, 3, u[2], t[5], ws.transposed);
}

// Rotates (core, U) by the full HOSVD of the core: core' = core ×n V_n^T, U_n' = U_n V_n with
// square orthogonal V_n. The product is unchanged; the new core is all-orthogonal with
// decreasing slice norms, so leading-rank truncation drops the weakest components first.
// Reads `core` from tensors[5] and returns the rotated core in tensors[2].
TensorD order_by_core_hosvd(const DecomposeKernels& k, Workspace& ws, const TensorD& core, FactorsD& u) {
  // Mode 3 needs no rotation: the sweep ended with U3 = the leading eigenvectors of the mode-3
  // Gram matrix of A ×1 U1^T ×2 U2^T and core = that tensor ×3 U3^T, so the core's mode-3 Gram
  // matrix is already diagonal with decreasing entries (V3 = I up to rounding), and the rotations
  // of modes 1 and 2 leave it unchanged.
  FactorsD v;
  for (int n = 1; n <= 2; ++n) {
    const std::size_t i = std::size_t(n - 1);
    v[i] = leading_left_singular_vectors(k, ws, core, n, int(core.dim(n)), ws.rotations[i]);
  }
  auto& t = ws.tensors;
  const TensorD c1 = ttm_transposed(k, core, 1, v[0], t[3], ws.transposed);
  const TensorD rotated = ttm_transposed(k, c1, 2, v[1], t[2], ws.transposed);
  for (std::size_t n = 0; n < 2; ++n) {
    // U_n V_n: (I_n x R_n) · (R_n x R_n).
    FactorD un{ws.rotated[n].get(std::size_t(u[n].rows * u[n].cols)), u[n].rows, u[n].cols};
    k.gemm(DGemmArgs{un.rows, un.cols, u[n].cols, u[n].data, u[n].rows, v[n].data, 1, v[n].rows, un.data, un.rows});
    u[n] = un;
  }
  return rotated;
}

}  // namespace

Tucker hosvd(const Tensor3& a, const Ranks3& ranks) {
  check_ranks(a.dims(), ranks, "hosvd");
  const DecomposeKernels& k = detail::decompose_kernels();
  Workspace& ws = workspace();
  const ReleaseLargeWorkspace release{ws, a.size() > kLargeTensor};
  const TensorD ad = input_tensor(a);
  const double norm_a = norm(k, ad);
  FactorsD u;
  for (int n = 1; n <= 3; ++n)
    u[std::size_t(n - 1)] =
        leading_left_singular_vectors(k, ws, ad, n, ranks[std::size_t(n - 1)], ws.factors[std::size_t(n - 1)]);
  const TensorD core = project(k, ws, ad, u);
  return to_float_model(core, u, fit_from_norms(norm_a, norm(k, core)), 0);
}

Tucker hooi(const Tensor3& a, const Ranks3& ranks, const HooiOptions& options) {
  check_ranks(a.dims(), ranks, "hooi");
  if (options.max_iterations < 1) throw Error("hooi: max_iterations must be at least 1");
  const DecomposeKernels& k = detail::decompose_kernels();
  Workspace& ws = workspace();
  const ReleaseLargeWorkspace release{ws, a.size() > kLargeTensor};
  const TensorD ad = input_tensor(a);
  const double norm_a = norm(k, ad);
  // Initialisation: the sequentially truncated HOSVD (Vannieuwenhoven et al. 2012) in the order
  // 3, 2, 1: U3 from A, U2 from A ×3 U3^T, U1 from A ×3 U3^T ×2 U2^T. A ×3 U3^T is also the
  // first product of the first sweep, and U1 only serves the fit that the first sweep's
  // convergence test compares against (a sweep recomputes U1 from U2 and U3 alone).
  FactorsD u;
  auto& t = ws.tensors;
  u[2] = leading_left_singular_vectors(k, ws, ad, 3, ranks[2], ws.factors[2]);
  const TensorD a3 = ttm_transposed(k, ad, 3, u[2], t[0], ws.transposed);
  u[1] = leading_left_singular_vectors(k, ws, a3, 2, ranks[1], ws.factors[1]);
  double fit = 0;
  if (options.max_iterations > 1) {
    const TensorD a32 = ttm_transposed(k, a3, 2, u[1], t[1], ws.transposed);
    u[0] = leading_left_singular_vectors(k, ws, a32, 1, ranks[0], ws.factors[0]);
    fit = fit_from_norms(norm_a, norm(k, ttm_transposed(k, a32, 1, u[0], t[5], ws.transposed)));
  }
  TensorD core;
  int sweeps = 0;
  while (sweeps < options.max_iterations) {
    core = hooi_sweep(k, ws, ad, ranks, u, sweeps == 0);
    ++sweeps;
    const double new_fit = fit_from_norms(norm_a, norm(k, core));
    const bool converged = std::abs(new_fit - fit) < options.tolerance;
    fit = new_fit;
    if (converged) break;
  }
  if (options.order_core) core = order_by_core_hosvd(k, ws, core, u);
  return to_float_model(core, u, fit, sweeps);
}

Tucker truncate(const Tucker& model, const Ranks3& ranks) {
  check_ranks(model.core.dims(), ranks, "truncate");
  Tucker t;
  t.core = Tensor3(ranks[0], ranks[1], ranks[2]);
  for (int r3 = 0; r3 < ranks[2]; ++r3)
    for (int r2 = 0; r2 < ranks[1]; ++r2)
      for (int r1 = 0; r1 < ranks[0]; ++r1) t.core(r1, r2, r3) = model.core(r1, r2, r3);
  for (std::size_t n = 0; n < 3; ++n) t.factors[n] = model.factors[n].leftCols(ranks[n]);
  t.fit = std::numeric_limits<double>::quiet_NaN();
  t.iterations = model.iterations;
  return t;
}

double tucker_fit(const Tensor3& a, const Tucker& model) {
  const Tensor3 approx = reconstruct(model.core, model.factors);
  if (approx.dims() != a.dims()) {
    throw Error("tucker_fit: model reconstructs " + to_string(approx.dims()) + ", tensor is " + to_string(a.dims()));
  }
  double err = 0, ref = 0;
  for (std::int64_t i = 0; i < a.size(); ++i) {
    const double d = double(a.data()[i]) - double(approx.data()[i]);
    err += d * d;
    ref += double(a.data()[i]) * double(a.data()[i]);
  }
  if (ref == 0) return err == 0 ? 1.0 : -std::numeric_limits<double>::infinity();
  return 1.0 - std::sqrt(err / ref);
}

double reconstruct_voxel(const Tucker& model, std::int64_t i1, std::int64_t i2, std::int64_t i3) {
  const Ranks3 r = model.ranks();
  const auto& [u1, u2, u3] = model.factors;
  double sum = 0;
  for (int r3 = 0; r3 < r[2]; ++r3)
    for (int r2 = 0; r2 < r[1]; ++r2)
      for (int r1 = 0; r1 < r[0]; ++r1)
        sum += double(model.core(r1, r2, r3)) * double(u1(i1, r1)) * double(u2(i2, r2)) * double(u3(i3, r3));
  return sum;
}

Tensor3 reconstruct_voxelwise(const Tucker& model) {
  const Dims3 d = model.dims();
  Tensor3 out(d);
  for (std::int64_t i3 = 0; i3 < d[2]; ++i3)
    for (std::int64_t i2 = 0; i2 < d[1]; ++i2)
      for (std::int64_t i1 = 0; i1 < d[0]; ++i1) out(i1, i2, i3) = float(reconstruct_voxel(model, i1, i2, i3));
  return out;
}

}  // namespace strata::tensor

#include "strata/ta/target_codec.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>

#include <Eigen/Cholesky>

#include "strata/core/error.hpp"
#include "strata/quant/coded_brick.hpp"
#include "strata/tensor/reconstruct.hpp"
#include "strata/tensor/ttm.hpp"
#include "strata/tensor/tucker.hpp"

namespace strata::ta {

namespace {

// Codes stay below 2^30 in magnitude: the range coder's integers, with room for the sign.
constexpr double kMaxCode = double(1 << 30);
// Shrink factor of Δ when a brick misses its mean squared error cap, and the most retries.
constexpr double kRetryShrink = 1.4;
constexpr int kMaxRetries = 12;
constexpr double kUnitRoundoff = 0x1p-24;  // float32

// Per-thread scratch of the brick encoder, so a loop over bricks does not allocate for it.
struct EncoderScratch {
  tensor::BrickProjector projector;
  tensor::BrickReconstructor reconstructor;
  tensor::Tensor3 coefficients, refit, slabs, slab_core;
  std::vector<std::int32_t> codes;
};

EncoderScratch& scratch() {
  thread_local EncoderScratch s;
  return s;
}

// Σ x² of n floats in double, in four independent sums (one chain of dependent additions would
// bound the scans below by the adder's latency).
double sum_squares(const float* x, std::int64_t n) {
  double s[4] = {0, 0, 0, 0};
  std::int64_t i = 0;
  for (; i + 4 <= n; i += 4)
    for (int l = 0; l < 4; ++l) s[l] += double(x[i + l]) * double(x[i + l]);
  for (; i < n; ++i) s[0] += double(x[i]) * double(x[i]);
  return (s[0] + s[1]) + (s[2] + s[3]);
}

// Squared and largest differences of runs of samples against their decoded values, in four
// independent sums (the order is fixed: results do not depend on where a brick is coded).
struct RowErrors {
  double sums[4] = {0, 0, 0, 0};
  double max_abs = 0;
  void add(const float* samples, const float* decoded, std::int64_t n) {
    std::int64_t i = 0;
    for (; i + 4 <= n; i += 4)
      for (int l = 0; l < 4; ++l) {
        const double d = double(samples[i + l]) - double(decoded[i + l]);
        sums[l] += d * d;
        max_abs = std::max(max_abs, std::abs(d));
      }
    for (; i < n; ++i) {
      const double d = double(samples[i]) - double(decoded[i]);
      sums[0] += d * d;
      max_abs = std::max(max_abs, std::abs(d));
    }
  }
  double squared() const { return (sums[0] + sums[1]) + (sums[2] + sums[3]); }
};

struct CodedModel {
  quant::CodedBrick coded;
  quant::DequantizedModel model;
  std::array<double, 3> factor_error{0, 0, 0};  // ‖Û_n - U_n‖_F of the kept columns
};

std::size_t index3(const tensor::Dims3& d, std::int64_t i, std::int64_t j, std::int64_t k) {
  return std::size_t(i + d[0] * (j + d[1] * k));
}

// Calls f(index) for the brick's core voxels, in ascending index order.
template <class F>
void for_each_core_voxel(const tensor::Dims3& d, const CoreRegion& core, F&& f) {
  for (int k = core.lo[2]; k < core.hi[2]; ++k)
    for (int j = core.lo[1]; j < core.hi[1]; ++j)
      for (int i = core.lo[0]; i < core.hi[0]; ++i) f(index3(d, i, j, k));
}

// The code of coefficient/Δ = v: rounded to nearest, except that |v| below the zero threshold
// (>= 1/2: a dead zone) codes 0. A wider dead zone drops the isolated ±1 codes that cost more bits
// than the error they remove (measured on MRI: threshold 0.65 needs 3 % fewer bits at 40 dB).
// Branch-free (half the codes of a busy brick are 0 at random: a branch would mispredict), so
// loops over it vectorise. Truncating a + 1/2 >= 0 is its floor (std::floor is a library call
// on baseline x86-64).
inline std::int32_t quantize_coefficient(double v, double zero_threshold) {
  const double a = std::abs(v);
  const auto q = std::int32_t(std::min(a + 0.5, kMaxCode));
  const std::int32_t kept = a < zero_threshold ? 0 : q;
  return v < 0 ? -kept : kept;
}

// The stored core step: Δ, or coarser where codes of Δ would not fit (finer is beyond float).
float guarded_step(const tensor::Tensor3& coefficients, double step) {
  float max_abs = 0;
  for (float c : coefficients.values()) max_abs = std::max(max_abs, std::abs(c));
  return float(std::max(step, 2 * double(max_abs) / kMaxCode));
}

// The code of every coefficient of `core` (first index fastest).
void quantize_all(const tensor::Tensor3& core, double step, double zero_threshold, std::vector<std::int32_t>& codes) {
  codes.resize(std::size_t(core.size()));
  const float* c = core.data();
  for (std::size_t i = 0; i < codes.size(); ++i) codes[i] = quantize_coefficient(double(c[i]) / step, zero_threshold);
}

// The leading ranks that still hold a non-zero code (at most max_rank per mode).
tensor::Ranks3 nonzero_ranks(const std::vector<std::int32_t>& codes, const tensor::Dims3& d, int max_rank) {
  tensor::Ranks3 r{0, 0, 0};
  const std::int32_t* row = codes.data();
  for (std::int64_t k = 0; k < d[2]; ++k)
    for (std::int64_t j = 0; j < d[1]; ++j, row += d[0]) {
      std::int64_t last = d[0];  // one past the row's last non-zero code
      while (last > 0 && row[last - 1] == 0) --last;
      if (last == 0) continue;
      r[0] = std::max(r[0], int(last));
      r[1] = std::max(r[1], int(j) + 1);
      r[2] = int(k) + 1;
    }
  for (int& rn : r) rn = std::min(rn, max_rank);
  return r;
}

// The codes of the leading r[0] x r[1] x r[2] block of a d-sized code tensor.
std::vector<std::int32_t> leading_codes(const std::vector<std::int32_t>& codes, const tensor::Dims3& d,
                                        const tensor::Ranks3& r) {
  std::vector<std::int32_t> out(std::size_t(r[0]) * std::size_t(r[1]) * std::size_t(r[2]));
  auto at = out.begin();
  for (int k = 0; k < r[2]; ++k)
    for (int j = 0; j < r[1]; ++j) {
      const auto row = codes.begin() + std::ptrdiff_t(d[0] * (j + d[1] * k));
      at = std::copy(row, row + r[0], at);
    }
  return out;
}

// Singular value of each kept column: the norm of its slice of the kept core block.
std::array<std::vector<double>, 3> slice_norms(const tensor::Tensor3& core, const tensor::Ranks3& r) {
  std::array<std::vector<double>, 3> s{std::vector<double>(std::size_t(r[0])), std::vector<double>(std::size_t(r[1])),
                                       std::vector<double>(std::size_t(r[2]))};
  for (int k = 0; k < r[2]; ++k)
    for (int j = 0; j < r[1]; ++j) {
      const float* row = &core(0, j, k);
      for (int i = 0; i < r[0]; ++i) s[0][std::size_t(i)] += double(row[i]) * double(row[i]);
      const double row_sum = sum_squares(row, r[0]);
      s[1][std::size_t(j)] += row_sum;
      s[2][std::size_t(k)] += row_sum;
    }
  for (auto& v : s)
    for (double& x : v) x = std::sqrt(x);
  return s;
}

// Quantizes the first r columns of `u` (step Δ/σ per column, never coarser than the column's
// largest entry, so no column vanishes). Returns the dequantized columns.
tensor::Matrix<float> quantize_factor(const tensor::Matrix<float>& u, int r, const std::vector<double>& sigma,
                                      double step, std::vector<std::uint8_t>& step_codes,
                                      std::vector<std::int32_t>& codes, double& error) {
  tensor::Matrix<float> q(u.rows(), r);
  error = 0;
  for (int c = 0; c < r; ++c) {
    const double largest = u.col(c).cwiseAbs().maxCoeff();
    const double wanted = std::min(step / std::max(sigma[std::size_t(c)], 1e-300), largest);
    const std::uint8_t code = quant::factor_step_code(wanted);
    const float fs = quant::factor_step(code);
    step_codes.push_back(code);
    for (std::int64_t i = 0; i < u.rows(); ++i) {
      const auto v = std::int32_t(std::lround(double(u(i, c)) / double(fs)));
      codes.push_back(v);
      q(i, c) = float(v) * fs;
      error += std::pow(double(q(i, c)) - double(u(i, c)), 2);
    }
  }
  error = std::sqrt(error);
  return q;
}

// Left pseudo-inverse, transposed: P = Û (ÛᵀÛ)^-1, so x ×n Pᵀ is the least-squares core.
tensor::Matrix<float> pseudo_inverse_transposed(const tensor::Matrix<float>& q) {
  const Eigen::MatrixXd qd = q.cast<double>();
  const Eigen::MatrixXd gram = qd.transpose() * qd;
  const Eigen::MatrixXd p = gram.ldlt().solve(qd.transpose()).transpose();
  return p.cast<float>();
}

// Drops trailing slices whose codes are all zero, with their factor columns.
void trim_zero_slices(quant::CodedBrick& b) {
  auto slice_zero = [&](int mode, int index) {
    const tensor::Ranks3& r = b.ranks;
    std::array<int, 3> lo{0, 0, 0}, hi = r;
    lo[std::size_t(mode)] = index;
    hi[std::size_t(mode)] = index + 1;
    for (int k = lo[2]; k < hi[2]; ++k)
      for (int j = lo[1]; j < hi[1]; ++j)
        for (int i = lo[0]; i < hi[0]; ++i)
          if (b.core_codes[std::size_t(i + r[0] * (j + r[1] * k))] != 0) return false;
    return true;
  };
  tensor::Ranks3 keep = b.ranks;
  for (int n = 0; n < 3; ++n)
    while (keep[std::size_t(n)] > 0 && slice_zero(n, keep[std::size_t(n)] - 1)) --keep[std::size_t(n)];
  if (keep == b.ranks) return;
  if (keep[0] == 0 || keep[1] == 0 || keep[2] == 0) keep = {0, 0, 0};
  std::vector<std::int32_t> core(std::size_t(keep[0]) * std::size_t(keep[1]) * std::size_t(keep[2]));
  for (int k = 0; k < keep[2]; ++k)
    for (int j = 0; j < keep[1]; ++j)
      for (int i = 0; i < keep[0]; ++i)
        core[std::size_t(i + keep[0] * (j + keep[1] * k))] = b.core_codes[std::size_t(i + b.ranks[0] * (j + b.ranks[1] * k))];
  std::vector<std::int32_t> factors;
  std::vector<std::uint8_t> steps;
  std::size_t at = 0, column = 0;
  for (std::size_t n = 0; n < 3; ++n)
    for (int c = 0; c < b.ranks[n]; ++c, ++column, at += std::size_t(quant::coded_rows(b, int(n)))) {
      if (c >= keep[n]) continue;
      steps.push_back(b.factor_step_codes[column]);
      factors.insert(factors.end(), b.factor_codes.begin() + std::ptrdiff_t(at),
                     b.factor_codes.begin() + std::ptrdiff_t(at + std::size_t(quant::coded_rows(b, int(n)))));
    }
  b.ranks = keep;
  b.core_codes = std::move(core);
  b.factor_codes = std::move(factors);
  b.factor_step_codes = std::move(steps);
}

// Steps 2 and 3 of the header: ranks, quantized factors, re-fitted and quantized core.
CodedModel code_model(const tensor::Tensor3& x0, int margin, const tensor::Tucker& full, double step,
                      const BrickTarget& target, float offset) {
  CodedModel out;
  quant::CodedBrick& b = out.coded;
  b.dims = full.dims();
  b.offset = offset;
  b.core_step = guarded_step(full.core, step);
  step = double(b.core_step);
  EncoderScratch& scratch = ::strata::ta::scratch();
  quantize_all(full.core, step, target.zero_threshold, scratch.codes);
  tensor::Ranks3 r = nonzero_ranks(scratch.codes, full.core.dims(), target.max_rank);
  if (r[0] > 0) {
    const auto sigma = slice_norms(full.core, r);
    tensor::Factors<float> pinv;
    for (std::size_t n = 0; n < 3; ++n) {
      const tensor::Matrix<float> q =
          quantize_factor(full.factors[n], r[n], sigma[n], step, b.factor_step_codes, b.factor_codes, out.factor_error[n]);
      pinv[n] = pseudo_inverse_transposed(q);
    }
    tensor::TuckerView bases;
    bases.dims = b.dims;
    bases.ranks = r;
    for (std::size_t n = 0; n < 3; ++n) bases.factors[n] = pinv[n].data();
    tensor::Tensor3& core = scratch.refit;
    scratch.projector.project(x0.values(), x0.dims(), {margin, margin, margin}, bases, core);
    b.ranks = r;
    b.core_codes.resize(std::size_t(core.size()));
    for (std::size_t i = 0; i < b.core_codes.size(); ++i)
      b.core_codes[i] = quantize_coefficient(double(core.values()[i]) / step, target.zero_threshold);
    trim_zero_slices(b);
  }
  if (b.ranks[0] == 0) {
    b.ranks = {0, 0, 0};
    b.core_codes.clear();
    b.factor_codes.clear();
    b.factor_step_codes.clear();
  }
  b.error_table.assign(std::size_t(std::max({b.ranks[0], b.ranks[1], b.ranks[2]})), 0);
  quant::dequantize(b, out.model);
  return out;
}

// The fixed alternative to step 2–3: a block-DCT basis (no factor bits for the fitted rows; the
// rank slider then keeps the lowest frequencies of every block).
CodedModel code_model_dct(const tensor::Tensor3& coefficients, int block, double step, const BrickTarget& target,
                          float offset) {
  CodedModel out;
  quant::CodedBrick& b = out.coded;
  b.dims = coefficients.dims();
  b.offset = offset;
  b.dct_block = std::uint8_t(block);
  b.core_step = guarded_step(coefficients, step);
  step = double(b.core_step);
  std::vector<std::int32_t>& codes = scratch().codes;
  quantize_all(coefficients, step, target.zero_threshold, codes);
  const tensor::Ranks3 r = nonzero_ranks(codes, coefficients.dims(), target.max_rank);
  if (r[0] > 0) {
    const auto sigma = slice_norms(coefficients, r);
    b.ranks = r;
    for (std::size_t n = 0; n < 3; ++n)
      for (int c = 0; c < r[n]; ++c)
        b.factor_step_codes.push_back(quant::factor_step_code(std::min(1.0, step / std::max(sigma[n][std::size_t(c)], 1e-300))));
    b.core_codes = leading_codes(codes, coefficients.dims(), r);
    trim_zero_slices(b);
  }
  if (b.ranks[0] == 0) {
    b.ranks = {0, 0, 0};
    b.core_codes.clear();
    b.factor_step_codes.clear();
  }
  b.error_table.assign(std::size_t(std::max({b.ranks[0], b.ranks[1], b.ranks[2]})), 0);
  quant::dequantize(b, out.model);
  // The basis is exact up to its float rounding.
  for (std::size_t n = 0; n < 3; ++n) out.factor_error[n] = std::sqrt(double(b.dims[n] * b.ranks[n])) * kUnitRoundoff;
  return out;
}

// The block-DCT coefficients of the fitted region [margin, B - margin)^3 of x0.
const tensor::Tensor3& block_dct_coefficients(const tensor::Tensor3& x0, int margin, int block) {
  EncoderScratch& s = scratch();
  tensor::TuckerView basis;
  for (std::size_t n = 0; n < 3; ++n) {
    const int rows = int(x0.dims()[n] - 2 * margin);
    basis.dims[n] = rows;
    basis.ranks[n] = rows;
    basis.factors[n] = quant::block_dct_basis(rows, block).data();
  }
  s.projector.project(x0.values(), x0.dims(), {margin, margin, margin}, basis, s.coefficients);
  return s.coefficients;
}

// The samples the model is fitted on: [margin, B - margin) along every mode.
tensor::Tensor3 fitted_region(const tensor::Tensor3& x, int margin) {
  const tensor::Dims3& d = x.dims();
  tensor::Tensor3 out(d[0] - 2 * margin, d[1] - 2 * margin, d[2] - 2 * margin);
  for (std::int64_t k = 0; k < out.dims()[2]; ++k)
    for (std::int64_t j = 0; j < out.dims()[1]; ++j)
      for (std::int64_t i = 0; i < out.dims()[0]; ++i) out(i, j, k) = x(i + margin, j + margin, k + margin);
  return out;
}

// The 2·margin overlap positions of mode n, as the last mode of a small tensor whose first two
// modes are the fitted region of the other two (lower mode first): S(a, b, q) is the sample at
// the q-th overlap position (the margin rows before the region, then those after it).
const tensor::Tensor3& overlap_slabs(const tensor::Tensor3& x0, int n, int margin, const tensor::Dims3& region) {
  tensor::Tensor3& s = scratch().slabs;
  const std::size_t sn = std::size_t(n);
  const std::int64_t ea = region[n == 0 ? 1 : 0], eb = region[n == 2 ? 1 : 2];
  if (s.dims() != tensor::Dims3{ea, eb, 2 * margin}) s = tensor::Tensor3(ea, eb, 2 * margin);
  for (std::int64_t q = 0; q < 2 * margin; ++q) {
    const std::int64_t p = q < margin ? q : region[sn] + q;
    for (std::int64_t bb = 0; bb < eb; ++bb)
      for (std::int64_t aa = 0; aa < ea; ++aa)
        s(aa, bb, q) = n == 0 ? x0(p, aa + margin, bb + margin)
                     : n == 1 ? x0(aa + margin, p, bb + margin)
                              : x0(aa + margin, bb + margin, p);
  }
  return s;
}

// C_(n) · vec(P_q) for every overlap position q: P = r_a x r_b x 2·margin (the slabs in the
// bases of the other two modes), C the core; r_n x 2·margin.
Eigen::MatrixXd core_times_slabs(const tensor::Tensor3& core, int n, const tensor::Tensor3& p) {
  // In float (a fit; its error is measured afterwards): no double copies of the core.
  const tensor::Dims3& r = core.dims();
  const std::int64_t q = p.dims()[2];
  const Eigen::Map<const Eigen::MatrixXf> c(core.data(), r[0], r[1] * r[2]);
  if (n == 0) return (c * Eigen::Map<const Eigen::MatrixXf>(p.data(), r[1] * r[2], q)).cast<double>();
  if (n == 2) {
    const Eigen::Map<const Eigen::MatrixXf> by_slice(core.data(), r[0] * r[1], r[2]);
    return (by_slice.transpose() * Eigen::Map<const Eigen::MatrixXf>(p.data(), r[0] * r[1], q)).cast<double>();
  }
  // Mode 2: Σ_k C(:, :, k)^T P(:, k, :).
  Eigen::MatrixXf out = Eigen::MatrixXf::Zero(r[1], q);
  for (std::int64_t k = 0; k < r[2]; ++k) {
    const Eigen::Map<const Eigen::MatrixXf> slice(core.data() + r[0] * r[1] * k, r[0], r[1]);
    const Eigen::Map<const Eigen::MatrixXf, 0, Eigen::OuterStride<>> pk(p.data() + r[0] * k, r[0], q,
                                                                      Eigen::OuterStride<>(r[0] * r[2]));
    out.noalias() += slice.transpose() * pk;
  }
  return out.cast<double>();
}

// G_(n) G_(n)^T of the model with mode n in coefficient space (G = C ×a U_a ×b U_b). For the
// block DCT, G = C = codes · Δ, and the Gram of the integer codes is exact and quick.
Eigen::MatrixXd model_gram(const CodedModel& cm, const tensor::Tensor3& core, const tensor::Factors<float>& u, int n) {
  const quant::CodedBrick& b = cm.coded;
  if (b.dct_block > 0) {
    if (const auto exact = tensor::integer_gram(b.core_codes, core.dims(), n + 1))
      return *exact * (double(b.core_step) * double(b.core_step));
    return tensor::gram(core, n + 1);
  }
  tensor::Tensor3 g = core;
  for (int other = 0; other < 3; ++other)
    if (other != n) g = tensor::ttm(g, other + 1, u[std::size_t(other)]);
  return tensor::gram(g, n + 1);
}

// The overlap voxels (shared with the neighbours for interpolation) are not fitted: each
// factor gets rows for them by least squares against the samples there, given the core model.
// They cost 2·margin factor rows per mode instead of (B/(B - 2·margin))^3 more coefficients.
// Row p of mode n minimises ‖T_p - G ×n u_p‖ + ridge·‖u_p‖², G = C ×a U_a ×b U_b (the model with
// mode n in coefficient space): u_p = (G_(n) G_(n)^T + ridge I)^-1 C_(n) vec(U_a^T T_p U_b).
// For an orthonormal basis (the block DCT) G_(n) G_(n)^T = C_(n) C_(n)^T, so G is never formed.
void extend_factors(CodedModel& cm, const tensor::Tensor3& x0, int margin) {
  quant::CodedBrick& b = cm.coded;
  const tensor::Dims3 region = b.dims;
  b.dims = x0.dims();
  if (b.dct_block > 0) b.margin = std::uint8_t(margin);
  if (b.ranks[0] == 0 || margin == 0) {
    quant::dequantize(b, cm.model);
    return;
  }
  const tensor::Ranks3 r = b.ranks;
  tensor::Tensor3 core(r[0], r[1], r[2]);
  std::copy(cm.model.core.begin(), cm.model.core.end(), core.values().begin());
  tensor::Factors<float> u;
  for (std::size_t n = 0; n < 3; ++n)
    u[n] = Eigen::Map<const tensor::Matrix<float>>(cm.model.factors[n].data(), region[n], r[n]);
  EncoderScratch& scratch = ::strata::ta::scratch();
  std::vector<std::int32_t> codes;
  std::size_t column = 0, old_at = 0;
  for (int n = 0; n < 3; ++n) {
    const std::size_t sn = std::size_t(n), a = n == 0 ? 1 : 0, bm = n == 2 ? 1 : 2;
    // Ridge: weak columns would otherwise fit the overlap's noise with huge entries. The weight
    // is the quantization noise per sample over the spread of an orthonormal basis entry.
    const double ridge = double(b.core_step) * double(b.core_step) * double(region[sn]) / 12.0;
    const Eigen::MatrixXd gram = model_gram(cm, core, u, n);
    const auto solver = (gram + ridge * Eigen::MatrixXd::Identity(r[sn], r[sn])).ldlt();
    tensor::TuckerView bases;
    const tensor::Tensor3& slabs = overlap_slabs(x0, n, margin, region);
    bases.dims = slabs.dims();
    bases.ranks = {r[a], r[bm], int(2 * margin)};
    const Eigen::MatrixXf identity = Eigen::MatrixXf::Identity(2 * margin, 2 * margin);
    bases.factors = {u[a].data(), u[bm].data(), identity.data()};
    scratch.projector.project(slabs.values(), slabs.dims(), {0, 0, 0}, bases, scratch.slab_core);
    const Eigen::MatrixXd solved = solver.solve(core_times_slabs(core, n, scratch.slab_core));  // r_n x 2·margin
    const std::int64_t m = region[sn];
    Eigen::MatrixXd rows(x0.dims()[sn], r[sn]);  // new factor: the overlap rows below
    for (std::int64_t q = 0; q < 2 * margin; ++q) rows.row(q < margin ? q : m + q) = solved.col(q).transpose();
    // A continuation far larger than any basis row would amplify rounding; such a row repeats
    // the nearest fitted row instead (what clamped edge samples look like anyway).
    const double largest_fitted = u[sn].rowwise().norm().maxCoeff();
    for (std::int64_t p = 0; p < x0.dims()[sn]; ++p) {
      if (p >= margin && p < margin + m) continue;
      if (rows.row(p).norm() > 2 * largest_fitted)
        rows.row(p) = u[sn].row(p < margin ? 0 : m - 1).cast<double>();
    }
    for (int c = 0; c < r[sn]; ++c, ++column) {
      const double step = double(quant::factor_step(b.factor_step_codes[column]));
      for (std::int64_t p = 0; p < x0.dims()[sn]; ++p) {
        const bool fitted = p >= margin && p < margin + m;
        if (fitted && b.dct_block > 0) continue;  // the basis itself, not coded
        const double value = rows(p, c) / step;
        codes.push_back(fitted ? b.factor_codes[old_at + std::size_t(p - margin)]
                               : std::int32_t(std::lround(std::clamp(value, -kMaxCode, kMaxCode))));
      }
      if (b.dct_block == 0) old_at += std::size_t(m);
    }
  }
  b.factor_codes = std::move(codes);
  if (b.dct_block > 0) b.margin = std::uint8_t(margin);
  quant::dequantize(b, cm.model);
  // The factor error bound of the decoder slack and the error table covers the fitted rows
  // only; the overlap rows widen it by their norm (they are not near an orthonormal basis).
  for (std::size_t n = 0; n < 3; ++n) {
    const Eigen::Map<const tensor::Matrix<float>> full(cm.model.factors[n].data(), x0.dims()[n], r[n]);
    double extra = 0;
    for (std::int64_t p = 0; p < x0.dims()[n]; ++p)
      if (p < margin || p >= margin + region[n]) extra += double(full.row(p).squaredNorm());
    cm.factor_error[n] += std::sqrt(extra);
  }
}


// A bound on how far two decoders (another instruction set, another summation order) can land
// from the encoder's own reconstruction of `m`: the TTM chain's rounding, γ_(R1+R2+R3+2) times
// the largest voxel magnitude ‖B‖_F Π max_i ‖row i of Û_n‖ (Cauchy–Schwarz on a row of the
// Kronecker product), twice, plus the roundings of the offset and correction additions.
double decoder_slack(const CodedModel& m, double max_correction) {
  double magnitude = std::sqrt(sum_squares(m.model.core.data(), std::int64_t(m.model.core.size())));
  for (std::size_t n = 0; n < 3 && m.model.has_tucker(); ++n) {
    const Eigen::Map<const tensor::Matrix<float>> u(m.model.factors[n].data(), m.model.dims[n], m.model.ranks[n]);
    magnitude *= double(u.rowwise().norm().maxCoeff());
  }
  const double rounds = double(m.coded.ranks[0] + m.coded.ranks[1] + m.coded.ranks[2] + 2);
  return 2 * rounds * kUnitRoundoff * magnitude +
         4 * kUnitRoundoff * (std::abs(double(m.coded.offset)) + magnitude + max_correction);
}

// Adds the sparse correction that brings every voxel within `bound` of its sample (step 2·bound,
// so the remainder of a rounded quotient is at most `bound`). False when a correction would not
// fit in a code.
bool add_corrections(std::span<const float> samples, std::span<float> decoded, const tensor::Dims3& d,
                     const CoreRegion& core, double bound, CodedModel& m) {
  quant::CodedBrick& b = m.coded;
  const float step = float(2 * bound);
  b.correction_step = 0;
  b.correction_index.clear();
  b.correction_codes.clear();
  bool fits = true;
  for_each_core_voxel(d, core, [&](std::size_t i) {
    const double miss = double(samples[i]) - double(decoded[i]);
    if (!fits || std::abs(miss) <= bound) return;
    const double quotient = miss / double(step);
    if (!(std::abs(quotient) < kMaxCode)) {
      fits = false;
      return;
    }
    auto code = std::int32_t(std::lround(quotient));
    // The float sum the decoder forms; nudge the code if its rounding lands outside the bound.
    float corrected = decoded[i] + float(code) * step;
    for (int tries = 0; tries < 2 && std::abs(double(samples[i]) - double(corrected)) > bound; ++tries) {
      code += double(samples[i]) > double(corrected) ? 1 : -1;
      corrected = decoded[i] + float(code) * step;
    }
    if (code == 0 || std::abs(double(samples[i]) - double(corrected)) > bound) {
      fits = false;
      return;
    }
    b.correction_index.push_back(std::uint32_t(i));
    b.correction_codes.push_back(code);
    decoded[i] = corrected;
  });
  if (!fits) return false;
  if (!b.correction_index.empty()) b.correction_step = step;
  m.model.correction_index = b.correction_index;
  m.model.correction_value.resize(b.correction_codes.size());
  for (std::size_t i = 0; i < b.correction_codes.size(); ++i) m.model.correction_value[i] = float(b.correction_codes[i]) * step;
  return true;
}

// Upper bounds of the brick's RMSE at leading ranks K = 1..max(R_n), rounded up into codes:
// ‖X - X̂_K‖ <= ‖X - X̂‖ + ‖B - B_K‖_F Π‖Û_n‖_2 and ‖Û_n‖_2 <= 1 + ‖Û_n - U_n‖_F. At full rank
// the measured error (with the correction) is exact.
void fill_error_table(CodedModel& m, double error_without_correction, double error_full, double slack,
                      std::int64_t voxels) {
  quant::CodedBrick& b = m.coded;
  const tensor::Ranks3& r = b.ranks;
  const int rmax = std::max({r[0], r[1], r[2]});
  std::vector<double> energy_by_shell(std::size_t(rmax), 0.0);  // coefficients with max(i, j, k) = s
  double total = 0;
  for (int k = 0; k < r[2]; ++k)
    for (int j = 0; j < r[1]; ++j) {
      // Along a row, entries up to max(j, k) share that shell; each later entry is its own.
      const float* row = m.model.core.data() + std::size_t(r[0]) * std::size_t(j + r[1] * k);
      const int shared = std::min(std::max(j, k) + 1, r[0]);
      if (shared > 0) energy_by_shell[std::size_t(std::max(j, k))] += sum_squares(row, shared);
      for (int i = shared; i < r[0]; ++i) energy_by_shell[std::size_t(i)] += double(row[i]) * double(row[i]);
    }
  for (double e : energy_by_shell) total += e;
  double gain = 1;
  for (double e : m.factor_error) gain *= 1 + e;
  const double n = std::sqrt(double(voxels));
  double kept = 0;
  for (int k = 1; k <= rmax; ++k) {
    kept += energy_by_shell[std::size_t(k - 1)];
    const double rmse = k == rmax ? error_full / n
                                  : (error_without_correction + std::sqrt(std::max(total - kept, 0.0)) * gain) / n;
    b.error_table[std::size_t(k - 1)] = quant::error_code((rmse + slack) * (1 + 1e-6), b.core_step);
  }
}

double residual_norm(std::span<const float> samples, std::span<const float> decoded) {
  RowErrors all;
  all.add(samples.data(), decoded.data(), std::int64_t(samples.size()));
  return std::sqrt(all.squared());
}

// What the encoder needs of the samples before coding, in one pass: their range (a constant
// brick has min = max), their sum (the offset) and whether all are finite.
struct SampleSummary {
  float min = 0, max = 0;
  double sum = 0;
  bool finite = true;
};

SampleSummary summarize(std::span<const float> v) {
  SampleSummary s;
  if (v.empty()) return s;
  float mn = v[0], mx = v[0];
  double sums[4] = {0, 0, 0, 0};  // independent chains, as in sum_squares
  bool bad = false;
  std::size_t i = 0;
  for (; i + 4 <= v.size(); i += 4)
    for (std::size_t l = 0; l < 4; ++l) {
      const float x = v[i + l];
      mn = x < mn ? x : mn;
      mx = x > mx ? x : mx;
      bad |= !(std::abs(x) <= std::numeric_limits<float>::max());
      sums[l] += double(x);
    }
  for (; i < v.size(); ++i) {
    mn = v[i] < mn ? v[i] : mn;
    mx = v[i] > mx ? v[i] : mx;
    bad |= !(std::abs(v[i]) <= std::numeric_limits<float>::max());
    sums[0] += double(v[i]);
  }
  s.min = mn, s.max = mx;
  s.sum = (sums[0] + sums[1]) + (sums[2] + sums[3]);
  s.finite = !bad;
  return s;
}

// The brick as one value: its mean, when that already meets the target.
bool fits_offset(std::span<const float> v, float offset, const tensor::Dims3& d, const CoreRegion& core,
                 const BrickTarget& t) {
  double sum = 0, worst = 0;
  std::int64_t count = 0;
  for_each_core_voxel(d, core, [&](std::size_t i) {
    const double e = double(v[i]) - double(offset);
    sum += e * e;
    worst = std::max(worst, std::abs(e));
    ++count;
  });
  return worst <= t.max_error && (count == 0 || sum / double(count) <= t.mse_cap);
}

EncodedBrick constant_brick(float value, std::span<float> decoded) {
  EncodedBrick out;
  out.kind = store::PayloadKind::constant;
  out.constant_value = value;
  std::fill(decoded.begin(), decoded.end(), value);
  return out;
}

EncodedBrick lossless_decoded_brick(std::span<const float> samples, int width, int zstd_level, std::span<float> decoded) {
  std::copy(samples.begin(), samples.end(), decoded.begin());
  return lossless_brick(samples, width, zstd_level);
}

struct CodedPayload {
  std::vector<std::byte> bytes;
  bool empty = false;  // no model and no correction: the brick decodes to its offset
};

// Steps 4–6 for one basis: codes the brick with `make(Δ)`, shrinking Δ until the brick's mean
// squared error fits, adds the max-error correction and the error table. `decoded` receives the
// decoder's samples. Nothing when only a lossless brick meets the target.
template <class MakeModel>
std::optional<CodedPayload> code_with_basis(MakeModel&& make, std::span<const float> v, const tensor::Tensor3& x0,
                                            const CoreRegion& core, const BrickTarget& target, std::span<float> decoded) {
  tensor::BrickReconstructor& reconstructor = scratch().reconstructor;
  const tensor::Dims3& d = x0.dims();
  double step = target.core_step;
  CodedModel m;
  CoreError error;
  for (int attempt = 0;; ++attempt) {
    m = make(step);
    extend_factors(m, x0, core.margin);
    reconstruct_model(m.model, m.model.ranks, reconstructor, decoded);
    error = core_error(v, decoded, d, core);
    if (attempt == kMaxRetries || error.mse() <= target.mse_cap) break;
    step /= kRetryShrink;
  }
  const double error_without_correction = residual_norm(v, decoded);
  if (std::isfinite(target.max_error)) {
    // A correction is at most the largest miss plus the bound.
    const double slack = decoder_slack(m, error.max_abs + target.max_error);
    const double bound = target.max_error - slack;
    if (!(bound > 0) || !add_corrections(v, decoded, d, core, bound, m)) return std::nullopt;
  } else if (error.mse() > target.mse_cap) {
    return std::nullopt;
  }
  double max_correction = 0;
  for (float c : m.model.correction_value) max_correction = std::max(max_correction, double(std::abs(c)));
  fill_error_table(m, error_without_correction, residual_norm(v, decoded), decoder_slack(m, max_correction), x0.size());
  return CodedPayload{quant::serialize(m.coded), m.coded.ranks[0] == 0 && m.coded.correction_index.empty()};
}

// Δ per unit of the target. Uniform quantization adds Δ²/12 per coded coefficient; coefficients
// below Δ/2 are dropped and add less, so Δ = √12 · RMSE keeps the mean squared error under the
// target and the per-brick cap catches the exceptions. Under a max-error target, Δ = E leaves
// a model error of about E/√12 RMS, so only the rare voxels beyond E need a correction.
constexpr double kStepPerRmse = 3.4641016151377544;  // √12
constexpr double kStepPerMaxError = 1.0;

}  // namespace

CoreError core_error(std::span<const float> samples, std::span<const float> decoded, const tensor::Dims3& dims,
                     const CoreRegion& core) {
  CoreError e;
  RowErrors rows;
  for (int k = core.lo[2]; k < core.hi[2]; ++k)
    for (int j = core.lo[1]; j < core.hi[1]; ++j) {
      const std::size_t at = index3(dims, core.lo[0], j, k);
      rows.add(samples.data() + at, decoded.data() + at, core.hi[0] - core.lo[0]);
    }
  e.squared = rows.squared();
  e.max_abs = rows.max_abs;
  e.voxels = std::int64_t(core.hi[0] - core.lo[0]) * (core.hi[1] - core.lo[1]) * (core.hi[2] - core.lo[2]);
  return e;
}

int dct_block_width(std::int64_t fitted) {
  // zfp-like locality without zfp's 4^3 block overhead.
  int best = 0;
  for (int w = 4; w <= 16; ++w)
    if (fitted % w == 0 && (best == 0 || std::abs(w - 8) < std::abs(best - 8))) best = w;
  return best;
}

void check_target(const ErrorTarget& t) {
  if (t.kind == TargetKind::none) return;
  const double limit = t.kind == TargetKind::psnr ? 300.0 : std::numeric_limits<double>::max();
  if (!std::isfinite(t.value) || !(t.value > 0) || t.value > limit)
    throw ParameterError("ErrorTarget::value", std::string("the ") + target_kind_name(t.kind) +
                                                   " target must be finite and positive" +
                                                   (t.kind == TargetKind::psnr ? " (at most 300 dB)" : "") + ", got " +
                                                   std::to_string(t.value));
  if (!std::isfinite(t.coarse_growth) || !(t.coarse_growth >= 1))
    throw ParameterError("ErrorTarget::coarse_growth", "must be at least 1, got " + std::to_string(t.coarse_growth));
}

double target_rmse(const ErrorTarget& t, double lo, double hi) {
  if (t.kind == TargetKind::rmse) return t.value;
  if (t.kind != TargetKind::psnr) return 0;
  // A constant volume has no range; every brick is then constant and the value is never used.
  const double range = hi > lo ? hi - lo : 1.0;
  return range * std::pow(10.0, -t.value / 20.0);
}

std::vector<BrickTarget> level_targets(const ErrorTarget& t, double lo, double hi, int level_count, int max_rank,
                                       int zstd_level, double level0_step) {
  check_target(t);
  if (t.kind == TargetKind::none) throw Error("level_targets: no target");
  std::vector<BrickTarget> out;
  for (int l = 0; l < level_count; ++l) {
    const double scale = std::pow(t.coarse_growth, l);
    BrickTarget b;
    b.max_rank = max_rank;
    b.zstd_level = zstd_level;
    if (t.kind == TargetKind::max_error) {
      b.max_error = t.value * scale;
      b.core_step = b.max_error * kStepPerMaxError;
    } else {
      const double rmse = target_rmse(t, lo, hi) * scale;
      // Only here: under a max-error target every coefficient a dead zone drops would come back
      // as corrections, so those keep plain rounding.
      b.zero_threshold = kMseZeroThreshold;
      if (level0_step > 0) {
        b.core_step = level0_step * scale;  // one step per level: a global budget, no cap
      } else {
        b.mse_cap = rmse * rmse;
        b.core_step = rmse * kStepPerRmse;
      }
    }
    out.push_back(b);
  }
  return out;
}

EncodedBrick encode_brick_to_target(const tensor::Tensor3& samples, const CoreRegion& core, const BrickTarget& target,
                                    std::span<float> decoded) {
  const std::span<const float> v = samples.values();
  if (decoded.size() != v.size()) throw Error("encode: decode buffer does not match the brick");
  const SampleSummary summary = summarize(v);
  if (!summary.finite) throw Error("encode: non-finite sample in the brick");
  if (summary.min == summary.max) return constant_brick(v[0], decoded);
  const auto offset = float(summary.sum / double(v.size()));
  // A bounded brick (per-brick cap or max error) is constant when its mean meets the bound; under
  // a global budget, when no coefficient survives the step.
  const bool bounded = std::isfinite(target.mse_cap) || std::isfinite(target.max_error);
  if (bounded && fits_offset(v, offset, samples.dims(), core, target)) return constant_brick(offset, decoded);

  tensor::Tensor3 x0(samples.dims());
  for (std::size_t i = 0; i < v.size(); ++i) x0.values()[i] = v[i] - offset;
  // The block-DCT basis first: it is cheap, and an empty result means the brick is its offset.
  const int block = dct_block_width(x0.dims()[0] - 2 * core.margin);
  std::optional<CodedPayload> dct;
  if (block > 0) {
    const tensor::Tensor3& coefficients = block_dct_coefficients(x0, core.margin, block);
    dct = code_with_basis([&](double step) { return code_model_dct(coefficients, block, step, target, offset); }, v,
                          x0, core, target, decoded);
  }
  if (dct && dct->empty) return constant_brick(offset, decoded);
  std::vector<float> tucker_decoded;
  std::optional<CodedPayload> tucker;
  if (target.try_hosvd || !dct) {  // also when the block-DCT basis could not meet the target
    tucker_decoded.resize(v.size());
    const tensor::Tensor3 fitted = fitted_region(x0, core.margin);
    const tensor::Tucker full =
        tensor::hosvd(fitted, {int(fitted.dims()[0]), int(fitted.dims()[1]), int(fitted.dims()[2])});
    tucker = code_with_basis([&](double step) { return code_model(x0, core.margin, full, step, target, offset); }, v,
                             x0, core, target, tucker_decoded);
  }
  CodedPayload* best = dct ? &*dct : nullptr;
  if (tucker && (!best || tucker->bytes.size() < best->bytes.size())) {
    best = &*tucker;
    std::copy(tucker_decoded.begin(), tucker_decoded.end(), decoded.begin());
  }
  const int width = int(samples.dims()[0]);
  if (!best) return lossless_decoded_brick(v, width, target.zstd_level, decoded);
  if (best->empty) return constant_brick(offset, decoded);

  EncodedBrick out;
  out.kind = store::PayloadKind::tucker_coded;
  if (dct && tucker) {
    out.block_dct_bytes = dct->bytes.size();
    out.hosvd_bytes = tucker->bytes.size();
  }
  out.payload = std::move(best->bytes);
  out.header_bytes = out.payload.size();  // split in `strata eval` (ta/evaluate.cpp)
  out = lossless_if_smaller(std::move(out), v, width, target.zstd_level);
  if (out.kind == store::PayloadKind::raw_packed) std::copy(v.begin(), v.end(), decoded.begin());
  return out;
}

}  // namespace strata::ta

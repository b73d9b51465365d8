#include "strata/tensor/ttm.hpp"

#include <algorithm>
#include <bit>
#include <string>
#include <type_traits>
#include <vector>

#include "strata/core/error.hpp"

#include "tensor/decompose_kernel.hpp"

namespace strata::tensor {

std::string to_string(const Dims3& d) {
  return std::to_string(d[0]) + "x" + std::to_string(d[1]) + "x" + std::to_string(d[2]);
}

void check_mode(int mode, const char* context) {
  if (mode < 1 || mode > 3) {
    throw Error(std::string(context) + ": mode must be 1, 2 or 3, got " + std::to_string(mode));
  }
}

namespace {

template <class T>
using MatrixMap = Eigen::Map<Matrix<T>>;
template <class T>
using ConstMatrixMap = Eigen::Map<const Matrix<T>>;

// Y = X ×n M for any matrix expression M (J x I_n). With first-index-fastest storage:
//   mode 1: X viewed as I1 x (I2 I3), Y = M X               (one GEMM)
//   mode 2: each frontal slice X(:,:,i3) is I1 x I2, Y = X M^T  (I3 GEMMs)
//   mode 3: X viewed as (I1 I2) x I3, Y = X M^T              (one GEMM)
template <class T, class Op>
BasicTensor3<T> multiply_mode(const BasicTensor3<T>& x, int mode, const Op& m, const char* context) {
  check_mode(mode, context);
  const Dims3& d = x.dims();
  if (m.cols() != x.dim(mode)) {
    throw Error(std::string(context) + ": matrix has " + std::to_string(m.cols()) + " columns but mode " +
                std::to_string(mode) + " of the " + to_string(d) + " tensor has extent " +
                std::to_string(x.dim(mode)));
  }
  Dims3 out_dims = d;
  out_dims[std::size_t(mode - 1)] = m.rows();
  BasicTensor3<T> y(out_dims);
  if (y.size() == 0) return y;
  if (mode == 1) {
    MatrixMap<T>(y.data(), m.rows(), d[1] * d[2]).noalias() = m * ConstMatrixMap<T>(x.data(), d[0], d[1] * d[2]);
  } else if (mode == 2) {
    for (std::int64_t i3 = 0; i3 < d[2]; ++i3) {
      ConstMatrixMap<T> slice(x.data() + i3 * d[0] * d[1], d[0], d[1]);
      MatrixMap<T>(y.data() + i3 * d[0] * m.rows(), d[0], m.rows()).noalias() = slice * m.transpose();
    }
  } else {
    MatrixMap<T>(y.data(), d[0] * d[1], m.rows()).noalias() =
        ConstMatrixMap<T>(x.data(), d[0] * d[1], d[2]) * m.transpose();
  }
  return y;
}

void check_factor_count(std::int64_t rows, std::int64_t extent, int mode, const char* context) {
  if (rows != extent) {
    throw Error(std::string(context) + ": factor U" + std::to_string(mode) + " has " + std::to_string(rows) +
                " rows, expected " + std::to_string(extent));
  }
}

}  // namespace

template <class T>
BasicTensor3<T> ttm(const BasicTensor3<T>& x, int mode, const Matrix<T>& u) {
  return multiply_mode(x, mode, u, "ttm");
}

template <class T>
BasicTensor3<T> ttm_transposed(const BasicTensor3<T>& x, int mode, const Matrix<T>& u) {
  return multiply_mode(x, mode, u.transpose(), "ttm_transposed");
}

// Each product shrinks the tensor, so applying the modes in order 1, 2, 3 keeps the
// intermediate results small when R_n < I_n.
template <class T>
BasicTensor3<T> project(const BasicTensor3<T>& a, const Factors<T>& u) {
  for (int n = 1; n <= 3; ++n) check_factor_count(u[std::size_t(n - 1)].rows(), a.dim(n), n, "project");
  return ttm_transposed(ttm_transposed(ttm_transposed(a, 1, u[0]), 2, u[1]), 3, u[2]);
}

template <class T>
BasicTensor3<T> reconstruct(const BasicTensor3<T>& core, const Factors<T>& u) {
  for (int n = 1; n <= 3; ++n) check_factor_count(u[std::size_t(n - 1)].cols(), core.dim(n), n, "reconstruct");
  return ttm(ttm(ttm(core, 1, u[0]), 2, u[1]), 3, u[2]);
}

template <class T>
Matrix<T> unfold(const BasicTensor3<T>& x, int mode) {
  check_mode(mode, "unfold");
  const Dims3& d = x.dims();
  Matrix<T> m(x.dim(mode), x.size() / std::max<std::int64_t>(x.dim(mode), 1));
  for (std::int64_t i3 = 0; i3 < d[2]; ++i3)
    for (std::int64_t i2 = 0; i2 < d[1]; ++i2)
      for (std::int64_t i1 = 0; i1 < d[0]; ++i1) {
        T v = x(i1, i2, i3);
        if (mode == 1) m(i1, i2 + d[1] * i3) = v;
        else if (mode == 2) m(i2, i1 + d[0] * i3) = v;
        else m(i3, i1 + d[0] * i2) = v;
      }
  return m;
}

template <class T>
Matrix<double> gram(const BasicTensor3<T>& x, int mode) {
  check_mode(mode, "gram");
  Matrix<double> g = Matrix<double>::Zero(x.dim(mode), x.dim(mode));
  if (x.size() == 0) return g;
  if constexpr (std::is_same_v<T, float>) {
    detail::mode_gram(detail::decompose_kernels(), x.dims(), nullptr, x.data(), mode, g.data());
  } else {
    detail::mode_gram(detail::decompose_kernels(), x.dims(), x.data(), nullptr, mode, g.data());
  }
  return g;
}

std::optional<Matrix<double>> integer_gram(std::span<const std::int32_t> values, const Dims3& dims, int mode) {
  check_mode(mode, "integer_gram");
  const std::int64_t count = dims[0] * dims[1] * dims[2];
  if (std::int64_t(values.size()) != count) throw Error("integer_gram: values do not match the extents");
  const std::int64_t rows = dims[std::size_t(mode - 1)], len = rows > 0 ? count / rows : 0;
  // v ^ (v >> 31) is |v| for v >= 0 and |v| - 1 below, so every |v| <= 2^bit_width(OR of them):
  // a bound from one vectorised pass.
  std::uint32_t bits = 0;
  for (std::int32_t v : values) bits |= std::uint32_t(v) ^ std::uint32_t(v >> 31);
  const std::int64_t bound = std::int64_t(1) << std::bit_width(bits);
  if (bound > 32768 || bound * bound * len >= (std::int64_t(1) << 31)) return std::nullopt;
  // The unfolding's rows made contiguous (the order inside a row is any, the same for all):
  // mode 3 is the tensor itself, mode 2 moves runs of I1, mode 1 transposes.
  thread_local std::vector<std::int16_t> unfolded;
  unfolded.resize(std::size_t(count));
  const std::int32_t* x = values.data();
  std::int16_t* out = unfolded.data();
  if (mode == 3) {
    for (std::int64_t at = 0; at < count; ++at) out[at] = std::int16_t(x[at]);
  } else if (mode == 2) {
    for (std::int64_t k = 0; k < dims[2]; ++k)
      for (std::int64_t j = 0; j < dims[1]; ++j) {
        const std::int32_t* run = x + dims[0] * (j + dims[1] * k);
        std::int16_t* to = out + j * len + k * dims[0];
        for (std::int64_t i = 0; i < dims[0]; ++i) to[i] = std::int16_t(run[i]);
      }
  } else {
    constexpr std::int64_t kTile = 16;  // columns per pass: contiguous writes, few open read lines
    for (std::int64_t c0 = 0; c0 < len; c0 += kTile) {
      const std::int64_t c1 = std::min(len, c0 + kTile);
      for (std::int64_t i = 0; i < dims[0]; ++i)
        for (std::int64_t c = c0; c < c1; ++c) out[i * len + c] = std::int16_t(x[c * dims[0] + i]);
    }
  }
  Matrix<double> g(rows, rows);
  if (count > 0) detail::decompose_kernels().gram_i16(unfolded.data(), rows, len, g.data());
  return g;
}

#define STRATA_TTM_INSTANTIATE(T)                                                       \
  template BasicTensor3<T> ttm(const BasicTensor3<T>&, int, const Matrix<T>&);            \
  template BasicTensor3<T> ttm_transposed(const BasicTensor3<T>&, int, const Matrix<T>&); \
  template BasicTensor3<T> project(const BasicTensor3<T>&, const Factors<T>&);            \
  template BasicTensor3<T> reconstruct(const BasicTensor3<T>&, const Factors<T>&);        \
  template Matrix<T> unfold(const BasicTensor3<T>&, int);                                 \
  template Matrix<double> gram(const BasicTensor3<T>&, int);

STRATA_TTM_INSTANTIATE(float)
STRATA_TTM_INSTANTIATE(double)
#undef STRATA_TTM_INSTANTIATE

}  // namespace strata::tensor

#include "strata/tensor/ttm.hpp"

#include <algorithm>
#include <string>
#include <type_traits>

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

#pragma once
/// @file
/// @brief Dense 3-way tensors (first index fastest, the layout of a brick) and the factor-matrix and
/// extent types the tensor code shares.
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "strata/core/error.hpp"

namespace strata::tensor {

/// @brief Extents of a 3-way tensor, (I1, I2, I3) in the paper's notation.
using Dims3 = std::array<std::int64_t, 3>;
/// @brief Per-mode ranks (R1, R2, R3), or the leading ranks (K1, K2, K3) used at decode.
using Ranks3 = std::array<int, 3>;

/// @brief Column-major (Eigen default) factor matrix: U^(n) is I_n x R_n.
template <class T>
using Matrix = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic>;

/// @brief The three factor matrices of a Tucker model: factors[n - 1] is U^(n).
template <class T>
using Factors = std::array<Matrix<T>, 3>;

/// @brief A dense 3-way tensor with contiguous storage, first index fastest: element (i1, i2, i3)
/// lives at i1 + I1 * (i2 + I2 * i3). This is the layout of a brick of an x-fastest volume,
/// so a brick converts to a tensor without reordering. Modes are numbered 1..3 as in the paper.
template <class T>
class BasicTensor3 {
 public:
  BasicTensor3() = default;
  BasicTensor3(std::int64_t i1, std::int64_t i2, std::int64_t i3) : dims_{i1, i2, i3} {
    if (i1 < 0 || i2 < 0 || i3 < 0) throw Error("Tensor3: negative dimension");
    values_.assign(std::size_t(i1 * i2 * i3), T(0));
  }
  explicit BasicTensor3(const Dims3& d) : BasicTensor3(d[0], d[1], d[2]) {}

  const Dims3& dims() const { return dims_; }
  std::int64_t dim(int mode) const { return dims_[std::size_t(mode - 1)]; }  // mode in 1..3
  std::int64_t size() const { return dims_[0] * dims_[1] * dims_[2]; }

  std::size_t index(std::int64_t i1, std::int64_t i2, std::int64_t i3) const {
    return std::size_t(i1 + dims_[0] * (i2 + dims_[1] * i3));
  }
  T& operator()(std::int64_t i1, std::int64_t i2, std::int64_t i3) { return values_[index(i1, i2, i3)]; }
  const T& operator()(std::int64_t i1, std::int64_t i2, std::int64_t i3) const {
    return values_[index(i1, i2, i3)];
  }

  T* data() { return values_.data(); }
  const T* data() const { return values_.data(); }
  std::span<T> values() { return values_; }
  std::span<const T> values() const { return values_; }

  /// @brief Frobenius norm, accumulated in double whatever T is.
  double norm() const {
    double sum = 0;
    for (T v : values_) sum += double(v) * double(v);
    return std::sqrt(sum);
  }

  /// @brief Element-wise conversion (e.g. float storage to double for a decomposition).
  template <class U>
  BasicTensor3<U> cast() const {
    BasicTensor3<U> out(dims_);
    for (std::size_t i = 0; i < values_.size(); ++i) out.data()[i] = U(values_[i]);
    return out;
  }

  bool operator==(const BasicTensor3&) const = default;

 private:
  Dims3 dims_{0, 0, 0};
  std::vector<T> values_;
};

using Tensor3 = BasicTensor3<float>;
using Tensor3d = BasicTensor3<double>;

std::string to_string(const Dims3& d);  // "I1xI2xI3"

}  // namespace strata::tensor

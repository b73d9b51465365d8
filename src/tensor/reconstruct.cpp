#include "strata/tensor/reconstruct.hpp"

#include <algorithm>
#include <cstdlib>
#include <new>
#include <string>

#include "strata/core/isa.hpp"
#include "tensor/reconstruct_kernel.hpp"

namespace strata::tensor {

TuckerView view_of(const Tucker& model) {
  TuckerView v;
  v.core = model.core.data();
  v.ranks = model.ranks();
  for (std::size_t n = 0; n < 3; ++n) {
    v.factors[n] = model.factors[n].data();
    if (model.factors[n].cols() != v.ranks[n]) {
      throw Error("view_of: factor U" + std::to_string(n + 1) + " has " + std::to_string(model.factors[n].cols()) +
                  " columns but the core has rank " + std::to_string(v.ranks[n]));
    }
  }
  v.dims = model.dims();
  return v;
}

namespace {

using KernelFn = void (*)(const detail::ReconstructArgs&);
using ProjectFn = void (*)(const detail::ProjectArgs&);

// The widest variant active_isa() allows.
KernelFn kernel_for(Isa isa) {
  switch (isa) {
    case Isa::avx512: return detail::reconstruct_avx512;
    case Isa::avx2: return detail::reconstruct_avx2;
    default: return detail::reconstruct_generic;
  }
}

ProjectFn project_kernel_for(Isa isa) {
  switch (isa) {
    case Isa::avx512: return detail::project_avx512;
    case Isa::avx2: return detail::project_avx2;
    default: return detail::project_generic;
  }
}

// Rows per vector of the widest kernel: padding the first product's rows to it fills every
// vector of every variant.
constexpr std::int64_t kRowPadding = 16;

// A float buffer aligned to a cache line (also the AVX-512 vector size), grown on demand and
// never shrunk, so repeated reconstructions of same-sized bricks do not allocate.
class AlignedFloats {
 public:
  AlignedFloats() = default;
  AlignedFloats(const AlignedFloats&) = delete;
  AlignedFloats& operator=(const AlignedFloats&) = delete;
  ~AlignedFloats() { std::free(data_); }

  float* reserve(std::size_t count) {
    if (count > capacity_) {
      const std::size_t bytes = (count * sizeof(float) + kAlign - 1) / kAlign * kAlign;
      void* p = std::aligned_alloc(kAlign, bytes);
      if (!p) throw std::bad_alloc();
      std::free(data_);
      data_ = static_cast<float*>(p);
      capacity_ = bytes / sizeof(float);
    }
    return data_;
  }

 private:
  static constexpr std::size_t kAlign = 64;
  float* data_ = nullptr;
  std::size_t capacity_ = 0;
};

void check_view(const TuckerView& m, const Ranks3& k, std::size_t out_size) {
  if (!m.core || !m.factors[0] || !m.factors[1] || !m.factors[2]) throw Error("reconstruct: null model pointer");
  check_ranks(m.dims, m.ranks, "reconstruct (model ranks)");
  for (std::size_t n = 0; n < 3; ++n) {
    if (k[n] < 1 || k[n] > m.ranks[n]) {
      throw Error("reconstruct: leading rank K" + std::to_string(n + 1) + " = " + std::to_string(k[n]) +
                  " must be in [1, " + std::to_string(m.ranks[n]) + "]");
    }
  }
  if (std::int64_t(out_size) != m.dims[0] * m.dims[1] * m.dims[2]) {
    throw Error("reconstruct: output buffer holds " + std::to_string(out_size) + " floats, the " +
                to_string(m.dims) + " brick needs " + std::to_string(m.dims[0] * m.dims[1] * m.dims[2]));
  }
}

// Copies the leading k1 x k2 x k3 block of an r1 x r2 x r3 core into contiguous storage, so the
// first product reads it as a plain k1 x (k2 k3) matrix.
void copy_leading_core(const float* core, const Ranks3& r, const Ranks3& k, float* dst) {
  for (int r3 = 0; r3 < k[2]; ++r3)
    for (int r2 = 0; r2 < k[1]; ++r2) {
      const float* src = core + std::int64_t(r[0]) * (r2 + std::int64_t(r[1]) * r3);
      for (int r1 = 0; r1 < k[0]; ++r1) *dst++ = src[r1];
    }
}

}  // namespace

struct BrickReconstructor::Scratch {
  AlignedFloats core, t1, t2;
};

BrickReconstructor::BrickReconstructor() : scratch_(std::make_unique<Scratch>()) {}
BrickReconstructor::~BrickReconstructor() = default;
BrickReconstructor::BrickReconstructor(BrickReconstructor&&) noexcept = default;
BrickReconstructor& BrickReconstructor::operator=(BrickReconstructor&&) noexcept = default;

void BrickReconstructor::reconstruct(const TuckerView& model, const Ranks3& k, std::span<float> out) {
  check_view(model, k, out.size());
  const Dims3& d = model.dims;
  detail::ReconstructArgs a;
  a.i1 = d[0], a.i2 = d[1], a.i3 = d[2];
  a.k1 = k[0], a.k2 = k[1], a.k3 = k[2];
  // Truncating mode 1 only shortens each core row and keeps its stride, but the kernel wants
  // the sub-core contiguous; copying K1 K2 K3 floats is negligible next to the products.
  if (k == model.ranks) {
    a.core = model.core;
  } else {
    float* sub = scratch_->core.reserve(std::size_t(k[0]) * k[1] * k[2]);
    copy_leading_core(model.core, model.ranks, k, sub);
    a.core = sub;
  }
  a.u1 = model.factors[0], a.u2 = model.factors[1], a.u3 = model.factors[2];
  a.t1 = scratch_->t1.reserve(std::size_t(d[0]) * k[1] * k[2]);
  a.t2 = scratch_->t2.reserve(std::size_t(d[0] * d[1]) * k[2]);
  a.out = out.data();
  kernel_for(active_isa())(a);
}

void BrickReconstructor::reconstruct(const TuckerView& model, std::span<float> out) {
  reconstruct(model, model.ranks, out);
}

Tensor3 BrickReconstructor::reconstruct(const Tucker& model, const Ranks3& leading_ranks) {
  Tensor3 out(model.dims());
  reconstruct(view_of(model), leading_ranks, out.values());
  return out;
}

struct BrickProjector::Scratch {
  AlignedFloats ut1, t1, t2, out;
};

BrickProjector::BrickProjector() : scratch_(std::make_unique<Scratch>()) {}
BrickProjector::~BrickProjector() = default;
BrickProjector::BrickProjector(BrickProjector&&) noexcept = default;
BrickProjector& BrickProjector::operator=(BrickProjector&&) noexcept = default;

void BrickProjector::project(std::span<const float> x, const Dims3& dims, const Dims3& lo, const TuckerView& bases,
                             Tensor3& core) {
  const Dims3& e = bases.dims;
  const Ranks3& r = bases.ranks;
  if (std::int64_t(x.size()) != dims[0] * dims[1] * dims[2])
    throw Error("project: the brick holds " + std::to_string(x.size()) + " floats, " + to_string(dims) + " expected");
  for (std::size_t n = 0; n < 3; ++n) {
    if (!bases.factors[n]) throw Error("project: null factor pointer");
    if (lo[n] < 0 || e[n] < 1 || lo[n] + e[n] > dims[n])
      throw Error("project: the box " + to_string(e) + " at " + to_string(lo) + " leaves the " + to_string(dims) + " brick");
    if (r[n] < 1) throw Error("project: ranks must be positive, got " + to_string({r[0], r[1], r[2]}));
  }
  detail::ProjectArgs a;
  a.e1 = e[0], a.e2 = e[1], a.e3 = e[2];
  a.r2 = r[1], a.r3 = r[2];
  a.mp = (r[0] + kRowPadding - 1) / kRowPadding * kRowPadding;
  a.x = x.data() + lo[0] + dims[0] * (lo[1] + dims[1] * lo[2]);
  a.x_j = dims[0], a.x_k = dims[0] * dims[1];
  float* ut1 = scratch_->ut1.reserve(std::size_t(a.mp * e[0]));
  for (std::int64_t s = 0; s < e[0]; ++s)
    for (std::int64_t c = 0; c < a.mp; ++c) ut1[c + a.mp * s] = c < r[0] ? bases.factors[0][s + e[0] * c] : 0.0f;
  a.ut1 = ut1;
  a.u2 = bases.factors[1], a.u3 = bases.factors[2];
  a.t1 = scratch_->t1.reserve(std::size_t(a.mp * e[1] * e[2]));
  a.t2 = scratch_->t2.reserve(std::size_t(a.mp * r[1] * e[2]));
  a.out = scratch_->out.reserve(std::size_t(a.mp * r[1] * r[2]));
  project_kernel_for(active_isa())(a);
  if (core.dims() != Dims3{r[0], r[1], r[2]}) core = Tensor3(r[0], r[1], r[2]);
  float* dst = core.data();
  for (std::int64_t k = 0; k < r[2]; ++k)
    for (std::int64_t j = 0; j < r[1]; ++j) {
      const float* src = a.out + a.mp * (j + r[1] * k);
      dst = std::copy(src, src + r[0], dst);
    }
}

}  // namespace strata::tensor

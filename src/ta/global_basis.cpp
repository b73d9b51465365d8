#include "strata/ta/global_basis.hpp"

#include <algorithm>
#include <cstring>
#include <cmath>
#include <numbers>
#include <random>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "strata/core/error.hpp"
#include "strata/core/stopwatch.hpp"
#include "strata/core/threads.hpp"
#include "strata/tensor/ttm.hpp"

namespace strata::ta {

namespace {

using tensor::Matrix;
using MatrixF = Eigen::MatrixXf;
using MatrixD = Eigen::MatrixXd;
using SliceMap = Eigen::Map<const MatrixF>;  // one z slice, I1 × I2, x fastest (column-major)

void check(const GlobalFitOptions& o) {
  if (o.rank < 1) throw ParameterError("GlobalFitOptions::rank", fmt::format("must be at least 1, got {}", o.rank));
  if (o.max_sweeps < 1)
    throw ParameterError("GlobalFitOptions::max_sweeps", fmt::format("must be at least 1, got {}", o.max_sweeps));
  if (!(o.tolerance >= 0)) throw ParameterError("GlobalFitOptions::tolerance", fmt::format("must be >= 0, got {}", o.tolerance));
}

// Column j of the orthonormal DCT-II basis of length n: the j-th smoothest cosine.
MatrixD dct_basis(std::int64_t n, int r) {
  MatrixD u(n, r);
  for (int j = 0; j < r; ++j) {
    const double scale = std::sqrt((j == 0 ? 1.0 : 2.0) / double(n));
    for (std::int64_t i = 0; i < n; ++i) u(i, j) = scale * std::cos(std::numbers::pi * (double(i) + 0.5) * j / double(n));
  }
  return u;
}

MatrixD random_basis(std::int64_t n, int r, std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  MatrixD g(n, r);
  for (std::int64_t i = 0; i < g.size(); ++i) g.data()[i] = normal(rng);
  Eigen::HouseholderQR<MatrixD> qr(g);
  return qr.householderQ() * MatrixD::Identity(n, r);
}

// A column's sign is arbitrary; fix it so its largest-magnitude entry is positive (the same
// rule as tensor::hosvd), so fits and bases are reproducible.
void fix_signs(MatrixD& u) {
  for (Eigen::Index j = 0; j < u.cols(); ++j) {
    Eigen::Index at = 0;
    u.col(j).cwiseAbs().maxCoeff(&at);
    if (u(at, j) < 0) u.col(j) = -u.col(j);
  }
}

// The r leading left singular vectors of the unfolded HOOI product Y (I × C), largest first,
// from `yt` = Yᵀ (C × I). Neither an I × I Gram matrix (it grows with the square of a volume
// axis: 128 MiB for 4096 slices) nor a second I × C copy for an SVD's workspace is formed: the
// eigenvectors V of the C × C matrix YᵀY give Y V, whose columns are the wanted vectors scaled by
// the singular values; a QR factorization normalizes them (and orthogonalizes what rounding or
// a zero singular value left). With fewer than r columns, DCT vectors complete the basis.
MatrixD leading_left_singular_vectors(const MatrixD& yt, int r) {
  const Eigen::Index c = yt.rows(), n = yt.cols();
  Eigen::SelfAdjointEigenSolver<MatrixD> eig(yt * yt.transpose());
  if (eig.info() != Eigen::Success) throw Error("global basis: the eigen-decomposition of a Gram matrix failed");
  const Eigen::Index kept = std::min<Eigen::Index>(r, c);
  MatrixD columns(n, r);
  for (Eigen::Index j = 0; j < kept; ++j) columns.col(j) = yt.transpose() * eig.eigenvectors().col(c - 1 - j);  // ascending
  if (kept < r) columns.rightCols(r - kept) = dct_basis(n, int(r)).rightCols(r - kept);
  const Eigen::HouseholderQR<MatrixD> qr(columns);
  MatrixD u = qr.householderQ() * MatrixD::Identity(n, r);
  // QR may flip a column; align each with its source before the sign convention.
  for (Eigen::Index j = 0; j < r; ++j)
    if (u.col(j).dot(columns.col(j)) < 0) u.col(j) = -u.col(j);
  fix_signs(u);
  return u;
}

// Streams the volume as float slabs of whole slices; visit(z0, slices, data) sees
// `slices` slices from z0, non-finite samples as 0.
class SlabReader {
 public:
  SlabReader(io::VolumeSource& source, std::uint64_t slab_bytes) : source_(source) {
    const Extent d = source.info().dims;
    const std::uint64_t slice = std::uint64_t(d.x) * std::uint64_t(d.y) * sizeof(float);
    slices_ = std::int64_t(std::clamp<std::uint64_t>(slab_bytes / std::max<std::uint64_t>(slice, 1), 1, std::uint64_t(d.z)));
  }
  template <class Visit>
  void pass(ProgressSink& progress, double& sum_squares, Visit&& visit) {
    const Extent d = source_.info().dims;
    sum_squares = 0;
    for (std::int64_t z0 = 0; z0 < d.z; z0 += slices_) {
      const std::int64_t z1 = std::min(d.z, z0 + slices_);
      Volume slab = source_.read_slab(z0, z1);
      if (slab.dtype() != DType::f32) slab = slab.converted(DType::f32);
      auto s = slab.samples<float>();
      double squares = 0;
      for (float& v : s) {
        if (!std::isfinite(v)) v = 0;
        squares += double(v) * double(v);
      }
      sum_squares += squares;
      visit(z0, z1 - z0, s.data());
      progress.advance(std::uint64_t(z1 - z0));
    }
  }

 private:
  io::VolumeSource& source_;
  std::int64_t slices_ = 1;
};

// Per-slice products of one pass, run in parallel over the slices of a slab: column k of the
// result is slice z0 + k's product, unfolded.
template <class SliceProduct>
MatrixF per_slice(std::int64_t slices, std::int64_t rows, const float* data, std::int64_t slice_size,
                  const SliceProduct& product) {
  MatrixF out(rows, slices);
#pragma omp parallel for schedule(static) num_threads(thread_count()) if (slices > 1)
  for (std::int64_t k = 0; k < slices; ++k) out.col(k) = product(data + k * slice_size);
  return out;
}

// The three HOOI updates. Shapes: U1 I1 × R1, U2 I2 × R2, U3 I3 × R3; a slice M is I1 × I2.
struct Sweep {
  SlabReader& reader;
  ProgressSink& progress;
  Extent dims;
  std::int64_t slice_size() const { return dims.x * dims.y; }

  // Each mode returns its unfolded product transposed (R_a R_b × I_n): the form the decomposition
  // takes and, for mode 3, the one the slabs fill, so the largest of them is never copied.
  // Y1 = A ×2 U2ᵀ ×3 U3ᵀ (I1 × R2R3): per slice M U2, combined over z by U3.
  MatrixD mode1(const MatrixD& u2, const MatrixD& u3, double& norm2) {
    const MatrixF u2f = u2.cast<float>();
    const Eigen::Index r2 = u2.cols(), r3 = u3.cols();
    MatrixD y(dims.x * r2, r3);
    y.setZero();
    reader.pass(progress, norm2, [&](std::int64_t z0, std::int64_t n, const float* data) {
      const MatrixF t = per_slice(n, dims.x * r2, data, slice_size(), [&](const float* s) {
        const MatrixF m = SliceMap(s, dims.x, dims.y) * u2f;
        return Eigen::Map<const Eigen::VectorXf>(m.data(), m.size()).eval();
      });
      y.noalias() += t.cast<double>() * u3.middleRows(z0, n);
    });
    return Eigen::Map<const MatrixD>(y.data(), dims.x, r2 * r3).transpose();  // Y1 unfolded along mode 1, transposed
  }

  // Y2 = A ×1 U1ᵀ ×3 U3ᵀ (R1 × I2 × R3); returns its mode-2 unfolding (I2 × R1R3), transposed.
  MatrixD mode2(const MatrixD& u1, const MatrixD& u3, double& norm2) {
    const MatrixF u1t = u1.transpose().cast<float>();
    const Eigen::Index r1 = u1.cols(), r3 = u3.cols();
    MatrixD y(r1 * dims.y, r3);
    y.setZero();
    reader.pass(progress, norm2, [&](std::int64_t z0, std::int64_t n, const float* data) {
      const MatrixF w = per_slice(n, r1 * dims.y, data, slice_size(), [&](const float* s) {
        const MatrixF m = u1t * SliceMap(s, dims.x, dims.y);
        return Eigen::Map<const Eigen::VectorXf>(m.data(), m.size()).eval();
      });
      y.noalias() += w.cast<double>() * u3.middleRows(z0, n);
    });
    MatrixD unfolded_t(r1 * r3, dims.y);
    for (Eigen::Index k = 0; k < r3; ++k) unfolded_t.middleRows(k * r1, r1) = Eigen::Map<const MatrixD>(y.col(k).data(), r1, dims.y);
    return unfolded_t;
  }

  // Y3 = A ×1 U1ᵀ ×2 U2ᵀ (R1R2 × I3, one column per slice): the mode-3 unfolding (I3 × R1R2),
  // transposed.
  MatrixD mode3(const MatrixD& u1, const MatrixD& u2, double& norm2) {
    const MatrixF u1t = u1.transpose().cast<float>(), u2f = u2.cast<float>();
    MatrixD y(u1.cols() * u2.cols(), dims.z);
    reader.pass(progress, norm2, [&](std::int64_t z0, std::int64_t n, const float* data) {
      const MatrixF v = per_slice(n, y.rows(), data, slice_size(), [&](const float* s) {
        const MatrixF m = (u1t * SliceMap(s, dims.x, dims.y)) * u2f;
        return Eigen::Map<const Eigen::VectorXf>(m.data(), m.size()).eval();
      });
      y.middleCols(z0, n) = v.cast<double>();
    });
    return y;
  }
};

}  // namespace

GlobalFit fit_global_factors(io::VolumeSource& source, const GlobalFitOptions& options, ProgressSink& progress) {
  check(options);
  const auto start = SteadyClock::now();
  const Extent d = source.info().dims;
  const std::array<std::int64_t, 3> extent{d.x, d.y, d.z};
  std::array<int, 3> rank{};
  for (int n = 0; n < 3; ++n) rank[std::size_t(n)] = int(std::min<std::int64_t>(options.rank, extent[std::size_t(n)]));

  GlobalFit fit;
  std::mt19937_64 rng(options.seed);
  for (int n = 0; n < 3; ++n) {
    const auto i = std::size_t(n);
    fit.factors[i] = options.init == GlobalInit::dct ? dct_basis(extent[i], rank[i]) : random_basis(extent[i], rank[i], rng);
  }
  SlabReader reader(source, options.slab_bytes);
  Sweep sweep{reader, progress, d};
  progress.begin("global basis", std::uint64_t(d.z) * 3u * std::uint64_t(options.max_sweeps), "slices");
  auto& [u1, u2, u3] = fit.factors;
  for (int s = 0; s < options.max_sweeps; ++s) {
    double norm2 = 0;
    const MatrixD y1 = sweep.mode1(u2, u3, norm2);
    u1 = leading_left_singular_vectors(y1, rank[0]);
    const MatrixD y2 = sweep.mode2(u1, u3, norm2);
    u2 = leading_left_singular_vectors(y2, rank[1]);
    const MatrixD y3 = sweep.mode3(u1, u2, norm2);
    u3 = leading_left_singular_vectors(y3, rank[2]);
    fit.passes += 3;
    // With orthonormal factors ‖A − Ã‖² = ‖A‖² − ‖core‖², and the core is Y3 ×3 U3ᵀ.
    const double core2 = (y3 * u3).squaredNorm();
    const double error = std::sqrt(std::max(0.0, norm2 - core2));
    fit.fit_per_sweep.push_back(norm2 > 0 ? 1.0 - error / std::sqrt(norm2) : 1.0);
    if (s > 0 && fit.fit_per_sweep[std::size_t(s)] - fit.fit_per_sweep[std::size_t(s - 1)] < options.tolerance) break;
  }
  progress.end();
  fit.seconds = seconds_since(start);
  return fit;
}

Matrix<double> halve_rows(const Matrix<double>& factor) {
  const Eigen::Index rows = (factor.rows() + 1) / 2;
  Matrix<double> half(rows, factor.cols());
  for (Eigen::Index i = 0; i < rows; ++i) {
    const Eigen::Index a = 2 * i, b = std::min(2 * i + 1, factor.rows() - 1);
    half.row(i) = 0.5 * (factor.row(a) + factor.row(b));
  }
  return half;
}

std::vector<Matrix<double>> mipmap_factor(const Matrix<double>& factor, int levels) {
  if (levels < 1) throw ParameterError("levels", fmt::format("must be at least 1, got {}", levels));
  std::vector<Matrix<double>> mip{factor};
  for (int l = 1; l < levels; ++l) mip.push_back(halve_rows(mip.back()));
  return mip;
}

Matrix<double> row_block_basis(const Matrix<double>& level_factor, std::int64_t first_row, int rows) {
  if (rows < 1) throw ParameterError("rows", fmt::format("must be at least 1, got {}", rows));
  const Eigen::Index last = level_factor.rows() - 1;
  MatrixD block(rows, level_factor.cols());
  for (int j = 0; j < rows; ++j) block.row(j) = level_factor.row(std::clamp<Eigen::Index>(first_row + j, 0, last));
  Eigen::BDCSVD<MatrixD> svd(block, Eigen::ComputeThinU);
  MatrixD u = svd.matrixU();  // singular values in decreasing order
  fix_signs(u);
  return u;
}

GlobalBases::GlobalBases(const tensor::Factors<double>& factors, const OctreeGeometry& geometry) {
  const BrickLayout& layout = geometry.layout();
  for (int n = 0; n < 3; ++n) ranks_[std::size_t(n)] = int(std::min<Eigen::Index>(factors[std::size_t(n)].cols(), layout.brick));
  std::array<std::vector<Matrix<double>>, 3> mip;
  for (int n = 0; n < 3; ++n) mip[std::size_t(n)] = mipmap_factor(factors[std::size_t(n)], geometry.level_count());
  bases_.resize(std::size_t(geometry.level_count()));
  for (int l = 0; l < geometry.level_count(); ++l) {
    const Extent& grid = geometry.level(l).bricks;
    const std::array<std::int64_t, 3> count{grid.x, grid.y, grid.z};
    for (int n = 0; n < 3; ++n) {
      auto& list = bases_[std::size_t(l)][std::size_t(n)];
      for (std::int64_t b = 0; b < count[std::size_t(n)]; ++b) {
        const std::int64_t first = b * layout.core() - layout.overlap;  // the brick's sample rows
        list.push_back(row_block_basis(mip[std::size_t(n)][std::size_t(l)], first, layout.brick).cast<float>());
      }
    }
  }
}

const Matrix<float>& GlobalBases::basis(int level, int mode, std::int64_t index) const {
  if (level < 0 || level >= int(bases_.size()) || mode < 1 || mode > 3)
    throw ParameterError("level", fmt::format("level {} mode {} has no bases ({} levels)", level, mode, bases_.size()));
  const auto& list = bases_[std::size_t(level)][std::size_t(mode - 1)];
  if (index < 0 || index >= std::int64_t(list.size()))
    throw ParameterError("index", fmt::format("brick index {} along mode {} is not in 0..{}", index, mode, list.size() - 1));
  return list[std::size_t(index)];
}

std::array<const Matrix<float>*, 3> GlobalBases::brick_bases(int level, std::int64_t bx, std::int64_t by,
                                                             std::int64_t bz) const {
  return {&basis(level, 1, bx), &basis(level, 2, by), &basis(level, 3, bz)};
}

std::vector<std::byte> GlobalBases::serialize() const {
  std::vector<std::byte> out;
  for (const auto& level : bases_)
    for (const auto& mode : level)
      for (const Matrix<float>& q : mode) {
        const auto* bytes = reinterpret_cast<const std::byte*>(q.data());
        out.insert(out.end(), bytes, bytes + q.size() * sizeof(float));
      }
  return out;
}

GlobalBases GlobalBases::deserialize(std::span<const std::byte> bytes, const OctreeGeometry& geometry,
                                     const std::array<int, 3>& ranks, const std::string& file) {
  const int b = geometry.layout().brick;
  std::uint64_t floats = 0;
  for (int l = 0; l < geometry.level_count(); ++l) {
    const Extent& grid = geometry.level(l).bricks;
    floats += std::uint64_t(b) * std::uint64_t(grid.x * ranks[0] + grid.y * ranks[1] + grid.z * ranks[2]);
  }
  if (bytes.size() != floats * sizeof(float))
    throw FormatError(file, "section global_bases",
                      fmt::format("{} bytes, expected {} ({} floats: one {}-row basis of ranks {},{},{} per brick "
                                  "position, mode and level)",
                                  bytes.size(), floats * sizeof(float), floats, b, ranks[0], ranks[1], ranks[2]));
  GlobalBases g;
  g.ranks_ = ranks;
  g.bases_.resize(std::size_t(geometry.level_count()));
  std::size_t at = 0;
  for (int l = 0; l < geometry.level_count(); ++l) {
    const Extent& grid = geometry.level(l).bricks;
    const std::array<std::int64_t, 3> count{grid.x, grid.y, grid.z};
    for (int n = 0; n < 3; ++n)
      for (std::int64_t i = 0; i < count[std::size_t(n)]; ++i) {
        Matrix<float> q(b, ranks[std::size_t(n)]);
        std::memcpy(q.data(), bytes.data() + at, std::size_t(q.size()) * sizeof(float));
        at += std::size_t(q.size()) * sizeof(float);
        if (!q.allFinite())
          throw FormatError(file, "section global_bases",
                            fmt::format("the basis of level {} mode {} brick index {} holds a non-finite value", l, n + 1, i));
        g.bases_[std::size_t(l)][std::size_t(n)].push_back(std::move(q));
      }
  }
  return g;
}

tensor::Tensor3 project_brick(const tensor::Tensor3& samples, const std::array<const Matrix<float>*, 3>& bases) {
  return tensor::project(samples, tensor::Factors<float>{*bases[0], *bases[1], *bases[2]});
}

std::vector<double> rank_ladder_rmse(const tensor::Tensor3& reference, const tensor::Tensor3& core,
                                     const std::array<const Matrix<float>*, 3>& bases, const Box& region,
                                     const std::vector<int>& ladder, double resolution_variance) {
  if (region.empty()) throw ParameterError("region", "is empty");
  std::vector<double> rmse;
  for (int k : ladder) {
    if (k < 1) throw ParameterError("ladder", fmt::format("ranks must be at least 1, got {}", k));
    tensor::Ranks3 r{};
    for (int n = 0; n < 3; ++n) r[std::size_t(n)] = int(std::min<std::int64_t>(k, core.dim(n + 1)));
    tensor::Tensor3 leading(r[0], r[1], r[2]);
    for (int c = 0; c < r[2]; ++c)
      for (int b = 0; b < r[1]; ++b)
        for (int a = 0; a < r[0]; ++a) leading(a, b, c) = core(a, b, c);
    tensor::Factors<float> u;
    for (int n = 0; n < 3; ++n) u[std::size_t(n)] = bases[std::size_t(n)]->leftCols(r[std::size_t(n)]);
    const tensor::Tensor3 rebuilt = tensor::reconstruct(leading, u);
    double sum = 0;
    for (std::int64_t z = region.lo.z; z < region.hi.z; ++z)
      for (std::int64_t y = region.lo.y; y < region.hi.y; ++y)
        for (std::int64_t x = region.lo.x; x < region.hi.x; ++x) {
          const double d = double(rebuilt(x, y, z)) - double(reference(x, y, z));
          sum += d * d;
        }
    rmse.push_back(std::sqrt(sum / double(region.size().voxel_count()) + resolution_variance));
  }
  // Conservative: no entry below that of a higher rank (see the header).
  for (std::size_t i = rmse.size(); i-- > 1;) rmse[i - 1] = std::max(rmse[i - 1], rmse[i]);
  return rmse;
}

}  // namespace strata::ta

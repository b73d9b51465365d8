#pragma once
/// @file
/// @brief The in-memory volume (Volume: dims, sample type, spacing and x-fastest samples), its typed
/// views, and VolumeInfo, what a file header says about a volume.
#include <cstddef>
#include <cstring>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "strata/core/dtype.hpp"
#include "strata/core/extent.hpp"
#include "strata/core/geometry.hpp"

namespace strata {

/// @brief Physical voxel size (e.g. millimetres), as read from the file headers.
struct Spacing {
  double x = 1.0, y = 1.0, z = 1.0;
  bool operator==(const Spacing&) const = default;
};

/// @brief What a file header says about a volume, without its samples.
struct VolumeInfo {
  Extent dims;
  DType dtype = DType::u8;
  Spacing spacing;
  /// 3D volumes of `dims` the file holds (NIfTI dim[4..7]: time points, components); a source
  /// reads one of them (io::ReadOptions::volume).
  std::int64_t volumes = 1;
  /// Origin, direction cosines, world space and unit (identity and 0 when the file has none).
  Geometry geometry{};

  /// dims.x * dims.y * sample size and dims.x * dims.y * dims.z * sample size, or std::nullopt
  /// when a dimension is negative or the product does not fit in a signed 64-bit count (the
  /// range of file offsets). Readers check these before trusting dims from a header.
  std::optional<std::uint64_t> checked_bytes_per_slice() const;
  std::optional<std::uint64_t> checked_byte_size() const;
  /// The same; throw Error naming the dims and dtype when the size overflows.
  std::size_t bytes_per_slice() const;
  std::size_t byte_size() const;
};

/// @brief Typed, non-owning view of x-fastest voxels.
template <class T>
struct VolumeView {
  T* data = nullptr;
  Extent dims;

  std::size_t index(std::int64_t x, std::int64_t y, std::int64_t z) const {
    return std::size_t((z * dims.y + y) * dims.x + x);
  }
  T& operator()(std::int64_t x, std::int64_t y, std::int64_t z) const { return data[index(x, y, z)]; }
  std::span<T> span() const { return {data, std::size_t(dims.voxel_count())}; }
};

/// @brief An in-memory volume (or a slab/box of one), x fastest. Large inputs are processed as
/// slabs through io::VolumeSource instead of one Volume.
class Volume {
 public:
  Volume() = default;
  Volume(Extent dims, DType dtype, Spacing spacing = {});
  explicit Volume(const VolumeInfo& info) : Volume(info.dims, info.dtype, info.spacing) { info_.geometry = info.geometry; }

  const Extent& dims() const { return info_.dims; }
  DType dtype() const { return info_.dtype; }
  const Spacing& spacing() const { return info_.spacing; }
  void set_spacing(const Spacing& s) { info_.spacing = s; }
  void set_geometry(Geometry g) { info_.geometry = std::move(g); }
  const VolumeInfo& info() const { return info_; }
  std::int64_t voxel_count() const { return info_.dims.voxel_count(); }
  std::size_t byte_size() const { return bytes_.size(); }

  std::byte* bytes() { return bytes_.data(); }
  const std::byte* bytes() const { return bytes_.data(); }

  /// @brief Typed access; throws Error if T does not match dtype().
  template <class T> VolumeView<T> view() {
    check_type(dtype_of<T>());
    return {reinterpret_cast<T*>(bytes_.data()), info_.dims};
  }
  template <class T> VolumeView<const T> view() const {
    check_type(dtype_of<T>());
    return {reinterpret_cast<const T*>(bytes_.data()), info_.dims};
  }
  template <class T> std::span<T> samples() { return view<T>().span(); }
  template <class T> std::span<const T> samples() const { return view<T>().span(); }

  /// @brief Any-type sample access, for tests and tools (slow path; kernels use view<T>()).
  double value(std::int64_t x, std::int64_t y, std::int64_t z) const;
  void set_value(std::int64_t x, std::int64_t y, std::int64_t z, double v);

  /// @brief Copies of a box (must lie inside) as a new Volume with the same dtype and spacing.
  Volume crop(const Box& box) const;
  /// @brief Converts samples to another dtype (values are rounded and clamped for integer targets).
  Volume converted(DType to) const;

  bool operator==(const Volume& o) const { return info_.dims == o.info_.dims && info_.dtype == o.info_.dtype && bytes_ == o.bytes_; }

 private:
  void check_type(DType requested) const;
  VolumeInfo info_;
  std::vector<std::byte> bytes_;
};

}  // namespace strata

#pragma once
// Label values of a segmentation (any integer dtype) <-> dense source ids 0..N-1.
// Ids follow ascending label value, so the map is canonical for a set of values, and level 0
// of the Mixture Graph decodes back to the original samples bit for bit.
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "strata/core/volume.hpp"

namespace strata::mixture {

class LabelMap {
 public:
  LabelMap() = default;
  // `values` must be strictly increasing and representable in `dtype` (an integer dtype).
  LabelMap(DType dtype, std::vector<std::int64_t> values);

  DType dtype() const { return dtype_; }
  std::uint32_t size() const { return std::uint32_t(values_.size()); }
  std::span<const std::int64_t> values() const { return values_; }
  std::int64_t value(std::uint32_t id) const { return values_.at(id); }
  std::optional<std::uint32_t> id_of(std::int64_t value) const;

  // Volume of the original dtype from per-voxel source ids (x fastest). Throws Error when an
  // id is out of range or ids.size() != dims.voxel_count().
  Volume decode(std::span<const std::uint32_t> ids, Extent dims, Spacing spacing = {}) const;

  bool operator==(const LabelMap&) const = default;

 private:
  DType dtype_ = DType::u32;
  std::vector<std::int64_t> values_;
};

struct SourceIds {
  LabelMap map;
  Extent dims;
  Spacing spacing;
  std::vector<std::uint32_t> ids;  // dense id per voxel, x fastest
};

/// @brief Throws Error naming `file` unless `dtype` is an integer type (u8, i8, u16, i16, u32 or
/// i32): only integer samples are labels.
void require_label_dtype(const std::string& file, DType dtype);

/// @brief The distinct values of an integer label volume, gathered slab by slab (the first pass
/// of a streamed encoding). Throws Error for a float dtype (at construction) and for a slab of
/// another dtype than the first.
class LabelValueCollector {
 public:
  explicit LabelValueCollector(DType dtype);
  /// @brief Adds the values of `slab` (parallel; O(voxels)).
  void add(const Volume& slab);
  /// @brief The map of every value added, ascending. Throws Error beyond 2^32 - 2 labels.
  LabelMap finish();

 private:
  DType dtype_;
  std::vector<unsigned char> seen_;    // dtypes of <= 16 bits: presence per value
  std::vector<std::int64_t> values_;   // wider dtypes: sorted, distinct
};

/// @brief Dense ids of the voxels of `labels` under `map` into `ids` (resized; x fastest;
/// parallel). Throws Error naming the value when one is not in the map, or on a dtype mismatch.
void assign_source_ids(const Volume& labels, const LabelMap& map, std::vector<std::uint32_t>& ids);

// Maps every voxel of an integer label volume to its dense id (parallel; O(voxels)).
// Throws Error for float dtypes and for more than 2^32 - 1 distinct labels.
SourceIds to_source_ids(const Volume& labels);

}  // namespace strata::mixture

#pragma once
// Label values of a segmentation (any integer dtype) <-> dense source ids 0..N-1.
// Ids follow ascending label value, so the map is canonical for a set of values, and level 0
// of the Mixture Graph decodes back to the original samples bit for bit.
#include <cstdint>
#include <optional>
#include <span>
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

// Maps every voxel of an integer label volume to its dense id (parallel; O(voxels)).
// Throws Error for float dtypes and for more than 2^32 - 1 distinct labels.
SourceIds to_source_ids(const Volume& labels);

}  // namespace strata::mixture

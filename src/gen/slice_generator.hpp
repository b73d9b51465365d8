#pragma once
// Private base of all generators: a slab is assembled from independent tasks (one slice, a
// block of rows), each computed only from its coordinates, so any slab partition and any
// thread schedule give the same bytes.
#include <cstddef>
#include <cstdint>
#include <memory>

#include "strata/gen/generators.hpp"

namespace strata::gen::detail {

class SliceGenerator : public Generator {
 public:
  explicit SliceGenerator(const VolumeInfo& info) : info_(info) {}
  const VolumeInfo& info() const override { return info_; }
  Volume slab(std::int64_t z0, std::int64_t z1) const override;
  // slab() with each slice cut into tasks of `rows_per_task` rows; tests use it to check that
  // the blocks join seamlessly (slab() picks the size from the width).
  Volume slab_in_blocks(std::int64_t z0, std::int64_t z1, std::int64_t rows_per_task) const;

 protected:
  // Fills rows [y0, y1) of slice z; `rows` points at row y0 (dims.x samples per row).
  virtual void fill_rows(std::int64_t z, std::int64_t y0, std::int64_t y1, std::byte* rows) const = 0;

 private:
  VolumeInfo info_;
};

// Factories of the individual kinds; params are validated by make_generator.
std::unique_ptr<Generator> make_prisms(const Params& params);
std::unique_ptr<Generator> make_marschner_lobb(const Params& params);
std::unique_ptr<Generator> make_sphere(const Params& params);
std::unique_ptr<Generator> make_voronoi(const Params& params);
std::unique_ptr<Generator> make_fibres(const Params& params);
std::unique_ptr<Generator> make_superpixels(const Params& params);

// Geometric mean of the dimensions: the length scale object sizes are chosen from.
double mean_extent(const Extent& dims);

// Bytes the kinds that place objects up front allocate for them (an estimate from the expected
// object sizes, with vector growth); params.count is resolved (> 0). Never allocates.
double prisms_setup_bytes(const Params& params);
double fibres_setup_bytes(const Params& params);
double voronoi_setup_bytes(const Params& params);
// Bytes of a z-bin index over `depth` slices (its offsets, before any object).
double zbin_index_bytes(std::int64_t depth);

}  // namespace strata::gen::detail

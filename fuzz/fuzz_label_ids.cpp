// The label id storage of one mip level (sections "ids_L<n>", mixture/id_storage.hpp), both
// layouts: deserialized, then read voxel by voxel and box by box as the label decoders do.
//
// Input: byte 0 = bit 0: FixedRateIds (else BlockPaletteIds); then the serialized ids.
#include <algorithm>
#include <vector>

#include "support.hpp"
#include "strata/mixture/id_storage.hpp"

namespace {

constexpr std::int64_t kMaxVoxels = 1 << 18;

template <class Ids>
void read_corners(const Ids& ids) {
  const strata::Extent d = ids.dims();
  if (d.x < 1 || d.y < 1 || d.z < 1) return;
  for (int c = 0; c < 8; ++c) (void)ids.at(c & 1 ? d.x - 1 : 0, c & 2 ? d.y - 1 : 0, c & 4 ? d.z - 1 : 0);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const auto bytes = strata::fuzz::as_bytes(data + 1, size - 1);
  strata::fuzz::run_guarded([&] {
    if (data[0] & 1) {
      const auto ids = strata::mixture::FixedRateIds::deserialize(bytes);
      read_corners(ids);
      const strata::Extent d = ids.dims();
      if (strata::fuzz::small_extent(d.x, d.y, d.z, kMaxVoxels))
        for (std::int64_t z = 0; z < d.z; ++z)
          for (std::int64_t y = 0; y < d.y; ++y)
            for (std::int64_t x = 0; x < d.x; ++x) (void)ids.at(x, y, z);
    } else {
      const auto ids = strata::mixture::BlockPaletteIds::deserialize(bytes);
      read_corners(ids);
      const strata::Extent d = ids.dims();
      if (strata::fuzz::small_extent(d.x, d.y, d.z, kMaxVoxels)) {
        std::vector<std::uint32_t> out(std::size_t(d.voxel_count()));
        ids.decode_box(strata::Box{{0, 0, 0}, d}, out);
        // An unaligned box too: runs that start and end inside blocks.
        const strata::Box inner{{d.x / 3, d.y / 3, d.z / 3}, {std::max<std::int64_t>(d.x / 3 + 1, d.x - d.x / 5),
                                                              std::max<std::int64_t>(d.y / 3 + 1, d.y - d.y / 5),
                                                              std::max<std::int64_t>(d.z / 3 + 1, d.z - d.z / 5)}};
        out.resize(std::size_t(inner.voxel_count()));
        ids.decode_box(inner, out);
      }
    }
  });
  return 0;
}

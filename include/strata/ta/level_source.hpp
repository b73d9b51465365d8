#pragma once
/// @file
/// @brief One resolution level of a TA `.strata` file as a volume source: what the multiscale
/// writers (`strata decompress -o x.ome.zarr`) and the chunk endpoints of `strata serve` read.
#include <filesystem>

#include "strata/io/volume_io.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata::ta {

/// @brief Level `level` of `volume` decoded at rank `rank`, in `dtype` (rounded and clamped when
/// it is an integer type), placed where the level lies (TaVolume::level_geometry). `volume` must
/// outlive the source. read_box is const-safe to call from several threads at once (it only
/// reads the file through TaVolume::decode_box).
class LevelSource final : public io::VolumeSource {
 public:
  /// @brief Throws ParameterError("level") for a level outside the file, ParameterError("rank")
  /// unless 1 <= rank <= volume.rank().
  LevelSource(const TaVolume& volume, int level, int rank, DType dtype, std::filesystem::path name);
  const VolumeInfo& info() const override { return info_; }
  const std::filesystem::path& path() const override { return name_; }
  Volume read_box(const Box& box) override;

 private:
  const TaVolume& volume_;
  int level_, rank_;
  std::filesystem::path name_;
  VolumeInfo info_;
};

}  // namespace strata::ta

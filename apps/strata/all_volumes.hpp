#pragma once
// `--all-volumes` of `compress` and `labels encode`: every volume of a file that holds several
// (a 4-D NIfTI or NRRD, a multi-channel TIFF) into one .strata volume set (docs/format.md).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include <CLI/CLI.hpp>

#include "strata/io/volume_io.hpp"

namespace strata::cli {

/// Encodes volume `index` of the input, read from `source`, into the .strata file `member`;
/// `name` is how its report line names it ("out.strata (volume 2)").
using EncodeVolume = std::function<void(io::VolumeSource& source, const std::filesystem::path& member,
                                        const std::string& name)>;

/// @brief Encodes every volume of `input` with `encode`, each into a temporary file beside
/// `output`, then writes `output` as their volume set and removes the temporaries (also when a
/// volume fails, leaving no output). A file of one volume is encoded straight to `output`, as
/// without --all-volumes. Returns the number of volumes.
std::int64_t encode_all_volumes(const std::string& input, io::ReadOptions read, const std::string& output,
                                const EncodeVolume& encode);

/// The `--all-volumes` flag, exclusive with --volume.
CLI::Option* add_all_volumes_flag(CLI::App& cmd, bool& all_volumes);

}  // namespace strata::cli

#pragma once
/// @file
/// @brief Volume sets (format 1.5): one `.strata` file holding the several volumes of one
/// source file (the time points of an fMRI series, the channels of a microscope stack). Each
/// member is a complete `.strata` container, stored byte for byte in section `volume_<i>` of an
/// outer container that has no bricks and whose metadata says `"codec": "volume-set"`. Members
/// share nothing else: each has its own header, metadata, index, codec, value range and
/// checksums, so a member opens exactly like a file of its own, once its section's check value
/// (format 1.6: over the member's header, the section's name and its size) has bound it to its
/// place in the set. Byte-level spec: docs/format.md, "Codec `volume-set`".
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "strata/store/container.hpp"

namespace strata::store {

inline constexpr const char* kVolumeSetCodec = "volume-set";

/// @brief True when `reader`'s metadata names the volume-set codec.
bool is_volume_set(const ContainerReader& reader);

/// @brief The number of members of a volume set (metadata `volume_count`, at least 1, each with
/// its section). Throws FormatError naming the file and field otherwise.
std::int64_t volume_count(const ContainerReader& set);

/// @brief Member `index` of a volume set, named "<file> (volume <index>)" in messages. Throws
/// ParameterError for an index outside 0..count-1 and FormatError for a member whose section
/// fails its check value (swapped with another, replaced, a check value of 0: named
/// "<file>: section volume_<index>"), that is not a valid container or is itself a volume set.
std::unique_ptr<ContainerReader> open_member(const ContainerReader& set, std::int64_t index);

/// @brief The container a command works on: member `volume` of a volume set, or the file itself
/// when it holds one volume (then `volume` must be empty or 0). A set of several members
/// without `volume` is refused with a message giving their number and naming --volume.
std::unique_ptr<ContainerReader> open_volume(const std::filesystem::path& path, std::optional<std::int64_t> volume);

/// @brief Writes `output` (through a temporary file and a rename) as a volume set of the
/// `.strata` files `members`, in order, each opened and checked first; `source` becomes the
/// set's metadata.source (what the members came from).
void write_volume_set(const std::filesystem::path& output, const std::vector<std::filesystem::path>& members,
                      const nlohmann::json& source);

}  // namespace strata::store

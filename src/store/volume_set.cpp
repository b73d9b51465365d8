#include "strata/store/volume_set.hpp"

#include <fmt/format.h>

#include "strata/core/error.hpp"
#include "strata/io/files.hpp"
#include "strata/store/metadata_json.hpp"

namespace strata::store {

namespace {

std::string member_section(std::int64_t index) { return "volume_" + std::to_string(index); }

// A set's member count is bounded by the sections it can hold; this bound only keeps a forged
// count from asking for absurd numbers of lookups before the first missing section is found.
constexpr std::int64_t kMaxMembers = std::int64_t(1) << 24;

}  // namespace

bool is_volume_set(const ContainerReader& reader) {
  const auto codec = reader.metadata().find("codec");
  return codec != reader.metadata().end() && codec->is_string() && *codec == kVolumeSetCodec;
}

std::int64_t volume_count(const ContainerReader& set) {
  const MetadataField field{set.name(), "metadata.volume_count"};
  const std::int64_t count = json_integer(json_member(set.metadata(), "volume_count", {set.name(), "metadata"}), field, 1,
                                          kMaxMembers);
  if (!set.bricks().empty())
    throw FormatError(set.name(), "index", fmt::format("a volume set has no bricks, got {}", set.bricks().size()));
  for (std::int64_t i = 0; i < count; ++i)
    if (!set.has_section(member_section(i)))
      throw FormatError(set.name(), "metadata.sections",
                        fmt::format("no section '{}' for volume {} of the {} metadata.volume_count declares",
                                    member_section(i), i, count));
  return count;
}

std::unique_ptr<ContainerReader> open_member(const ContainerReader& set, std::int64_t index) {
  const std::int64_t count = volume_count(set);
  if (index < 0 || index >= count)
    throw ParameterError("volume", fmt::format("{}: volume {} does not exist; the file holds {} (0..{})", set.name(), index,
                                               count, count - 1));
  auto member = std::make_unique<ContainerReader>(set, member_section(index),
                                                  fmt::format("{} (volume {})", set.name(), index));
  if (is_volume_set(*member))
    throw FormatError(member->name(), "metadata.codec", "a member of a volume set cannot be a volume set itself");
  return member;
}

std::unique_ptr<ContainerReader> open_volume(const std::filesystem::path& path, std::optional<std::int64_t> volume) {
  auto reader = std::make_unique<ContainerReader>(path);
  if (!is_volume_set(*reader)) {
    if (volume.value_or(0) != 0)
      throw ParameterError("volume", fmt::format("{}: volume {} does not exist; the file holds one volume (0)",
                                                 reader->name(), *volume));
    return reader;
  }
  const std::int64_t count = volume_count(*reader);
  if (!volume && count > 1)
    throw FormatError(reader->name(), "metadata.volume_count",
                      fmt::format("holds {} volumes; choose one with --volume T (0..{})", count, count - 1));
  return open_member(*reader, volume.value_or(0));
}

void write_volume_set(const std::filesystem::path& output, const std::vector<std::filesystem::path>& members,
                      const nlohmann::json& source) {
  if (members.empty()) throw ParameterError("members", "a volume set needs at least one volume");
  ContainerWriter writer(output);
  for (std::size_t i = 0; i < members.size(); ++i) {
    const ContainerReader member(members[i]);  // a valid container, never a set inside a set
    if (is_volume_set(member))
      throw ParameterError("members", members[i].string() + ": a member of a volume set cannot be a volume set itself");
    const io::MappedFile bytes(members[i]);
    writer.add_container_section(member_section(std::int64_t(i)), {bytes.data(), std::size_t(bytes.size())});
  }
  writer.finish({{"codec", kVolumeSetCodec}, {"volume_count", members.size()}, {"source", source}});
}

}  // namespace strata::store

// The .strata container: header, metadata JSON, brick index (plain and compressed) and
// sections, as `strata info` opens it; then, as `decompress` and `labels decode` do, the codec's
// own metadata (TaVolume or EncodedLabels over the open container) and one decode of the
// coarsest level (one brick for a TA file, the smallest mip level for a label file and for its
// nested normals graph). A volume set's first members are opened and read the same way.
//
// Every input is read twice: as it is, and with the header, metadata and index checksums
// recomputed, so mutations get past the checksums to the parsers behind them (payload and
// section checksums are left alone; the payload targets cover the decoders).
#include <algorithm>
#include <cstring>
#include <memory>
#include <vector>

#include "support.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/store/container.hpp"
#include "strata/store/crc32c.hpp"
#include "strata/store/volume_set.hpp"
#include "strata/ta/codec_registry.hpp"
#include "strata/ta/ta_volume.hpp"

namespace {

void read_codec(std::unique_ptr<strata::store::ContainerReader> reader) {
  const nlohmann::json& m = reader->metadata();
  (void)reader->file_size();
  std::size_t checked = 0;
  for (const auto& entry : reader->bricks()) {
    (void)reader->find(entry.key);
    strata::fuzz::run_guarded([&] { (void)reader->payload(entry); });  // each checksum on its own
    if (++checked == 64) break;
  }
  if (m.contains("sections") && m["sections"].is_object())
    for (const auto& item : m["sections"].items()) {
      const std::string name = item.key();
      if (reader->has_section(name)) strata::fuzz::run_guarded([&] { (void)reader->section(name); });
    }
  const std::string codec = m.contains("codec") && m["codec"].is_string() ? m["codec"].get<std::string>() : "";
  if (strata::ta::is_codec_name(codec)) {
    const strata::ta::TaVolume volume(std::move(reader));
    const int top = volume.geometry().level_count() - 1;
    const strata::Extent dims = volume.geometry().level(top).dims;
    if (strata::fuzz::small_extent(dims.x, dims.y, dims.z, 1 << 18)) (void)volume.decode_box(top, strata::Box{{0, 0, 0}, dims}, volume.rank());
  } else if (codec == strata::mixture::kMixtureCodecName) {
    const strata::mixture::EncodedLabels labels(std::move(reader));
    const int top = labels.level_count() - 1;
    if (top < 0) return;
    const strata::Extent dims = labels.level_dims(top);
    if (strata::fuzz::small_extent(dims.x, dims.y, dims.z, 1 << 18)) (void)labels.dominant_labels(top);
    // The normals graph is a whole .strata file nested in a section: opened as the renderer does.
    if (labels.has_normals()) {
      const std::unique_ptr<strata::mixture::EncodedLabels> normals = labels.open_normals();
      const int coarsest = normals->level_count() - 1;
      const strata::Extent n = normals->level_dims(coarsest);
      if (strata::fuzz::small_extent(n.x, n.y, n.z, 1 << 18)) (void)normals->dominant_labels(coarsest);
    }
  }
}

void read_container(const std::filesystem::path& path) {
  if (!strata::store::is_strata_file(path)) return;
  auto reader = std::make_unique<strata::store::ContainerReader>(path);
  if (!strata::store::is_volume_set(*reader)) {
    read_codec(std::move(reader));
    return;
  }
  const std::int64_t count = std::min<std::int64_t>(strata::store::volume_count(*reader), 4);
  for (std::int64_t i = 0; i < count; ++i)
    strata::fuzz::run_guarded([&] { read_codec(strata::store::open_member(*reader, i)); });
}

template <class T>
T load(const std::vector<std::byte>& b, std::size_t at) {
  T v{};
  std::memcpy(&v, b.data() + at, sizeof(T));
  return v;
}

void store_crc(std::vector<std::byte>& b, std::size_t at, std::uint32_t crc) { std::memcpy(b.data() + at, &crc, 4); }

// Header fields (docs/format.md): flags u32 @12, index_offset u64 @16, index_count u64 @24,
// metadata_offset u64 @32, metadata_size u64 @40, metadata_crc @52, index_crc @56, header_crc @60.
void fix_checksums(std::vector<std::byte>& b) {
  if (b.size() < strata::store::kHeaderSize) return;
  const std::uint64_t n = b.size();
  const auto meta_offset = load<std::uint64_t>(b, 32), meta_size = load<std::uint64_t>(b, 40);
  if (meta_offset <= n && meta_size <= n - meta_offset)
    store_crc(b, 52, strata::store::crc32c(b.data() + meta_offset, meta_size));
  const auto index_offset = load<std::uint64_t>(b, 16), count = load<std::uint64_t>(b, 24);
  if (load<std::uint32_t>(b, 12) & 1) {  // compressed index: u64 frame size, then the frame
    if (index_offset <= n && n - index_offset >= 8) {
      const auto frame = load<std::uint64_t>(b, index_offset);
      if (frame <= n - index_offset - 8) store_crc(b, 56, strata::store::crc32c(b.data() + index_offset, 8 + frame));
    }
  } else if (count <= n / 64 && index_offset <= n && count * 64 <= n - index_offset) {
    store_crc(b, 56, strata::store::crc32c(b.data() + index_offset, count * 64));
  }
  store_crc(b, 60, strata::store::crc32c(b.data(), 60));
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = strata::fuzz::write_input("input.strata", strata::fuzz::as_bytes(data, size));
  strata::fuzz::run_guarded([&] { read_container(path); });
  std::vector<std::byte> fixed(reinterpret_cast<const std::byte*>(data), reinterpret_cast<const std::byte*>(data) + size);
  fix_checksums(fixed);
  if (!std::equal(fixed.begin(), fixed.end(), reinterpret_cast<const std::byte*>(data))) {
    strata::fuzz::write_input("input.strata", fixed);
    strata::fuzz::run_guarded([&] { read_container(path); });
  }
  return 0;
}

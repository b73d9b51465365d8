#pragma once
// Forging .strata files for tests of hostile input: files whose container checksums are valid
// but whose content lies. Header-only so the store, ta, mixture and cli test programs share it.
#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <random>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"
#include "strata/store/container.hpp"
#include "strata/store/crc32c.hpp"
#include "strata/store/zstd_frame.hpp"

namespace strata::test::forge {

// Header fields by their offsets in docs/format.md.
inline constexpr std::size_t kMinorField = 10, kFlagsField = 12, kIndexOffsetField = 16, kIndexCountField = 24,
                             kMetadataOffsetField = 32, kMetadataSizeField = 40, kMetadataCrcField = 52,
                             kIndexCrcField = 56, kHeaderCrcField = 60;

inline std::vector<std::byte> file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  const std::vector<char> chars{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  std::vector<std::byte> bytes(chars.size());
  std::memcpy(bytes.data(), chars.data(), chars.size());
  return bytes;
}

inline void write_file(const std::filesystem::path& path, std::span<const std::byte> bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

/// `n` pseudo-random bytes from `seed`.
inline std::vector<std::byte> random_bytes(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<std::byte> v(n);
  for (auto& b : v) b = std::byte(rng() & 0xff);
  return v;
}

/// What `f` throws, for tests of hostile input: "" when nothing, the message of a FormatError,
/// "Error: <message>" for another strata::Error and "FOREIGN: <what>" for anything else.
inline std::string failure_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const FormatError& e) {
    return e.what();
  } catch (const Error& e) {
    return std::string("Error: ") + e.what();
  } catch (const std::exception& e) {
    return std::string("FOREIGN: ") + e.what();
  }
  return "";
}

/// Recomputes the header checksum of a file image.
inline void seal_header(std::vector<std::byte>& bytes) {
  store_field(std::span(bytes), kHeaderCrcField, store::crc32c(bytes.data(), kHeaderCrcField));
}

/// Rewrites header bytes of `path` with `edit`, then recomputes the header checksum.
inline void patch_header(const std::filesystem::path& path, const std::function<void(std::span<std::byte>)>& edit) {
  std::vector<std::byte> bytes = file_bytes(path);
  edit(std::span(bytes).first(store::kHeaderSize));
  seal_header(bytes);
  write_file(path, bytes);
}

/// Replaces the metadata of `path` in place by `edit(metadata)` dumped as `text` (or the raw
/// `text` when `raw` is set), keeping payloads and index where they are (the index moves behind
/// the new metadata), and fixes metadata_crc32c and the header checksum: what a forger does who
/// edits the JSON and re-checksums it so the container accepts it. Payload check values of 1.3
/// files still cover the old metadata checksum.
inline void replace_metadata_text(const std::filesystem::path& path, const std::string& text) {
  std::vector<std::byte> bytes = file_bytes(path);
  const auto meta_offset = load_field<std::uint64_t>(bytes, kMetadataOffsetField);
  const auto meta_size = load_field<std::uint64_t>(bytes, kMetadataSizeField);
  const auto index_offset = load_field<std::uint64_t>(bytes, kIndexOffsetField);
  const std::vector<std::byte> index(bytes.begin() + std::ptrdiff_t(index_offset), bytes.end());
  (void)meta_size;
  bytes.resize(meta_offset);
  const auto t = std::as_bytes(std::span(text));
  bytes.insert(bytes.end(), t.begin(), t.end());
  bytes.resize((bytes.size() + 63) / 64 * 64);
  const std::uint64_t new_index_offset = bytes.size();
  bytes.insert(bytes.end(), index.begin(), index.end());
  const std::span<std::byte> h(bytes.data(), store::kHeaderSize);
  store_field(h, kMetadataSizeField, std::uint64_t(text.size()));
  store_field(h, kMetadataCrcField, store::crc32c(text.data(), text.size()));
  store_field(h, kIndexOffsetField, new_index_offset);
  seal_header(bytes);
  write_file(path, bytes);
}

inline void edit_metadata_in_place(const std::filesystem::path& path, const std::function<void(nlohmann::json&)>& edit) {
  nlohmann::json m = store::ContainerReader(path).metadata();
  edit(m);
  replace_metadata_text(path, m.dump());
}

/// Replaces the compressed index at the tail of `path` (as ContainerWriter writes it) by one whose
/// columns `edit` changed, with valid frame size, index checksum and header checksum: what a
/// reader sees when a writer (or a forger) got the column content wrong.
inline void rewrite_index_columns(const std::filesystem::path& path, const std::function<void(std::vector<std::byte>&)>& edit) {
  std::vector<std::byte> bytes = file_bytes(path);
  const auto index_offset = load_field<std::uint64_t>(bytes, kIndexOffsetField);
  const auto frame_size = load_field<std::uint64_t>(bytes, index_offset);
  if (index_offset + 8 + frame_size != bytes.size()) throw Error("rewrite_index_columns: the index is not the file's tail");
  std::vector<std::byte> columns;
  store::zstd_decompress(std::span(bytes).subspan(index_offset + 8), 1 << 26, columns, path.string(), "test");
  edit(columns);
  const std::vector<std::byte> frame = store::zstd_compress(columns, 3);
  bytes.resize(index_offset + 8);
  store_field(std::span(bytes).subspan(index_offset), 0, std::uint64_t(frame.size()));
  bytes.insert(bytes.end(), frame.begin(), frame.end());
  store_field(std::span(bytes), kIndexCrcField, store::crc32c(bytes.data() + index_offset, 8 + frame.size()));
  seal_header(bytes);
  write_file(path, bytes);
}

/// Rewrites a file written now (format 1.6, compressed index) as a 1.2 writer wrote it: payload
/// and section checksums by the old rule (the CRC-32C of their bytes alone), no
/// metadata.bricks_crc32c and no section marked as a container, minor version 2.
inline void downgrade_to_1_2(const std::filesystem::path& path) {
  std::vector<std::uint32_t> crcs;  // the crc32c column: entries with payload bytes, in index order
  nlohmann::json m;
  {
    const store::ContainerReader r(path);
    for (const auto& e : r.bricks())
      if (e.size != 0) {
        const auto p = r.payload(e);
        crcs.push_back(store::crc32c(p.data(), p.size()));
      }
    m = r.metadata();
    m.erase("bricks_crc32c");
    for (auto& [name, s] : m["sections"].items()) {
      const auto b = r.section(name);
      s["crc32c"] = store::crc32c(b.data(), b.size());
      s.erase("container");
    }
  }
  replace_metadata_text(path, m.dump());
  rewrite_index_columns(path, [&](std::vector<std::byte>& c) {
    const std::size_t at = c.size() - 4 * crcs.size();  // the last column, as 4 byte planes
    for (std::size_t i = 0; i < crcs.size(); ++i)
      for (std::size_t plane = 0; plane < 4; ++plane) c[at + plane * crcs.size() + i] = std::byte(crcs[i] >> (8 * plane));
  });
  patch_header(path, [](std::span<std::byte> h) { store_field(h, kMinorField, std::uint16_t(2)); });
}

/// One brick of a rewritten file: its entry (key, kind, min, max, histogram) and payload.
struct Brick {
  store::BrickEntry entry;
  std::vector<std::byte> payload;
};
/// One section: name, bytes, and whether it holds a whole container (format 1.6).
struct Section {
  std::string name;
  std::vector<std::byte> bytes;
  bool container = false;
};

/// Writes `out` from `in` through ContainerWriter, the metadata changed by `edit`, the bricks and
/// sections by `edit_bricks` / `edit_sections`: a forgery with every checksum valid, the
/// payload bindings of format 1.3 included.
inline void rewrite(const std::filesystem::path& in, const std::filesystem::path& out,
                    const std::function<void(nlohmann::json&)>& edit,
                    const std::function<void(std::vector<Brick>&)>& edit_bricks = nullptr,
                    const std::function<void(std::vector<Section>&)>& edit_sections = nullptr) {
  std::vector<Brick> bricks;
  std::vector<Section> sections;
  nlohmann::json m;
  {
    const store::ContainerReader r(in);
    for (const auto& e : r.bricks()) {
      const auto p = r.payload(e);
      bricks.push_back({e, std::vector<std::byte>(p.begin(), p.end())});
    }
    m = r.metadata();
    for (const auto& [name, s] : m["sections"].items()) {
      const auto b = r.section(name);
      sections.push_back({name, std::vector<std::byte>(b.begin(), b.end()), s.value("container", false)});
    }
  }
  m.erase("sections");
  m.erase("bricks_crc32c");
  if (edit) edit(m);
  if (edit_bricks) edit_bricks(bricks);
  if (edit_sections) edit_sections(sections);
  store::ContainerWriter w(out);
  for (const Brick& b : bricks) w.add_brick(b.entry, b.payload);
  for (const Section& s : sections) s.container ? w.add_container_section(s.name, s.bytes) : w.add_section(s.name, s.bytes);
  w.finish(m);
}

}  // namespace strata::test::forge

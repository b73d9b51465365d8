#pragma once
// The .strata container (byte-level spec: docs/format.md). One file holds a fixed header,
// payloads written as they are produced (64-byte-aligned where needs_alignment says so, packed
// otherwise), then the JSON metadata and the brick index at the tail (the header points to both,
// so a writer can stream bricks without knowing their count in advance). Since format 1.2 the
// index is stored column by column in one zstd frame; readers also take 1.0/1.1 files with the
// fixed 64-byte-per-entry index. Since format 1.3 a payload's checksum also covers its index
// key, its kind and the metadata's checksum, and a section's covers its name
// (payload_check_value, section_check_value), so a swapped index entry or section, or metadata
// edited under the payloads, fails the check. Since format 1.6 the metadata holds the check value
// of the index's keys, kinds, sizes, min, max and histograms (bricks_check_value), and a section
// that holds a whole container (a volume set member, the labels' normals) is checked through that
// container's header whenever it is opened (container_section_check_value).
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "strata/io/byte_source.hpp"
#include "strata/io/files.hpp"
#include "strata/store/payload_kinds.hpp"

namespace strata::store {

inline constexpr std::uint16_t kFormatVersionMajor = 1;
inline constexpr std::uint16_t kFormatVersionMinor = 6;
/// The first minor version whose checksums are bound to keys, kinds and names.
inline constexpr std::uint16_t kBoundChecksumsMinor = 3;
/// The first minor version with metadata.bricks_crc32c and sections marked as containers.
inline constexpr std::uint16_t kBoundIndexMinor = 6;
/// Bytes of a section holding a container that its check value covers: the container's header
/// without its own checksum (bytes 0-59, which that checksum covers). Not all 64: a CRC-32C
/// continued over a block and then over that block's own CRC-32C gives one value for every block.
inline constexpr std::size_t kContainerSectionHead = 60;
inline constexpr std::size_t kHeaderSize = 64;
/// Bytes of one entry of the 1.0/1.1 index, and the header's `index_entry_size` in every version
/// (the logical entry; a compressed index stores far fewer).
inline constexpr std::size_t kIndexEntrySize = 64;
inline constexpr std::size_t kPayloadAlignment = 64;

struct BrickKey {
  std::uint8_t level = 0;  // 0 = full resolution
  std::int32_t x = 0, y = 0, z = 0;  // brick coordinates in that level's grid
  bool operator==(const BrickKey&) const = default;
};

// "brick (level l, x,y,z)": how messages name a brick.
std::string brick_name(const BrickKey& k);

struct BrickKeyHash {
  std::size_t operator()(const BrickKey& k) const {
    std::uint64_t h = k.level;
    h = h * 0x9E3779B97F4A7C15ull ^ std::uint32_t(k.x);
    h = h * 0x9E3779B97F4A7C15ull ^ std::uint32_t(k.y);
    h = h * 0x9E3779B97F4A7C15ull ^ std::uint32_t(k.z);
    return std::size_t(h ^ (h >> 29));
  }
};

/// @brief Format 1.3's check value of a brick payload: the CRC-32C of the payload bytes
/// (`payload_crc`) continued over the 20-byte binding record of docs/format.md (level, kind, 0,
/// x, y, z, `metadata_crc`). An empty payload's check value is 0 (it has nothing to check).
std::uint32_t payload_check_value(std::uint32_t payload_crc, std::uint64_t size, const BrickKey& key, PayloadKind kind,
                                  std::uint32_t metadata_crc);
/// @brief Format 1.3's check value of a section: the CRC-32C of its bytes continued over its
/// name (UTF-8) and the name's length (u32).
std::uint32_t section_check_value(std::span<const std::byte> bytes, const std::string& name);

// One index entry. `histogram` bit i is set when some voxel falls into bin i of 64 equal
// bins over the volume's value range (metadata "source.value_range"), for transfer-function culling.
struct BrickEntry {
  BrickKey key;
  PayloadKind kind = PayloadKind::constant;
  std::uint64_t offset = 0, size = 0;
  std::uint32_t crc32c = 0;  // as stored: the bound check value in 1.3, the payload's CRC-32C before
  float min = 0, max = 0;
  std::uint64_t histogram = 0;
};

/// @brief Format 1.6's check value of the brick index, stored as metadata.bricks_crc32c: the
/// CRC-32C of the first nine columns of the compressed index (level, kind, x, y, z, size, min,
/// max, histogram: byte planes, before compression) of `entries`, i.e. everything but offsets and
/// check values. The payload check values cover the metadata's checksum, so an index entry's
/// min, max or histogram (which no payload check value covers) cannot change unnoticed.
std::uint32_t bricks_check_value(std::span<const BrickEntry> entries);

/// @brief Format 1.6's check value of a section that holds a whole container: section_check_value
/// over its first kContainerSectionHead bytes (`head`: the container's header, which roots every
/// other check of it; all of them in a shorter section), continued over the section's size (u64).
/// `head` may be longer; only its first kContainerSectionHead bytes count.
std::uint32_t container_section_check_value(std::span<const std::byte> head, const std::string& name, std::uint64_t size);

// A named blob outside the brick index (e.g. global factor matrices, a mixture graph). A
// `container` section (format 1.6) holds a whole .strata file: a volume set member, the labels'
// normals graph; its check value is container_section_check_value.
struct Section {
  std::uint64_t offset = 0, size = 0;
  std::uint32_t crc32c = 0;
  bool container = false;
};

// Streams payloads into `<path>.tmp`; finish() writes metadata, the compressed index (format
// 1.2) and the header, then renames to `path`. add_brick/add_section are thread-safe. Without
// finish() nothing is left.
class ContainerWriter {
 public:
  explicit ContainerWriter(const std::filesystem::path& path);
  ~ContainerWriter();
  ContainerWriter(const ContainerWriter&) = delete;
  ContainerWriter& operator=(const ContainerWriter&) = delete;

  /// @brief Appends `payload` (aligned when needs_alignment(entry.kind), packed otherwise) and
  /// fills entry.offset/size/crc32c from it; the rest comes from the caller. An empty payload
  /// gets offset 0. finish() binds the checksum to the key, the kind and the metadata.
  void add_brick(BrickEntry entry, std::span<const std::byte> payload);
  void add_section(const std::string& name, std::span<const std::byte> payload);
  /// @brief Appends `container`, the bytes of a whole .strata file, as a section that readers
  /// open in place (ContainerReader's section constructor): marked `"container": true` in
  /// metadata.sections, with the check value of its header, name and size.
  void add_container_section(const std::string& name, std::span<const std::byte> container);
  std::uint64_t bytes_written() const;
  // `metadata` gets a "sections" object and "bricks_crc32c" (bricks_check_value of the index)
  // added; returns the final file size.
  std::uint64_t finish(nlohmann::json metadata);

 private:
  std::uint64_t append(std::span<const std::byte> payload, bool aligned);
  std::unique_ptr<io::AtomicOutputFile> out_;
  mutable std::mutex mutex_;
  std::uint64_t position_ = 0;
  std::vector<BrickEntry> entries_;
  std::vector<std::pair<std::string, Section>> sections_;
};

// Opens a container through an io::ByteSource (a memory-mapped local file, or an http(s) URL read
// with range requests) and validates header, metadata and index: the metadata must be a JSON
// object whose "sections" entries are well-formed and inside the file; index entries must have a
// known kind, a unique key and a range inside the file, and constant bricks no payload bytes;
// since format 1.6 the index must match metadata.bricks_crc32c.
// Opening reads the header, the metadata and the index only (the last two with one read, as the
// writer puts them together at the tail). Payload checksums are verified on every payload()
// call; a mismatch raises a FormatError naming the brick.
class ContainerReader {
 public:
  /// @brief Opens `path`, a local file or an `http://`/`https://` URL (io::open_byte_source).
  explicit ContainerReader(const std::filesystem::path& path);
  /// @brief Opens the container stored in section `section` of `outer` (a member of a volume
  /// set, store/volume_set.hpp; the labels' normals graph), sharing its mapping; offsets are
  /// relative to the section's start. The section's check value is verified first: in a file of
  /// format 1.6 the section must be marked as a container and its check value covers the
  /// container's header (which roots the container's own checks), its name and its size; in an
  /// older file it covers the section's bytes, which are then read once. So a section swapped
  /// with another, a check value of 0 or a replaced container is a FormatError naming `outer`
  /// and the section. Then every check of the path constructor applies, within the section's
  /// bytes. Messages name the file as `name`.
  ContainerReader(const ContainerReader& outer, const std::string& section, std::string name);
  ~ContainerReader();

  /// @brief The file on disk or the URL (for a member of a volume set, the set's file).
  const std::filesystem::path& path() const { return path_; }
  /// @brief How messages name this container: the path, or "<path> (volume N)" for a member of
  /// a volume set.
  const std::string& name() const { return name_; }
  const nlohmann::json& metadata() const { return metadata_; }
  const std::vector<BrickEntry>& bricks() const { return entries_; }
  const BrickEntry* find(const BrickKey& key) const;  // nullptr when absent
  /// @brief The brick's payload bytes, checksum verified (a local file's are not copied).
  io::SharedBytes payload(const BrickEntry& entry) const;
  /// @brief A hint that the payloads of `entries` will be read soon: a remote file fetches them
  /// in as few requests as is cheap; a local one does nothing.
  void prefetch(std::span<const BrickEntry* const> entries) const;
  bool has_section(const std::string& name) const;
  /// @brief The section's bytes, checksum verified (for a container section of format 1.6, its
  /// header, name and size; the container's own checks cover the rest when it is opened).
  io::SharedBytes section(const std::string& name) const;
  /// @brief Where the bytes come from (its transfer_stats() count a remote file's requests).
  const io::ByteSource& source() const { return *source_; }
  /// @brief Bytes of this container: the file, or the member's section.
  std::uint64_t file_size() const;
  std::uint64_t metadata_bytes() const { return metadata_size_; }
  /// @brief Bytes the brick index occupies in the file as stored: count × 64 for a 1.0/1.1
  /// index, the 8-byte size field plus the zstd frame for a compressed one.
  std::uint64_t index_bytes() const { return index_size_; }
  /// @brief True when the file stores its index compressed (header flag bit 0, format 1.2).
  bool index_compressed() const { return index_compressed_; }
  /// @brief The header's minor version (kFormatVersionMinor for files written now).
  std::uint16_t version_minor() const { return minor_; }

 private:
  void check_range(std::uint64_t offset, std::uint64_t size, const std::string& what) const;
  io::SharedBytes read_range(std::uint64_t offset, std::uint64_t size, const std::string& what) const;
  void read_tail(std::uint64_t metadata_offset, std::uint64_t index_offset, std::uint64_t count);
  void read_sections();
  void check_bricks() const;
  const Section& container_section(const std::string& name) const;
  void check_section_value(const std::string& name, const Section& s, std::uint32_t computed) const;
  void check_entry(const BrickEntry& e) const;
  void check_index_fits_memory(std::uint64_t count) const;
  std::vector<BrickEntry> read_plain_index(std::uint64_t offset, std::uint64_t count, std::uint32_t crc);
  std::vector<BrickEntry> read_compressed_index(std::uint64_t offset, std::uint64_t count, std::uint32_t crc);
  void open();
  std::filesystem::path path_;
  std::string name_;
  std::shared_ptr<const io::ByteSource> source_;  // the whole file, or a volume set member's section
  std::uint64_t size_ = 0;                         // source_->size()
  io::SharedBytes tail_;  // metadata and index, read at once while opening; released after
  std::uint64_t tail_offset_ = 0;
  nlohmann::json metadata_;
  std::uint64_t metadata_size_ = 0;
  std::uint64_t index_size_ = 0;
  bool index_compressed_ = false;
  std::uint16_t minor_ = 0;
  std::uint32_t metadata_crc_ = 0;
  std::vector<BrickEntry> entries_;
  std::unordered_map<BrickKey, std::size_t, BrickKeyHash> lookup_;
  std::unordered_map<std::string, Section> sections_;
};

// True when the file starts with the .strata magic (cheap; for format dispatch in the CLI). A
// URL is always taken for one (only .strata files are read remotely; opening checks the magic).
bool is_strata_file(const std::filesystem::path& path);

}  // namespace strata::store

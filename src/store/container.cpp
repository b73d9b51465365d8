#include "strata/store/container.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>

#include <fmt/format.h>

#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"
#include "strata/core/memory.hpp"
#include "strata/io/formats.hpp"
#include "strata/store/byte_planes.hpp"
#include "strata/store/crc32c.hpp"
#include "strata/store/metadata_json.hpp"
#include "strata/store/zstd_frame.hpp"

namespace strata::store {

namespace {

// "\x89STRATA\n": the high byte catches 7-bit transfers, the newline catches text-mode
// line-ending conversion (the trick PNG uses).
constexpr std::array<unsigned char, 8> kMagic{0x89, 'S', 'T', 'R', 'A', 'T', 'A', '\n'};

// Header `flags` bits. A flag marks a change an older reader would misread (a 1.1 reader would
// take a compressed index for 64-byte entries), so readers reject bits they do not know.
constexpr std::uint32_t kFlagCompressedIndex = 1u << 0;  // format 1.2
constexpr std::uint32_t kKnownFlags = kFlagCompressedIndex;

// The compressed index (format 1.2, docs/format.md): a u64 frame size, then one zstd frame of
// columns, each split into byte planes. Columns every entry has: level u8, kind u8, x, y, z i32,
// size u64, min, max f32, histogram u64. Columns only entries with payload bytes have: offset
// gap u64, crc32c u32 (a payload-less entry has offset 0 and the CRC-32C of nothing, 0).
constexpr std::uint64_t kColumnBytesPerEntry = 1 + 1 + 3 * 4 + 8 + 2 * 4 + 8;
constexpr std::uint64_t kColumnBytesPerPayload = 8 + 4;
// The decompression limit is count × this: never more than the 64 bytes an uncompressed entry takes.
static_assert(kColumnBytesPerEntry + kColumnBytesPerPayload <= kIndexEntrySize);
constexpr std::size_t kIndexSizeField = 8;
// The index is compressed once per file, so a slow level costs little: on the MRI files of
// docs/format.md level 15 is 8% smaller than 3 and within 1% of 17..22.
constexpr int kIndexZstdLevel = 15;
// A zstd block regenerates at most 128 KiB and takes at least 4 stored bytes (a 3-byte block
// header and the one byte of an RLE block), so no frame inflates more than 32768-fold. An
// index_count whose columns would need more is refused before anything is allocated; the
// bound never rejects a real file, however many constant bricks it has.
constexpr std::uint64_t kZstdMaxExpansion = 128 * 1024 / 4;

// Memory an index entry takes while the reader opens the file: the entry itself, its lookup
// node and bucket, and its columns (at most the 64 bytes of a plain entry) while they decode.
constexpr std::uint64_t kOpenBytesPerEntry = sizeof(BrickEntry) + 64 + kIndexEntrySize;
// The share of physical memory an index may take to open: a header declaring more is corrupt or
// hostile (a zstd frame may declare 32768 bytes of columns per stored byte), or the volume is
// too large for this machine; either way it is refused before anything is allocated.
constexpr std::uint64_t kIndexMemoryShareDivisor = 2;

std::uint64_t saturating_mul(std::uint64_t a, std::uint64_t b) { return a != 0 && b > UINT64_MAX / a ? UINT64_MAX : a * b; }

std::uint64_t align_up(std::uint64_t position) {
  return (position + kPayloadAlignment - 1) / kPayloadAlignment * kPayloadAlignment;
}

// Where the writer puts a payload of `kind` when the previous brick payload ended at `end`. The
// compressed index stores offsets as the gap from it: 0 unless a section was written between.
std::uint64_t packed_offset(std::uint64_t end, PayloadKind kind) { return needs_alignment(kind) ? align_up(end) : end; }


struct Header {
  std::uint16_t version_major = kFormatVersionMajor, version_minor = kFormatVersionMinor;
  std::uint32_t flags = 0;
  std::uint64_t index_offset = 0, index_count = 0, metadata_offset = 0, metadata_size = 0;
  std::uint32_t index_entry_size = kIndexEntrySize, metadata_crc = 0, index_crc = 0;
};

std::array<std::byte, kHeaderSize> encode_header(const Header& h) {
  std::array<std::byte, kHeaderSize> b{};
  std::memcpy(b.data(), kMagic.data(), kMagic.size());
  store_field(b, 8, h.version_major);
  store_field(b, 10, h.version_minor);
  store_field(b, 12, h.flags);
  store_field(b, 16, h.index_offset);
  store_field(b, 24, h.index_count);
  store_field(b, 32, h.metadata_offset);
  store_field(b, 40, h.metadata_size);
  store_field(b, 48, h.index_entry_size);
  store_field(b, 52, h.metadata_crc);
  store_field(b, 56, h.index_crc);
  store_field(b, 60, crc32c(b.data(), 60));
  return b;
}

// The 64-byte entry of a 1.0/1.1 index (the writer no longer produces it).
BrickEntry decode_entry(std::span<const std::byte, kIndexEntrySize> b) {
  BrickEntry e;
  e.key.level = load_field<std::uint8_t>(b, 0);
  e.kind = PayloadKind(load_field<std::uint8_t>(b, 1));
  e.crc32c = load_field<std::uint32_t>(b, 4);
  e.key.x = load_field<std::int32_t>(b, 8);
  e.key.y = load_field<std::int32_t>(b, 12);
  e.key.z = load_field<std::int32_t>(b, 16);
  e.offset = load_field<std::uint64_t>(b, 24);
  e.size = load_field<std::uint64_t>(b, 32);
  e.min = load_field<float>(b, 40);
  e.max = load_field<float>(b, 44);
  e.histogram = load_field<std::uint64_t>(b, 48);
  return e;
}

bool known_kind(PayloadKind k) { return find_payload_kind(std::uint8_t(k)) != nullptr; }

// Appends value(e) of the entries (with payload_only, of those with payload bytes) as one column
// of T, split into byte planes.
template <class T, class Value>
void put_column(std::vector<std::byte>& out, std::span<const BrickEntry> entries, bool payload_only, Value&& value) {
  std::vector<T> column;
  column.reserve(entries.size());
  for (const BrickEntry& e : entries)
    if (!payload_only || e.size != 0) column.push_back(T(value(e)));
  const auto bytes = std::as_bytes(std::span(column));
  const std::size_t at = out.size();
  out.resize(at + bytes.size());
  split_byte_planes(bytes, std::span(out).subspan(at), sizeof(T));
}

// The columns every entry has (1-9 of docs/format.md): what bricks_check_value covers.
void put_entry_columns(std::vector<std::byte>& columns, std::span<const BrickEntry> entries) {
  put_column<std::uint8_t>(columns, entries, false, [](const BrickEntry& e) { return e.key.level; });
  put_column<std::uint8_t>(columns, entries, false, [](const BrickEntry& e) { return std::uint8_t(e.kind); });
  put_column<std::int32_t>(columns, entries, false, [](const BrickEntry& e) { return e.key.x; });
  put_column<std::int32_t>(columns, entries, false, [](const BrickEntry& e) { return e.key.y; });
  put_column<std::int32_t>(columns, entries, false, [](const BrickEntry& e) { return e.key.z; });
  put_column<std::uint64_t>(columns, entries, false, [](const BrickEntry& e) { return e.size; });
  put_column<float>(columns, entries, false, [](const BrickEntry& e) { return e.min; });
  put_column<float>(columns, entries, false, [](const BrickEntry& e) { return e.max; });
  put_column<std::uint64_t>(columns, entries, false, [](const BrickEntry& e) { return e.histogram; });
}

// The stored compressed index: u64 frame size, then the zstd frame of the columns.
std::vector<std::byte> encode_compressed_index(const std::vector<BrickEntry>& entries) {
  std::vector<std::byte> columns;
  columns.reserve(entries.size() * (kColumnBytesPerEntry + kColumnBytesPerPayload));
  put_entry_columns(columns, entries);
  std::uint64_t end = kHeaderSize;  // where the previous brick payload ended
  put_column<std::uint64_t>(columns, entries, true, [&end](const BrickEntry& e) {
    const std::uint64_t expected = packed_offset(end, e.kind);
    if (e.offset < expected)  // the writer appends in index order, so offsets only grow
      throw Error(fmt::format("internal error: {} at offset {} precedes the end of the previous payload", brick_name(e.key),
                              e.offset));
    end = e.offset + e.size;
    return e.offset - expected;
  });
  put_column<std::uint32_t>(columns, entries, true, [](const BrickEntry& e) { return e.crc32c; });

  const std::vector<std::byte> frame = zstd_compress(columns, kIndexZstdLevel);
  std::vector<std::byte> stored(kIndexSizeField + frame.size());
  store_field(stored, 0, std::uint64_t(frame.size()));
  std::copy(frame.begin(), frame.end(), stored.begin() + kIndexSizeField);
  return stored;
}

// Takes the columns of encode_compressed_index back in order; the caller has checked the sizes.
class ColumnReader {
 public:
  explicit ColumnReader(std::span<const std::byte> bytes) : bytes_(bytes) {}
  template <class T>
  std::vector<T> take(std::size_t n) {
    std::vector<T> column(n);
    merge_byte_planes(bytes_.subspan(at_, n * sizeof(T)), std::as_writable_bytes(std::span(column)), sizeof(T));
    at_ += n * sizeof(T);
    return column;
  }

 private:
  std::span<const std::byte> bytes_;
  std::size_t at_ = 0;
};

// Format 1.3's binding record (docs/format.md, "Checksums"): what a payload's check value covers
// after the payload bytes.
//
// | offset | type | field                                    |
// | ------ | ---- | ---------------------------------------- |
// | 0      | u8   | level                                    |
// | 1      | u8   | kind                                     |
// | 2      | u16  | 0                                        |
// | 4      | i32  | x                                        |
// | 8      | i32  | y                                        |
// | 12     | i32  | z                                        |
// | 16     | u32  | metadata_crc32c (the header's field)     |
constexpr std::size_t kBindingRecordSize = 20;

std::array<std::byte, kBindingRecordSize> binding_record(const BrickKey& key, PayloadKind kind, std::uint32_t metadata_crc) {
  std::array<std::byte, kBindingRecordSize> r{};
  store_field(r, 0, key.level);
  store_field(r, 1, std::uint8_t(kind));
  store_field(r, 4, key.x);
  store_field(r, 8, key.y);
  store_field(r, 12, key.z);
  store_field(r, 16, metadata_crc);
  return r;
}

}  // namespace

std::uint32_t payload_check_value(std::uint32_t payload_crc, std::uint64_t size, const BrickKey& key, PayloadKind kind,
                                  std::uint32_t metadata_crc) {
  if (size == 0) return 0;
  const auto record = binding_record(key, kind, metadata_crc);
  return crc32c(record.data(), record.size(), payload_crc);
}

std::uint32_t section_check_value(std::span<const std::byte> bytes, const std::string& name) {
  std::array<std::byte, 4> length{};
  store_field(length, 0, std::uint32_t(name.size()));
  std::uint32_t crc = crc32c(bytes.data(), bytes.size());
  crc = crc32c(name.data(), name.size(), crc);
  return crc32c(length.data(), length.size(), crc);
}

std::uint32_t container_section_check_value(std::span<const std::byte> head, const std::string& name, std::uint64_t size) {
  std::array<std::byte, 8> length{};
  store_field(length, 0, size);
  return crc32c(length.data(), length.size(), section_check_value(head.first(std::min(head.size(), kContainerSectionHead)), name));
}

std::uint32_t bricks_check_value(std::span<const BrickEntry> entries) {
  std::vector<std::byte> columns;
  columns.reserve(entries.size() * kColumnBytesPerEntry);
  put_entry_columns(columns, entries);
  return crc32c(columns.data(), columns.size());
}

std::string brick_name(const BrickKey& k) { return fmt::format("brick (level {}, {},{},{})", int(k.level), k.x, k.y, k.z); }

const PayloadKindTraits& payload_kind_traits(PayloadKind kind) {
  const PayloadKindTraits* traits = find_payload_kind(std::uint8_t(kind));
  if (traits == nullptr) throw Error(fmt::format("unknown payload kind {}", int(kind)));
  return *traits;
}

const char* payload_kind_name(PayloadKind kind) {
  const PayloadKindTraits* traits = find_payload_kind(std::uint8_t(kind));
  return traits != nullptr ? traits->name.data() : "unknown";
}

// Unknown kinds (read from a damaged index before check_entry names them) are packed.
bool needs_alignment(PayloadKind kind) {
  const PayloadKindTraits* traits = find_payload_kind(std::uint8_t(kind));
  return traits != nullptr && traits->aligned;
}

// ---------------------------------------------------------------------------------------------
// Writer

ContainerWriter::ContainerWriter(const std::filesystem::path& path)
    : out_(std::make_unique<io::AtomicOutputFile>(path)) {
  std::array<std::byte, kHeaderSize> placeholder{};  // rewritten by finish()
  out_->write(placeholder.data(), placeholder.size());
  position_ = kHeaderSize;
}

ContainerWriter::~ContainerWriter() = default;

std::uint64_t ContainerWriter::append(std::span<const std::byte> payload, bool aligned) {
  static const std::array<std::byte, kPayloadAlignment> zeros{};
  const std::uint64_t offset = aligned ? align_up(position_) : position_;
  if (offset > position_) out_->write(zeros.data(), offset - position_);
  if (!payload.empty()) out_->write(payload.data(), payload.size());
  position_ = offset + payload.size();
  return offset;
}

void ContainerWriter::add_brick(BrickEntry entry, std::span<const std::byte> payload) {
  // The payload's own CRC-32C; finish() continues it over the binding record, whose metadata
  // checksum is known only then.
  entry.crc32c = crc32c(payload.data(), payload.size());
  entry.size = payload.size();
  std::lock_guard lock(mutex_);
  // Entries are pushed in the order their payloads are appended: the compressed index relies on
  // offsets growing along the index.
  entry.offset = payload.empty() ? 0 : append(payload, needs_alignment(entry.kind));
  entries_.push_back(entry);
}

void ContainerWriter::add_section(const std::string& name, std::span<const std::byte> payload) {
  Section s{0, payload.size(), section_check_value(payload, name)};
  std::lock_guard lock(mutex_);
  s.offset = append(payload, true);
  sections_.emplace_back(name, s);
}

void ContainerWriter::add_container_section(const std::string& name, std::span<const std::byte> container) {
  Section s{0, container.size(), container_section_check_value(container, name, container.size()), true};
  std::lock_guard lock(mutex_);
  s.offset = append(container, true);
  sections_.emplace_back(name, s);
}

std::uint64_t ContainerWriter::bytes_written() const {
  std::lock_guard lock(mutex_);
  return position_;
}

std::uint64_t ContainerWriter::finish(nlohmann::json metadata) {
  std::lock_guard lock(mutex_);
  nlohmann::json sections = nlohmann::json::object();
  for (const auto& [name, s] : sections_) {
    sections[name] = {{"offset", s.offset}, {"size", s.size}, {"crc32c", s.crc32c}};
    if (s.container) sections[name]["container"] = true;
  }
  metadata["sections"] = sections;
  metadata["bricks_crc32c"] = bricks_check_value(entries_);
  const std::string text = metadata.dump();
  Header h;
  h.metadata_size = text.size();
  h.metadata_crc = crc32c(text.data(), text.size());
  h.metadata_offset = append(std::as_bytes(std::span(text)), true);
  for (BrickEntry& e : entries_) e.crc32c = payload_check_value(e.crc32c, e.size, e.key, e.kind, h.metadata_crc);

  const std::vector<std::byte> index = encode_compressed_index(entries_);
  h.flags = kFlagCompressedIndex;
  h.index_count = entries_.size();
  h.index_crc = crc32c(index.data(), index.size());
  h.index_offset = append(index, true);

  auto header = encode_header(h);
  std::FILE* f = out_->handle();
  if (std::fflush(f) != 0 || std::fseek(f, 0, SEEK_SET) != 0 || std::fwrite(header.data(), 1, header.size(), f) != header.size())
    throw Error(fmt::format("{}: cannot write the header", out_->path().string()));
  out_->commit();
  return position_;
}

// ---------------------------------------------------------------------------------------------
// Reader

void ContainerReader::check_range(std::uint64_t offset, std::uint64_t size, const std::string& what) const {
  if (offset > size_ || size > size_ - offset)
    throw FormatError(name_, what, fmt::format("range [{}, +{}) lies outside the {}-byte file (truncated?)", offset, size, size_));
}

// Checked, then from the tail read while opening when it holds the range, else from the source.
io::SharedBytes ContainerReader::read_range(std::uint64_t offset, std::uint64_t size, const std::string& what) const {
  check_range(offset, size, what);
  if (offset >= tail_offset_ && offset - tail_offset_ <= tail_.size() && size <= tail_.size() - (offset - tail_offset_))
    return tail_.subrange(offset - tail_offset_, size);
  return source_->read(offset, size);
}

ContainerReader::ContainerReader(const std::filesystem::path& path)
    : path_(path), name_(path.string()), source_(io::open_byte_source(path)) {
  open();
}

ContainerReader::ContainerReader(const ContainerReader& outer, const std::string& section, std::string name)
    : path_(outer.path_), name_(std::move(name)) {
  // The outer reader checked that the range lies inside the file, and checks here that the
  // section is the one its name says; the member's own checksums (header, metadata, index, every
  // payload, its sections) protect the rest of its bytes.
  const Section& s = outer.container_section(section);
  source_ = io::byte_subrange(outer.source_, s.offset, s.size, name_);
  open();
}

// The section `name` verified as one holding a container, before it is opened in place. Format
// 1.6: it is marked as a container and its check value covers its header (whose own checksum
// covers the container's metadata and index checksums, and through them everything else), its
// name and its size, so only the header is read. Before 1.6 its check value covers all its bytes.
const Section& ContainerReader::container_section(const std::string& name) const {
  const auto it = sections_.find(name);
  if (it == sections_.end()) throw FormatError(name_, "sections", "no section named '" + name + "'");
  const Section& s = it->second;
  if (minor_ < kBoundIndexMinor) {
    section(name);
    return s;
  }
  if (!s.container)
    throw FormatError(name_, "metadata.sections." + name + ".container",
                      fmt::format("missing: section {} holds a whole .strata file, and a format 1.{} file marks such a "
                                  "section with \"container\": true (its check value covers the container's header)",
                                  name, minor_));
  const io::SharedBytes head = read_range(s.offset, std::min<std::uint64_t>(s.size, kContainerSectionHead), "section " + name);
  check_section_value(name, s, container_section_check_value(head, name, s.size));
  return s;
}

// The writer puts the metadata and then the index at the end of the file (format.md), so one
// read from the metadata to the end fetches both: a remote file opens in two requests (the
// header's, this). A file laid out otherwise (or whose tail is longer than any index of `count`
// entries could be) is read field by field.
void ContainerReader::read_tail(std::uint64_t metadata_offset, std::uint64_t index_offset, std::uint64_t count) {
  if (metadata_offset > size_ || index_offset > size_ || index_offset < metadata_offset) return;
  if (index_offset - metadata_offset > metadata_size_ + kPayloadAlignment) return;
  // A compressed index is at most its columns plus zstd's framing of incompressible data.
  constexpr std::uint64_t kFrameSlack = 4096;
  if (size_ - index_offset > saturating_mul(count, kIndexEntrySize) + kIndexSizeField + kFrameSlack) return;
  tail_offset_ = metadata_offset;
  tail_ = source_->read(metadata_offset, size_ - metadata_offset);
}

void ContainerReader::open() {
  const std::string& file = name_;
  size_ = source_->size();
  const io::SharedBytes head = source_->read(0, std::min<std::uint64_t>(size_, kHeaderSize));
  if (head.size() < kMagic.size() || std::memcmp(head.data(), kMagic.data(), kMagic.size()) != 0)
    throw FormatError(file, "magic", "not a .strata file");
  if (head.size() < kHeaderSize)
    throw FormatError(file, "header",
                      fmt::format("the file ends after {} bytes, inside the {}-byte header (truncated)", size_, kHeaderSize));
  const std::span<const std::byte> h = head.span();
  if (load_field<std::uint32_t>(h, 60) != crc32c(h.data(), 60)) throw FormatError(file, "header", "checksum mismatch");
  const auto major = load_field<std::uint16_t>(h, 8);
  if (major != kFormatVersionMajor)
    throw FormatError(file, "version", fmt::format("format version {} is not supported (expected {})", major, kFormatVersionMajor));
  // Minor versions are not rejected: additions that older readers cannot ignore set a flag bit
  // or use a new payload kind, and both are rejected below. The minor version decides which
  // checksum rule applies (1.3: bound to keys, kinds and names).
  minor_ = load_field<std::uint16_t>(h, 10);
  const auto flags = load_field<std::uint32_t>(h, 12);
  if ((flags & ~kKnownFlags) != 0)
    throw FormatError(file, "flags",
                      fmt::format("unknown bits {:#x} set (this reader knows bit 0, compressed index)", flags & ~kKnownFlags));
  index_compressed_ = (flags & kFlagCompressedIndex) != 0;
  if (index_compressed_ && minor_ < 2)
    throw FormatError(file, "flags", fmt::format("bit 0 (compressed index) is set in a format 1.{} file; it needs 1.2", minor_));
  if (load_field<std::uint32_t>(h, 48) != kIndexEntrySize)
    throw FormatError(file, "index_entry_size", fmt::format("expected {}", kIndexEntrySize));

  metadata_size_ = load_field<std::uint64_t>(h, 40);
  metadata_crc_ = load_field<std::uint32_t>(h, 52);
  const auto metadata_offset = load_field<std::uint64_t>(h, 32), index_offset = load_field<std::uint64_t>(h, 16);
  check_range(metadata_offset, metadata_size_, "metadata");
  read_tail(metadata_offset, index_offset, load_field<std::uint64_t>(h, 24));
  const io::SharedBytes meta = read_range(metadata_offset, metadata_size_, "metadata");
  if (crc32c(meta.data(), meta.size()) != metadata_crc_) throw FormatError(file, "metadata", "checksum mismatch");
  try {
    metadata_ = nlohmann::json::parse(reinterpret_cast<const char*>(meta.data()),
                                      reinterpret_cast<const char*>(meta.data()) + meta.size());
  } catch (const nlohmann::json::exception& e) {
    throw FormatError(file, "metadata", "invalid JSON (" + io::json_error_reason(e) + ")");
  }
  if (!metadata_.is_object())
    throw FormatError(file, "metadata", "expected a JSON object, got " + std::string(metadata_.type_name()));

  const auto count = load_field<std::uint64_t>(h, 24);
  const auto index_crc = load_field<std::uint32_t>(h, 56);
  std::vector<BrickEntry> entries = index_compressed_ ? read_compressed_index(index_offset, count, index_crc)
                                                      : read_plain_index(index_offset, count, index_crc);
  lookup_.reserve(entries.size());
  for (std::size_t i = 0; i < entries.size(); ++i) {
    check_entry(entries[i]);
    if (!lookup_.emplace(entries[i].key, i).second) throw FormatError(file, "index", brick_name(entries[i].key) + " appears twice");
  }
  entries_ = std::move(entries);
  read_sections();
  if (minor_ >= kBoundIndexMinor) check_bricks();
  tail_ = {};  // payloads and sections are read from the source, with its cache
}

void ContainerReader::check_index_fits_memory(std::uint64_t count) const {
  const std::uint64_t memory = physical_memory_bytes();
  if (memory == 0) return;  // the system does not say; the frame and file size bounds still hold
  const std::uint64_t needed = saturating_mul(count, kOpenBytesPerEntry), allowed = memory / kIndexMemoryShareDivisor;
  if (needed > allowed)
    throw FormatError(name_, "index_count",
                      fmt::format("{} entries would take {:.1f} GiB to open, more than half of this machine's {:.1f} GiB "
                                  "(a corrupt or hostile header, or a volume too large for this machine)",
                                  count, double(needed) / double(1ull << 30), double(memory) / double(1ull << 30)));
}

// An index entry the payload kinds table allows: a known kind, a range inside the file, and for
// a constant brick no payload bytes and min == max (the value every voxel has).
void ContainerReader::check_entry(const BrickEntry& e) const {
  const std::string file = name_;
  if (!known_kind(e.kind))
    throw FormatError(file, "index", fmt::format("{} has unknown payload kind {}", brick_name(e.key), int(e.kind)));
  check_range(e.offset, e.size, brick_name(e.key));
  if (e.kind == PayloadKind::constant && e.size != 0)
    throw FormatError(file, brick_name(e.key),
                      fmt::format("a constant brick has no payload, but the index gives it {} bytes", e.size));
  if (e.kind == PayloadKind::constant && !(e.min == e.max) && !(std::isnan(e.min) && std::isnan(e.max)))
    throw FormatError(file, brick_name(e.key),
                      fmt::format("a constant brick needs min == max (its value), got min {} and max {}", e.min, e.max));
}

// Format 1.6: metadata.bricks_crc32c is the check value of the index's entries without their
// offsets and check values. Those are covered by the payloads' check values, which cover the
// metadata's checksum, so an edited min, max or histogram (or any key, kind or size) fails here,
// and fixing bricks_crc32c too fails every payload.
void ContainerReader::check_bricks() const {
  const MetadataField field{name_, "metadata.bricks_crc32c"};
  const auto it = metadata_.find("bricks_crc32c");
  if (it == metadata_.end())
    field.fail(fmt::format("missing (a format 1.{} file keeps the check value of its brick index here)", minor_));
  const auto stored = std::uint32_t(json_unsigned(*it, field, UINT32_MAX));
  const std::uint32_t computed = bricks_check_value(entries_);
  if (computed != stored)
    throw FormatError(name_, "index",
                      fmt::format("the bricks' keys, kinds, sizes, min, max and histograms give check value {:#010x}, but "
                                  "metadata.bricks_crc32c is {:#010x} (the index or the metadata was altered)",
                                  computed, stored));
}

// "sections": {"<name>": {"offset": u64, "size": u64, "crc32c": u32, "container": bool (1.6,
// optional)}, ...}, every range inside the file.
void ContainerReader::read_sections() {
  const auto it = metadata_.find("sections");
  if (it == metadata_.end()) return;
  const MetadataField field{name_, "metadata.sections"};
  for (const auto& [name, s] : json_object(*it, field).items()) {
    const MetadataField at = field / name;
    json_object(s, at);
    Section sec{json_unsigned(json_member(s, "offset", at), at / "offset"), json_unsigned(json_member(s, "size", at), at / "size"),
                std::uint32_t(json_unsigned(json_member(s, "crc32c", at), at / "crc32c", UINT32_MAX))};
    check_range(sec.offset, sec.size, "section " + name);
    if (minor_ >= kBoundIndexMinor && s.contains("container")) sec.container = json_bool(s["container"], at / "container");
    sections_[name] = sec;
  }
}

ContainerReader::~ContainerReader() = default;

// Format 1.0/1.1 (and 1.2 without flag bit 0): count entries of 64 bytes.
std::vector<BrickEntry> ContainerReader::read_plain_index(std::uint64_t offset, std::uint64_t count, std::uint32_t crc) {
  if (count > size_ / kIndexEntrySize) throw FormatError(name_, "index_count", "larger than the file");
  check_index_fits_memory(count);
  index_size_ = count * kIndexEntrySize;
  const io::SharedBytes bytes = read_range(offset, index_size_, "index");
  const std::span<const std::byte> index = bytes.span();
  if (crc32c(index.data(), index.size()) != crc) throw FormatError(name_, "index", "checksum mismatch");
  std::vector<BrickEntry> entries;
  entries.reserve(count);
  for (std::uint64_t i = 0; i < count; ++i) entries.push_back(decode_entry(index.subspan(i * kIndexEntrySize).first<kIndexEntrySize>()));
  return entries;
}

// Format 1.2 with flag bit 0: see encode_compressed_index. Offsets are derived (and their ranges
// checked) here; kinds and keys are checked by the constructor, as for the plain index.
std::vector<BrickEntry> ContainerReader::read_compressed_index(std::uint64_t offset, std::uint64_t count, std::uint32_t crc) {
  const std::string file = name_;
  const io::SharedBytes size_field = read_range(offset, kIndexSizeField, "index");
  const auto frame_size = load_field<std::uint64_t>(size_field.span(), 0);
  check_range(offset + kIndexSizeField, frame_size, "index");
  index_size_ = kIndexSizeField + frame_size;
  const io::SharedBytes index = read_range(offset, index_size_, "index");
  const std::span<const std::byte> frame = index.span().subspan(kIndexSizeField);
  if (crc32c(index.data(), index.size()) != crc) throw FormatError(file, "index", "checksum mismatch");
  if (count > saturating_mul(frame_size, kZstdMaxExpansion) / kColumnBytesPerEntry)
    throw FormatError(file, "index_count",
                      fmt::format("{} entries need {} bytes of columns each, more than a {}-byte zstd frame can "
                                  "inflate to ({} per byte at most)",
                                  count, kColumnBytesPerEntry, frame_size, kZstdMaxExpansion));
  check_index_fits_memory(count);
  std::vector<std::byte> columns;
  zstd_decompress(frame, saturating_mul(count, kColumnBytesPerEntry + kColumnBytesPerPayload), columns, file, "index");
  const auto wrong_size = [&](std::uint64_t expected) {
    return FormatError(file, "index",
                       fmt::format("columns of {} bytes, expected {} for index_count {}", columns.size(), expected, count));
  };
  if (columns.size() < count * kColumnBytesPerEntry) throw wrong_size(count * kColumnBytesPerEntry);
  ColumnReader in(columns);
  const auto levels = in.take<std::uint8_t>(count), kinds = in.take<std::uint8_t>(count);
  const auto xs = in.take<std::int32_t>(count), ys = in.take<std::int32_t>(count), zs = in.take<std::int32_t>(count);
  const auto sizes = in.take<std::uint64_t>(count);
  const auto mins = in.take<float>(count), maxs = in.take<float>(count);
  const auto histograms = in.take<std::uint64_t>(count);
  const auto with_payload = std::uint64_t(std::count_if(sizes.begin(), sizes.end(), [](std::uint64_t s) { return s != 0; }));
  const std::uint64_t expected = count * kColumnBytesPerEntry + with_payload * kColumnBytesPerPayload;
  if (columns.size() != expected) throw wrong_size(expected);
  const auto gaps = in.take<std::uint64_t>(with_payload);
  const auto crcs = in.take<std::uint32_t>(with_payload);

  std::vector<BrickEntry> entries(count);
  std::uint64_t end = kHeaderSize, payload = 0;
  for (std::size_t i = 0; i < count; ++i) {
    BrickEntry& e = entries[i];
    e.key = {levels[i], xs[i], ys[i], zs[i]};
    e.kind = PayloadKind(kinds[i]);
    e.size = sizes[i];
    e.min = mins[i];
    e.max = maxs[i];
    e.histogram = histograms[i];
    if (e.size == 0) continue;  // offset 0, crc32c of nothing: 0
    // `end` lies inside the file (the previous range was checked) and the gap is bounded by the
    // file size, so a hostile gap cannot wrap the offset around to an earlier position.
    if (gaps[payload] > size_)
      throw FormatError(file, brick_name(e.key), fmt::format("offset gap {} lies outside the {}-byte file", gaps[payload], size_));
    e.offset = packed_offset(end, e.kind) + gaps[payload];
    e.crc32c = crcs[payload++];
    check_range(e.offset, e.size, brick_name(e.key));
    end = e.offset + e.size;
  }
  return entries;
}

const BrickEntry* ContainerReader::find(const BrickKey& key) const {
  auto it = lookup_.find(key);
  return it == lookup_.end() ? nullptr : &entries_[it->second];
}

io::SharedBytes ContainerReader::payload(const BrickEntry& e) const {
  io::SharedBytes bytes = read_range(e.offset, e.size, brick_name(e.key));
  std::uint32_t check = crc32c(bytes.data(), bytes.size());
  if (minor_ >= kBoundChecksumsMinor) check = payload_check_value(check, e.size, e.key, e.kind, metadata_crc_);
  if (check != e.crc32c)
    throw FormatError(name_, brick_name(e.key),
                      minor_ >= kBoundChecksumsMinor
                          ? "payload checksum mismatch (the payload is corrupted, or its index entry or the metadata "
                            "was altered: the checksum covers the bytes, the key, the kind and the metadata)"
                          : "payload checksum mismatch (file corrupted)");
  return bytes;
}

void ContainerReader::prefetch(std::span<const BrickEntry* const> entries) const {
  if (!source_->remote()) return;
  std::vector<io::ByteRange> ranges;
  ranges.reserve(entries.size());
  for (const BrickEntry* e : entries)
    if (e && e->size != 0) ranges.push_back({e->offset, e->size});
  source_->prefetch(ranges);
}

bool ContainerReader::has_section(const std::string& name) const { return sections_.count(name) != 0; }

io::SharedBytes ContainerReader::section(const std::string& name) const {
  auto it = sections_.find(name);
  if (it == sections_.end()) throw FormatError(name_, "sections", "no section named '" + name + "'");
  const Section& s = it->second;
  io::SharedBytes bytes = read_range(s.offset, s.size, "section " + name);
  check_section_value(name, s,
                      s.container                      ? container_section_check_value(bytes, name, s.size)
                      : minor_ >= kBoundChecksumsMinor ? section_check_value(bytes, name)
                                                       : crc32c(bytes.data(), bytes.size()));
  return bytes;
}

// `computed` is the check value of section `name` by the rule of its kind and this file's version.
void ContainerReader::check_section_value(const std::string& name, const Section& s, std::uint32_t computed) const {
  if (computed == s.crc32c) return;
  const char* covers = s.container                      ? "the header of the container it holds, its name and its size"
                       : minor_ >= kBoundChecksumsMinor ? "its bytes and its name"
                                                        : "its bytes";
  throw FormatError(name_, "section " + name,
                    fmt::format("checksum mismatch: metadata.sections.{}.crc32c is {:#010x}, expected {:#010x} from {} (the "
                                "section is damaged or replaced, or its entry belongs to another section)",
                                name, s.crc32c, computed, covers));
}

std::uint64_t ContainerReader::file_size() const { return size_; }

bool is_strata_file(const std::filesystem::path& path) {
  if (io::is_url(path.string())) return !io::is_remote_volume(path.string());
  std::ifstream in(path, std::ios::binary);
  std::array<char, 8> head{};
  return in.read(head.data(), head.size()) && std::memcmp(head.data(), kMagic.data(), kMagic.size()) == 0;
}

}  // namespace strata::store

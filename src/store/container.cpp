#include "strata/store/container.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <fstream>

#include <fmt/format.h>

#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"
#include "strata/store/crc32c.hpp"

namespace strata::store {

namespace {

// "\x89STRATA\n": the high byte catches 7-bit transfers, the newline catches text-mode
// line-ending conversion (the trick PNG uses).
constexpr std::array<unsigned char, 8> kMagic{0x89, 'S', 'T', 'R', 'A', 'T', 'A', '\n'};


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

void encode_entry(const BrickEntry& e, std::span<std::byte, kIndexEntrySize> b) {
  std::fill(b.begin(), b.end(), std::byte{0});
  store_field(b, 0, e.key.level);
  store_field(b, 1, std::uint8_t(e.kind));
  store_field(b, 4, e.crc32c);
  store_field(b, 8, e.key.x);
  store_field(b, 12, e.key.y);
  store_field(b, 16, e.key.z);
  store_field(b, 24, e.offset);
  store_field(b, 32, e.size);
  store_field(b, 40, e.min);
  store_field(b, 44, e.max);
  store_field(b, 48, e.histogram);
}

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

bool known_kind(PayloadKind k) {
  return k == PayloadKind::constant || k == PayloadKind::tucker || k == PayloadKind::tucker_zstd ||
         k == PayloadKind::tucker_coded || k == PayloadKind::raw_zstd;
}

}  // namespace

std::string brick_name(const BrickKey& k) { return fmt::format("brick (level {}, {},{},{})", int(k.level), k.x, k.y, k.z); }

const char* payload_kind_name(PayloadKind k) {
  switch (k) {
    case PayloadKind::constant: return "constant";
    case PayloadKind::tucker: return "tucker";
    case PayloadKind::tucker_zstd: return "tucker_zstd";
    case PayloadKind::tucker_coded: return "tucker_coded";
    case PayloadKind::raw_zstd: return "raw_zstd";
  }
  return "unknown";
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

std::uint64_t ContainerWriter::append_aligned(std::span<const std::byte> payload) {
  static const std::array<std::byte, kPayloadAlignment> zeros{};
  const std::uint64_t pad = (kPayloadAlignment - position_ % kPayloadAlignment) % kPayloadAlignment;
  if (pad) out_->write(zeros.data(), pad);
  const std::uint64_t offset = position_ + pad;
  if (!payload.empty()) out_->write(payload.data(), payload.size());
  position_ = offset + payload.size();
  return offset;
}

void ContainerWriter::add_brick(BrickEntry entry, std::span<const std::byte> payload) {
  entry.crc32c = crc32c(payload.data(), payload.size());
  entry.size = payload.size();
  std::lock_guard lock(mutex_);
  entry.offset = payload.empty() ? 0 : append_aligned(payload);
  entries_.push_back(entry);
}

void ContainerWriter::add_section(const std::string& name, std::span<const std::byte> payload) {
  Section s{0, payload.size(), crc32c(payload.data(), payload.size())};
  std::lock_guard lock(mutex_);
  s.offset = append_aligned(payload);
  sections_.emplace_back(name, s);
}

std::uint64_t ContainerWriter::bytes_written() const {
  std::lock_guard lock(mutex_);
  return position_;
}

std::uint64_t ContainerWriter::finish(nlohmann::json metadata) {
  std::lock_guard lock(mutex_);
  nlohmann::json sections = nlohmann::json::object();
  for (const auto& [name, s] : sections_) sections[name] = {{"offset", s.offset}, {"size", s.size}, {"crc32c", s.crc32c}};
  metadata["sections"] = sections;
  const std::string text = metadata.dump();
  Header h;
  h.metadata_size = text.size();
  h.metadata_crc = crc32c(text.data(), text.size());
  h.metadata_offset = append_aligned(std::as_bytes(std::span(text)));

  std::vector<std::byte> index(entries_.size() * kIndexEntrySize);
  for (std::size_t i = 0; i < entries_.size(); ++i) encode_entry(entries_[i], std::span(index).subspan(i * kIndexEntrySize).first<kIndexEntrySize>());
  h.index_count = entries_.size();
  h.index_crc = crc32c(index.data(), index.size());
  h.index_offset = append_aligned(index);

  auto header = encode_header(h);
  std::FILE* f = out_->handle();
  if (std::fflush(f) != 0 || std::fseek(f, 0, SEEK_SET) != 0 || std::fwrite(header.data(), 1, header.size(), f) != header.size())
    throw Error(fmt::format("{}: cannot write the header", out_->path().string()));
  out_->commit();
  return position_;
}

// ---------------------------------------------------------------------------------------------
// Reader

std::span<const std::byte> ContainerReader::checked_range(std::uint64_t offset, std::uint64_t size,
                                                          const std::string& what) const {
  if (offset > file_->size() || size > file_->size() - offset)
    throw FormatError(path_.string(), what,
                      fmt::format("range [{}, +{}) lies outside the {}-byte file (truncated?)", offset, size, file_->size()));
  return {file_->data() + offset, std::size_t(size)};
}

ContainerReader::ContainerReader(const std::filesystem::path& path)
    : path_(path), file_(std::make_shared<io::MappedFile>(path)) {
  const std::string file = path.string();
  if (file_->size() < kHeaderSize || std::memcmp(file_->data(), kMagic.data(), kMagic.size()) != 0)
    throw FormatError(file, "magic", "not a .strata file");
  const std::span<const std::byte> h(file_->data(), kHeaderSize);
  if (load_field<std::uint32_t>(h, 60) != crc32c(h.data(), 60)) throw FormatError(file, "header", "checksum mismatch");
  const auto major = load_field<std::uint16_t>(h, 8);
  if (major != kFormatVersionMajor)
    throw FormatError(file, "version", fmt::format("format version {} is not supported (expected {})", major, kFormatVersionMajor));
  if (load_field<std::uint32_t>(h, 48) != kIndexEntrySize)
    throw FormatError(file, "index_entry_size", fmt::format("expected {}", kIndexEntrySize));

  metadata_size_ = load_field<std::uint64_t>(h, 40);
  auto meta = checked_range(load_field<std::uint64_t>(h, 32), metadata_size_, "metadata");
  if (crc32c(meta.data(), meta.size()) != load_field<std::uint32_t>(h, 52)) throw FormatError(file, "metadata", "checksum mismatch");
  try {
    metadata_ = nlohmann::json::parse(reinterpret_cast<const char*>(meta.data()),
                                      reinterpret_cast<const char*>(meta.data()) + meta.size());
  } catch (const nlohmann::json::exception& e) {
    throw FormatError(file, "metadata", std::string("invalid JSON: ") + e.what());
  }

  const auto count = load_field<std::uint64_t>(h, 24);
  if (count > file_->size() / kIndexEntrySize) throw FormatError(file, "index_count", "larger than the file");
  auto index = checked_range(load_field<std::uint64_t>(h, 16), count * kIndexEntrySize, "index");
  if (crc32c(index.data(), index.size()) != load_field<std::uint32_t>(h, 56)) throw FormatError(file, "index", "checksum mismatch");
  entries_.reserve(count);
  for (std::uint64_t i = 0; i < count; ++i) {
    BrickEntry e = decode_entry(index.subspan(i * kIndexEntrySize).first<kIndexEntrySize>());
    if (!known_kind(e.kind))
      throw FormatError(file, "index", fmt::format("{} has unknown payload kind {}", brick_name(e.key), int(e.kind)));
    checked_range(e.offset, e.size, brick_name(e.key));
    if (!lookup_.emplace(e.key, entries_.size()).second)
      throw FormatError(file, "index", brick_name(e.key) + " appears twice");
    entries_.push_back(e);
  }
  if (metadata_.contains("sections"))
    for (const auto& [name, s] : metadata_["sections"].items()) {
      Section sec{s.at("offset").get<std::uint64_t>(), s.at("size").get<std::uint64_t>(), s.at("crc32c").get<std::uint32_t>()};
      checked_range(sec.offset, sec.size, "section " + name);
      sections_[name] = sec;
    }
}

ContainerReader::~ContainerReader() = default;

const BrickEntry* ContainerReader::find(const BrickKey& key) const {
  auto it = lookup_.find(key);
  return it == lookup_.end() ? nullptr : &entries_[it->second];
}

std::span<const std::byte> ContainerReader::payload(const BrickEntry& e) const {
  auto bytes = checked_range(e.offset, e.size, brick_name(e.key));
  if (crc32c(bytes.data(), bytes.size()) != e.crc32c)
    throw FormatError(path_.string(), brick_name(e.key), "payload checksum mismatch (file corrupted)");
  return bytes;
}

bool ContainerReader::has_section(const std::string& name) const { return sections_.count(name) != 0; }

std::span<const std::byte> ContainerReader::section(const std::string& name) const {
  auto it = sections_.find(name);
  if (it == sections_.end()) throw FormatError(path_.string(), "sections", "no section named '" + name + "'");
  auto bytes = checked_range(it->second.offset, it->second.size, "section " + name);
  if (crc32c(bytes.data(), bytes.size()) != it->second.crc32c)
    throw FormatError(path_.string(), "section " + name, "checksum mismatch (file corrupted)");
  return bytes;
}

std::uint64_t ContainerReader::file_size() const { return file_->size(); }

bool is_strata_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::array<char, 8> head{};
  return in.read(head.data(), head.size()) && std::memcmp(head.data(), kMagic.data(), kMagic.size()) == 0;
}

}  // namespace strata::store

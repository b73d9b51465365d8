// Zip stores: the central directory once, members by offset (PKWARE APPNOTE 6.3).
//
// Records read (little-endian):
// | record                          | signature  | fields used                                       |
// | ------------------------------- | ---------- | ------------------------------------------------- |
// | end of central directory        | 0x06054b50 | entries (@10, u16), size (@12, u32), offset (@16, |
// |                                 |            | u32); found in the last 64 KiB + 22 bytes         |
// | zip64 end of central dir locator| 0x07064b50 | the zip64 record's offset (@8, u64), 20 bytes     |
// |                                 |            | before the end record                             |
// | zip64 end of central directory  | 0x06064b50 | entries (@32, u64), size (@40), offset (@48)      |
// | central directory header        | 0x02014b50 | flags (@8), method (@10: 0 stored, 8 deflate),     |
// |                                 |            | crc32 (@16), compressed (@20) and plain (@24)     |
// |                                 |            | sizes, name (@28), extra (@30) and comment (@32)   |
// |                                 |            | lengths, local header offset (@42), name (@46)    |
// | zip64 extra field (id 0x0001)   |            | plain size, compressed size, local header offset:  |
// |                                 |            | those of the header that are 0xffffffff, in order |
// | local file header               | 0x04034b50 | name (@26) and extra (@28) lengths: data at 30 +   |
// |                                 |            | both                                              |
//
// Refused (FormatError naming the zip and the field): encrypted members (flag bit 0), methods
// other than stored and deflate, several disks, records or data outside the file, sizes that
// overflow, stored members whose sizes differ, deflate data that decodes to another size than
// the directory says, crc32 mismatches on whole-member reads. Directory entries (names ending in
// "/") are skipped. A zip whose members all sit in one top folder (`zip -r x.zarr.zip x.zarr`)
// has that folder as its root.
#include "io/zarr/zip_store.hpp"

#include <algorithm>
#include <set>
#include <unordered_map>

#include <fmt/format.h>
#include <zlib.h>

#include "io/zarr/zarr_array.hpp"
#include "strata/core/bytes.hpp"
#include "strata/core/checked.hpp"
#include "strata/core/error.hpp"
#include "strata/io/files.hpp"

namespace strata::io::detail {

namespace {

namespace fs = std::filesystem;

constexpr std::uint32_t kEndSignature = 0x06054b50, kZip64LocatorSignature = 0x07064b50,
                        kZip64EndSignature = 0x06064b50, kCentralSignature = 0x02014b50,
                        kLocalSignature = 0x04034b50;
constexpr std::uint64_t kEndBytes = 22, kZip64LocatorBytes = 20, kZip64EndBytes = 56, kCentralBytes = 46,
                        kLocalBytes = 30, kMaxComment = 0xFFFF;
constexpr std::uint32_t kSaturated32 = 0xFFFFFFFFu;
constexpr std::uint16_t kZip64ExtraId = 0x0001, kStored = 0, kDeflated = 8;

struct Member {
  std::uint64_t local_offset = 0, compressed = 0, plain = 0;
  std::uint32_t crc = 0;
  std::uint16_t method = kStored;
};

// Where the central directory is and how many entries it declares.
struct Directory {
  std::uint64_t offset = 0, size = 0, entries = 0;
};

class ZipStore final : public ZarrStore {
 public:
  explicit ZipStore(const fs::path& path) : path_(path.string()), file_(path) {
    index(find_directory());
    root_ = common_root();
  }

  std::optional<std::uint64_t> size(const std::string& key) const override {
    const Member* m = find(key);
    return m ? std::optional(m->plain) : std::nullopt;
  }

  std::vector<std::byte> read(const std::string& key, std::uint64_t offset, std::uint64_t length,
                              const std::string& field) const override {
    const Member* m = find(key);
    if (!m) throw FormatError(name(key), field, "missing");
    const auto end = checked_add(offset, length);
    if (!end || *end > m->plain)
      throw FormatError(name(key), field, fmt::format("bytes {}..+{} are outside the member of {} bytes", offset, length, m->plain));
    const std::byte* data = member_data(*m, key);
    if (m->method == kStored) {
      std::vector<std::byte> out(data + offset, data + *end);
      if (length == m->plain) check_crc(*m, out, key);
      return out;
    }
    // A deflate stream cannot be entered in the middle: the member is decoded whole.
    if (m->plain > kMaxZarrChunkBytes * 2)
      throw FormatError(name(key), "zip member",
                        fmt::format("a deflated member of {} bytes is not read (store it uncompressed)", m->plain));
    std::vector<std::byte> whole = inflate_member(*m, data, key);
    check_crc(*m, whole, key);
    if (length == whole.size()) return whole;
    return {whole.begin() + std::ptrdiff_t(offset), whole.begin() + std::ptrdiff_t(*end)};
  }

  std::vector<std::string> children(const std::string& prefix) const override {
    std::set<std::string> names;
    const std::string start = prefix.empty() ? root_ : root_ + prefix + "/";
    for (const auto& [member, _] : members_) {
      if (!member.starts_with(start)) continue;
      const std::size_t slash = member.find('/', start.size());
      if (slash != std::string::npos && slash > start.size()) names.insert(member.substr(start.size(), slash - start.size()));
    }
    return {names.begin(), names.end()};
  }

  std::string name(const std::string& key) const override { return fmt::format("{}:/{}", path_, root_ + key); }

 private:
  std::span<const std::byte> bytes() const { return {file_.data(), file_.size()}; }

  [[noreturn]] void fail(const std::string& field, const std::string& what) const { throw FormatError(path_, field, what); }
  // Errors of one member name it as the file ("x.zarr.zip:/0/.zarray"), the field "zip member".
  [[noreturn]] void fail_member(const std::string& member, const std::string& what) const {
    throw FormatError(fmt::format("{}:/{}", path_, member), "zip member", what);
  }

  // The bytes [offset, offset + length) of the file, or FormatError naming `field`.
  std::span<const std::byte> range(std::uint64_t offset, std::uint64_t length, const std::string& field) const {
    const auto end = checked_add(offset, length);
    if (!end || *end > file_.size())
      fail(field, fmt::format("bytes {}..+{} are outside the file of {} bytes", offset, length, file_.size()));
    return bytes().subspan(offset, length);
  }

  std::span<const std::byte> member_range(std::uint64_t offset, std::uint64_t length, const std::string& key,
                                          const std::string& what) const {
    const auto end = checked_add(offset, length);
    if (!end || *end > file_.size())
      fail_member(root_ + key, fmt::format("its {} (bytes {}..+{}) lies outside the file of {} bytes", what, offset,
                                           length, file_.size()));
    return bytes().subspan(offset, length);
  }

  Directory find_directory() const {
    const std::uint64_t size = file_.size();
    if (size < kEndBytes) fail("end of central directory", "too short to be a zip file");
    const std::uint64_t lowest = size - kEndBytes - std::min(size - kEndBytes, kMaxComment);
    for (std::uint64_t at = size - kEndBytes + 1; at-- > lowest;) {
      const auto end = bytes().subspan(at, kEndBytes);
      if (load_field<std::uint32_t>(end, 0) != kEndSignature) continue;
      if (load_field<std::uint16_t>(end, 4) != 0 || load_field<std::uint16_t>(end, 6) != 0)
        fail("end of central directory", "a zip split over several disks is not read");
      Directory d{load_field<std::uint32_t>(end, 16), load_field<std::uint32_t>(end, 12), load_field<std::uint16_t>(end, 10)};
      const bool zip64 = d.offset == kSaturated32 || d.size == kSaturated32 || d.entries == 0xFFFF;
      if (zip64 && at >= kZip64LocatorBytes) return zip64_directory(at - kZip64LocatorBytes);
      return d;
    }
    fail("end of central directory", "not found: not a zip file (or a damaged one)");
  }

  Directory zip64_directory(std::uint64_t locator_at) const {
    const auto locator = range(locator_at, kZip64LocatorBytes, "zip64 end of central directory locator");
    if (load_field<std::uint32_t>(locator, 0) != kZip64LocatorSignature)
      fail("zip64 end of central directory locator", "missing before an end record whose fields are saturated");
    const auto end = range(load_field<std::uint64_t>(locator, 8), kZip64EndBytes, "zip64 end of central directory");
    if (load_field<std::uint32_t>(end, 0) != kZip64EndSignature) fail("zip64 end of central directory", "bad signature");
    return {load_field<std::uint64_t>(end, 48), load_field<std::uint64_t>(end, 40), load_field<std::uint64_t>(end, 32)};
  }

  void index(const Directory& d) {
    const auto directory = range(d.offset, d.size, "central directory");
    if (d.entries > d.size / kCentralBytes)
      fail("central directory", fmt::format("{} entries cannot fit in its {} bytes", d.entries, d.size));
    members_.reserve(std::size_t(d.entries));
    std::uint64_t at = 0;
    for (std::uint64_t i = 0; i < d.entries; ++i) at = read_entry(directory, at);
  }

  // Reads the central directory header at `at`, returns where the next one starts.
  std::uint64_t read_entry(std::span<const std::byte> directory, std::uint64_t at) {
    const std::string field = "central directory";
    if (directory.size() - at < kCentralBytes) fail(field, "ends inside an entry");
    const auto h = directory.subspan(at);
    if (load_field<std::uint32_t>(h, 0) != kCentralSignature) fail(field, fmt::format("no entry signature at byte {}", at));
    const std::uint64_t name_length = load_field<std::uint16_t>(h, 28), extra_length = load_field<std::uint16_t>(h, 30),
                        comment_length = load_field<std::uint16_t>(h, 32);
    const std::uint64_t entry_bytes = kCentralBytes + name_length + extra_length + comment_length;
    if (h.size() < entry_bytes) fail(field, "ends inside an entry");
    const std::string name(reinterpret_cast<const char*>(h.data() + kCentralBytes), name_length);
    Member m{load_field<std::uint32_t>(h, 42), load_field<std::uint32_t>(h, 20), load_field<std::uint32_t>(h, 24),
             load_field<std::uint32_t>(h, 16), load_field<std::uint16_t>(h, 10)};
    apply_zip64_extra(h.subspan(kCentralBytes + name_length, extra_length), m, name);
    if (load_field<std::uint16_t>(h, 8) & 1) fail_member(name, "encrypted members are not read");
    if (m.method != kStored && m.method != kDeflated)
      fail_member(name, fmt::format("compression method {} is not read (expected 0 stored or 8 deflate)", m.method));
    if (m.method == kStored && m.compressed != m.plain)
      fail_member(name, fmt::format("stored, but {} bytes compressed and {} plain", m.compressed, m.plain));
    if (!name.empty() && name.back() != '/') members_.emplace(name, m);
    return at + entry_bytes;
  }

  // Replaces the saturated 32-bit fields of `m` by the zip64 extra field's values.
  void apply_zip64_extra(std::span<const std::byte> extra, Member& m, const std::string& name) const {
    std::uint64_t* wide[] = {&m.plain, &m.compressed, &m.local_offset};
    std::vector<std::uint64_t*> wanted;
    for (std::uint64_t* v : wide)
      if (*v == kSaturated32) wanted.push_back(v);
    if (wanted.empty()) return;
    for (std::size_t at = 0; at + 4 <= extra.size();) {
      const std::uint16_t id = load_field<std::uint16_t>(extra, at), length = load_field<std::uint16_t>(extra, at + 2);
      if (id == kZip64ExtraId && length >= 8 * wanted.size() && at + 4 + length <= extra.size()) {
        for (std::size_t k = 0; k < wanted.size(); ++k) *wanted[k] = load_field<std::uint64_t>(extra, at + 4 + 8 * k);
        return;
      }
      at += 4 + std::size_t(length);
    }
    fail_member(name, "sizes are saturated but no zip64 extra field gives them");
  }

  // A name all members share as their first folder ("x.zarr/"), when the root holds no metadata.
  std::string common_root() const {
    for (const char* meta : {".zarray", ".zgroup", ".zattrs", "zarr.json"})
      if (members_.count(meta)) return "";
    std::string root;
    for (const auto& [member, _] : members_) {
      const std::size_t slash = member.find('/');
      if (slash == std::string::npos) return "";
      const std::string first = member.substr(0, slash + 1);
      if (root.empty()) root = first;
      else if (first != root) return "";
    }
    return root;
  }

  const Member* find(const std::string& key) const {
    const auto it = members_.find(root_ + key);
    return it == members_.end() ? nullptr : &it->second;
  }

  // The first byte of a member's data, its local header checked and its data inside the file.
  const std::byte* member_data(const Member& m, const std::string& key) const {
    const auto local = member_range(m.local_offset, kLocalBytes, key, "local header");
    if (load_field<std::uint32_t>(local, 0) != kLocalSignature) fail_member(root_ + key, "no local header signature");
    const std::uint64_t start = m.local_offset + kLocalBytes + load_field<std::uint16_t>(local, 26) +
                                load_field<std::uint16_t>(local, 28);
    return member_range(start, m.compressed, key, "data").data();
  }

  // The member's plain bytes. The buffer grows with what is decoded, never to the declared size
  // at once: a small member cannot make the reader allocate what its directory entry claims.
  std::vector<std::byte> inflate_member(const Member& m, const std::byte* data, const std::string& key) const {
    const std::uint64_t cap = m.plain + 1;  // one byte more: room to tell a longer stream
    std::vector<std::byte> out(std::size_t(std::min<std::uint64_t>(cap, 1u << 16)));
    z_stream stream{};
    if (inflateInit2(&stream, -MAX_WBITS) != Z_OK) fail_member(root_ + key, "cannot initialise deflate decoding");
    struct End { z_stream* s; ~End() { inflateEnd(s); } } end_guard{&stream};
    std::uint64_t in_left = m.compressed, produced = 0;
    stream.next_in = reinterpret_cast<Bytef*>(const_cast<std::byte*>(data));
    int status = Z_OK;
    while (status == Z_OK) {
      if (produced == out.size()) {
        if (out.size() == cap) break;
        out.resize(std::size_t(std::min<std::uint64_t>(cap, 2 * std::uint64_t(out.size()))));
      }
      // zlib counts in 32 bits: feed and drain in pieces.
      const auto in_piece = uInt(std::min<std::uint64_t>(in_left, 1u << 30));
      const auto out_piece = uInt(std::min<std::uint64_t>(out.size() - produced, 1u << 30));
      stream.next_out = reinterpret_cast<Bytef*>(out.data() + produced);
      stream.avail_in = in_piece;
      stream.avail_out = out_piece;
      status = inflate(&stream, Z_NO_FLUSH);
      in_left -= in_piece - stream.avail_in;
      produced += out_piece - stream.avail_out;
      if (status == Z_BUF_ERROR && in_left > 0) status = Z_OK;  // it wanted room: the loop grows it
    }
    if (status != Z_STREAM_END || produced != m.plain)
      fail_member(root_ + key, fmt::format("the deflate data {} (the directory says {} bytes)",
                                           status == Z_STREAM_END ? fmt::format("decodes to {} bytes", produced)
                                           : produced > m.plain   ? std::string("decodes to more")
                                                                  : fmt::format("is damaged or truncated ({})",
                                                                                stream.msg ? stream.msg : "ends early"),
                                           m.plain));
    out.resize(std::size_t(produced));
    return out;
  }

  void check_crc(const Member& m, std::span<const std::byte> plain, const std::string& key) const {
    uLong crc = crc32(0L, Z_NULL, 0);
    for (std::size_t at = 0; at < plain.size(); at += 1u << 30) {
      const auto piece = uInt(std::min<std::size_t>(plain.size() - at, 1u << 30));
      crc = crc32(crc, reinterpret_cast<const Bytef*>(plain.data() + at), piece);
    }
    if (std::uint32_t(crc) != m.crc) fail_member(root_ + key, "crc32 mismatch (a damaged member)");
  }

  std::string path_;
  MappedFile file_;
  std::unordered_map<std::string, Member> members_;
  std::string root_;  // "" or the one top folder, with its "/"
};

}  // namespace

std::shared_ptr<const ZarrStore> open_zip_store(const fs::path& path) { return std::make_shared<ZipStore>(path); }

}  // namespace strata::io::detail

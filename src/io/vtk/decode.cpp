// Decoding of VTK array data into a temporary file: base64, zlib block tables, ASCII numbers.
#include <zlib.h>

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

#include <fmt/format.h>

#include "io/vtk/vtk_detail.hpp"
#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail::vtk {

namespace {

// Bytes decoded (or inflated) at a time: large enough to keep system calls rare, small enough
// to never matter for memory.
constexpr std::size_t kChunkBytes = 1 << 20;

struct TypeNames {
  DType dtype;
  std::string_view xml, legacy;
};
constexpr std::array<TypeNames, 10> kTypeNames{{
    {DType::u8, "UInt8", "unsigned_char"},
    {DType::i8, "Int8", "char"},
    {DType::u16, "UInt16", "unsigned_short"},
    {DType::i16, "Int16", "short"},
    {DType::u32, "UInt32", "unsigned_int"},
    {DType::i32, "Int32", "int"},
    {DType::f32, "Float32", "float"},
    {DType::f64, "Float64", "double"},
    {DType::u64, "UInt64", "vtktypeuint64"},
    {DType::i64, "Int64", "vtktypeint64"},
}};

// Other spellings of the legacy format for the same types.
struct LegacyAlias {
  std::string_view name;
  DType dtype;
};
constexpr std::array<LegacyAlias, 6> kLegacyAliases{{{"signed_char", DType::i8},
                                                     {"unsigned_long", DType::u64},
                                                     {"long", DType::i64},
                                                     {"vtkidtype", DType::i64},
                                                     {"vtktypeint32", DType::i32},
                                                     {"vtktypeuint32", DType::u32}}};

}  // namespace

std::string_view xml_type_name(DType t) {
  for (const TypeNames& n : kTypeNames)
    if (n.dtype == t) return n.xml;
  throw Error("xml_type_name: invalid dtype");
}

std::optional<DType> dtype_of_xml_type(std::string_view name) {
  for (const TypeNames& n : kTypeNames)
    if (n.xml == name) return n.dtype;
  return std::nullopt;
}

std::string_view legacy_type_name(DType t) {
  for (const TypeNames& n : kTypeNames)
    if (n.dtype == t) return n.legacy;
  throw Error("legacy_type_name: invalid dtype");
}

std::optional<DType> dtype_of_legacy_type(std::string_view name) {
  const std::string lower = ascii_lower(std::string(name));
  for (const TypeNames& n : kTypeNames)
    if (n.legacy == lower) return n.dtype;
  for (const LegacyAlias& a : kLegacyAliases)
    if (a.name == lower) return a.dtype;
  return std::nullopt;
}

// ---------------------------------------------------------------------------------------------
// Temporary file

namespace {

const std::filesystem::path& checked_temp_folder(const std::filesystem::path& dir, const std::string& file,
                                                 const std::string& field, std::uint64_t bytes) {
  check_temp_space(dir, bytes, file, field, "decoding the samples");
  return dir;
}

}  // namespace

DecodedSamples::DecodedSamples(const ReadOptions& options, std::string file, const std::string& field,
                               std::uint64_t bytes)
    : temp_(checked_temp_folder(temp_folder(options.temp_dir, file), file, field, bytes), "strata-vtk"), file_(std::move(file)) {}

void DecodedSamples::write(const void* data, std::size_t bytes) {
  try {
    temp_.write(data, bytes);
  } catch (const Error& e) {
    throw Error(fmt::format("{} (while decoding {})", e.what(), file_));
  }
  size_ += bytes;
}

std::shared_ptr<MappedFile> DecodedSamples::map() const {
  return std::make_shared<MappedFile>(temp_.descriptor(), fmt::format("{} (decoded)", file_));
}

// ---------------------------------------------------------------------------------------------
// Byte readers

ByteReader region_reader(const std::byte* data, std::uint64_t size) {
  return [data, size, at = std::uint64_t(0)](std::byte* out, std::size_t n) mutable {
    const auto take = std::size_t(std::min<std::uint64_t>(n, size - at));
    std::memcpy(out, data + at, take);
    at += take;
    return take;
  };
}

namespace {

// The 6-bit value of a base64 digit, -1 for anything else.
int base64_value(char c) {
  if (c >= 'A' && c <= 'Z') return c - 'A';
  if (c >= 'a' && c <= 'z') return c - 'a' + 26;
  if (c >= '0' && c <= '9') return c - '0' + 52;
  if (c == '+') return 62;
  if (c == '/') return 63;
  return -1;
}

bool is_space(char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t'; }

class Base64Decoder {
 public:
  Base64Decoder(std::string_view text, std::string file, std::string field)
      : text_(text), file_(std::move(file)), field_(std::move(field)) {}

  std::size_t read(std::byte* out, std::size_t n) {
    std::size_t produced = 0;
    while (produced < n) {
      if (pending_count_ > 0) {  // bytes of the last quantum not yet handed out
        out[produced++] = pending_[3 - pending_count_--];
        continue;
      }
      if (!decode_quantum()) break;
    }
    return produced;
  }

 private:
  // Decodes the next four digits (with their padding) into pending_; false at the end of the text.
  bool decode_quantum() {
    int digits[4];
    int count = 0, padding = 0;
    while (count + padding < 4) {
      if (at_ == text_.size()) {
        if (count + padding == 0) return false;
        throw FormatError(file_, field_, fmt::format("truncated base64: the text ends inside a group of four digits"));
      }
      const char c = text_[at_++];
      if (is_space(c)) continue;
      if (c == '=' && count >= 2) {
        ++padding;
        continue;
      }
      const int v = base64_value(c);
      if (v < 0 || padding > 0)
        throw FormatError(file_, field_, fmt::format("invalid base64 character '{}' at offset {}", c, at_ - 1));
      digits[count++] = v;
    }
    const std::uint32_t bits = std::uint32_t(digits[0]) << 18 | std::uint32_t(digits[1]) << 12 |
                               std::uint32_t(count > 2 ? digits[2] : 0) << 6 | std::uint32_t(count > 3 ? digits[3] : 0);
    const int bytes = count - 1;  // 4 digits: 3 bytes, 3: 2, 2: 1
    for (int i = 0; i < bytes; ++i) pending_[3 - bytes + i] = std::byte(bits >> (16 - 8 * i));
    pending_count_ = bytes;
    return true;
  }

  std::string_view text_;
  std::string file_, field_;
  std::size_t at_ = 0;
  std::byte pending_[3]{};
  int pending_count_ = 0;
};

}  // namespace

ByteReader base64_reader(std::string_view text, std::string file, std::string field) {
  auto decoder = std::make_shared<Base64Decoder>(text, std::move(file), std::move(field));
  return [decoder](std::byte* out, std::size_t n) { return decoder->read(out, n); };
}

void read_exactly(ByteReader& in, std::byte* out, std::size_t n, const std::string& file, const std::string& field) {
  const std::size_t got = in(out, n);
  if (got != n) throw FormatError(file, field, fmt::format("truncated: {} bytes where {} were expected", got, n));
}

// ---------------------------------------------------------------------------------------------
// Binary headers and zlib blocks

namespace {

std::uint64_t read_word(ByteReader& in, const BinaryHeaderFormat& format, const std::string& file,
                        const std::string& field) {
  std::array<std::byte, 8> word{};
  read_exactly(in, word.data(), format.word_bytes, file, field);
  const std::endian order = format.big_endian ? std::endian::big : std::endian::little;
  const std::span<const std::byte> bytes(word.data(), format.word_bytes);
  return format.word_bytes == 4 ? load_field<std::uint32_t>(bytes, 0, order) : load_field<std::uint64_t>(bytes, 0, order);
}

// The block table of a compressed array (header_type words):
// | word  | meaning                                                       |
// | ----- | ------------------------------------------------------------- |
// | 0     | number of blocks n                                            |
// | 1     | uncompressed size of every block but the last                 |
// | 2     | uncompressed size of the last block (0: as large as the rest) |
// | 3+i   | compressed size of block i, i < n                             |
struct BlockTable {
  std::uint64_t block_bytes = 0, last_bytes = 0;
  std::vector<std::uint64_t> compressed;
  std::uint64_t decoded_size(std::size_t i) const { return i + 1 == compressed.size() && last_bytes ? last_bytes : block_bytes; }
};

BlockTable read_block_table(ByteReader& in, const BinaryHeaderFormat& format, std::uint64_t expected,
                            std::uint64_t available, const std::string& file, const std::string& field) {
  const std::uint64_t blocks = read_word(in, format, file, field);
  BlockTable table;
  table.block_bytes = read_word(in, format, file, field);
  table.last_bytes = read_word(in, format, file, field);
  // Every block needs a word of the table: a count past what the input holds is damage, refused
  // before the table is allocated.
  if (blocks > available / format.word_bytes)
    throw FormatError(file, field, fmt::format("{} compressed blocks declared, more than the data can hold", blocks));
  if (blocks == 0 || table.block_bytes == 0 || table.last_bytes > table.block_bytes)
    throw FormatError(file, field,
                      fmt::format("bad block table: {} blocks of {} bytes, the last of {}", blocks, table.block_bytes,
                                  table.last_bytes));
  const std::uint64_t last = table.last_bytes ? table.last_bytes : table.block_bytes;
  if ((blocks - 1) > (expected - last) / table.block_bytes || last > expected ||
      (blocks - 1) * table.block_bytes + last != expected)
    throw FormatError(file, field,
                      fmt::format("{} blocks of {} bytes (the last of {}) do not make the {} bytes of the array", blocks,
                                  table.block_bytes, last, expected));
  table.compressed.resize(blocks);
  for (auto& size : table.compressed) size = read_word(in, format, file, field);
  return table;
}

// Inflates one zlib stream of `compressed` bytes from `in` into `out`; it must decode to `size`.
void inflate_block(ByteReader& in, std::uint64_t compressed, std::uint64_t size, std::size_t index, DecodedSamples& out,
                   const std::string& file, const std::string& field) {
  z_stream stream{};
  if (inflateInit(&stream) != Z_OK) throw Error(file + ": cannot initialise zlib decompression");
  struct End {
    z_stream* s;
    ~End() { inflateEnd(s); }
  } end_guard{&stream};
  std::vector<std::byte> input(std::min<std::uint64_t>(compressed, kChunkBytes)), output(kChunkBytes);
  std::uint64_t left = compressed, produced = 0;
  int status = Z_OK;
  const auto wrong_size = [&](const std::string& what) {
    return FormatError(file, field, fmt::format("block {} {} (declared {} bytes)", index, what, size));
  };
  while (status != Z_STREAM_END) {
    if (stream.avail_in == 0) {
      if (left == 0) throw wrong_size(fmt::format("ends before its zlib stream does, after {} bytes", produced));
      const auto take = std::size_t(std::min<std::uint64_t>(left, input.size()));
      read_exactly(in, input.data(), take, file, field);
      left -= take;
      stream.next_in = reinterpret_cast<Bytef*>(input.data());
      stream.avail_in = uInt(take);
    }
    // Room for one byte past the declared size, enough to tell that the block holds more.
    const auto room = std::size_t(std::min<std::uint64_t>(output.size(), size - produced + 1));
    stream.next_out = reinterpret_cast<Bytef*>(output.data());
    stream.avail_out = uInt(room);
    status = inflate(&stream, Z_NO_FLUSH);
    if (status != Z_OK && status != Z_STREAM_END && status != Z_BUF_ERROR)
      throw FormatError(file, field,
                        fmt::format("block {}: corrupt zlib stream: {}", index, stream.msg ? stream.msg : "invalid data"));
    const std::size_t got = room - stream.avail_out;
    produced += got;
    if (produced > size) throw wrong_size("decodes to more bytes");
    out.write(output.data(), got);
  }
  if (produced != size) throw wrong_size(fmt::format("decodes to {} bytes", produced));
  // Compressed bytes the stream did not use are skipped, as VTK's reader does.
  std::uint64_t skip = left;
  while (skip > 0) {
    const auto take = std::size_t(std::min<std::uint64_t>(skip, input.size()));
    read_exactly(in, input.data(), take, file, field);
    skip -= take;
  }
}

}  // namespace

void read_byte_count(ByteReader& in, const BinaryHeaderFormat& format, std::uint64_t expected, const std::string& file,
                     const std::string& field) {
  const std::uint64_t count = read_word(in, format, file, field);
  if (count != expected)
    throw FormatError(file, field,
                      fmt::format("the array's header says {} bytes, its extent and type make {}", count, expected));
}

void inflate_blocks(ByteReader& in, const BinaryHeaderFormat& format, std::uint64_t expected, std::uint64_t available,
                    DecodedSamples& out, const std::string& file, const std::string& field) {
  const BlockTable table = read_block_table(in, format, expected, available, file, field);
  for (std::size_t i = 0; i < table.compressed.size(); ++i)
    inflate_block(in, table.compressed[i], table.decoded_size(i), i, out, file, field);
}

// ---------------------------------------------------------------------------------------------
// ASCII numbers

namespace {

template <class T>
T parse_number(std::string_view word, const std::string& file, const std::string& field) {
  T value{};
  if constexpr (std::is_floating_point_v<T>) {
    double d = 0;
    const auto [end, ec] = std::from_chars(word.data(), word.data() + word.size(), d);
    if (ec == std::errc{} && end == word.data() + word.size()) return T(d);
  } else {
    const auto [end, ec] = std::from_chars(word.data(), word.data() + word.size(), value);
    if (ec == std::errc{} && end == word.data() + word.size()) return value;
    if (ec == std::errc::result_out_of_range)
      throw FormatError(file, field, fmt::format("\"{}\" is outside the range of {}", word, dtype_name(dtype_of<T>())));
  }
  throw FormatError(file, field, fmt::format("expected a number, found \"{}\"", word.substr(0, 40)));
}

}  // namespace

std::size_t parse_ascii_samples(std::string_view text, DType dtype, std::uint64_t count, DecodedSamples* out,
                                const std::string& file, const std::string& field) {
  std::size_t at = 0;
  visit_dtype(dtype, [&](auto tag) {
    using T = decltype(tag);
    std::vector<T> buffer;
    buffer.reserve(std::min<std::uint64_t>(count, kChunkBytes / sizeof(T)));
    for (std::uint64_t i = 0; i < count; ++i) {
      while (at < text.size() && is_space(text[at])) ++at;
      const std::size_t start = at;
      while (at < text.size() && !is_space(text[at])) ++at;
      if (start == at)
        throw FormatError(file, field, fmt::format("truncated: {} numbers where {} were expected", i, count));
      const T v = parse_number<T>(text.substr(start, at - start), file, field);
      if (!out) continue;
      buffer.push_back(v);
      if (buffer.size() == buffer.capacity()) {
        out->write(buffer.data(), buffer.size() * sizeof(T));
        buffer.clear();
      }
    }
    if (out && !buffer.empty()) out->write(buffer.data(), buffer.size() * sizeof(T));
  });
  return at;
}

}  // namespace strata::io::detail::vtk

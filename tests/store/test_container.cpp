#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <random>

#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"
#include "strata/store/container.hpp"
#include "strata/store/crc32c.hpp"
#include "strata/store/zstd_frame.hpp"
#include "io/io_test_util.hpp"
#include "store/forge.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::store;
namespace forge = strata::test::forge;

namespace {

using forge::random_bytes;

using strata::test::error_of;
using strata::test::io::read_bytes;
using strata::test::io::write_bytes;

// The message of the FormatError `f` throws; "" when it throws none (any other exception fails
// the test), so a test can insist on FormatError rather than any Error.
std::string format_error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const FormatError& e) {
    return e.what();
  }
  return "";
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

using forge::kFlagsField;
using forge::kHeaderCrcField;
using forge::kIndexCountField;
using forge::kIndexCrcField;
using forge::kIndexOffsetField;
using forge::kMinorField;
using forge::patch_header;
using forge::rewrite_index_columns;

struct PlainBrick {
  BrickEntry entry;  // offset, size and crc32c are filled in by write_plain_index_file
  std::vector<std::byte> payload;
};

// Writes a file with the 64-byte-per-entry index of formats 1.0 and 1.1, byte by byte from the
// tables of docs/format.md rather than through ContainerWriter (which writes only 1.3): every
// payload 64-aligned, then metadata, then the index.
void write_plain_index_file(const std::filesystem::path& path, std::vector<PlainBrick>& bricks, const nlohmann::json& metadata,
                            std::uint16_t minor, std::uint32_t flags = 0) {
  std::vector<std::byte> file(kHeaderSize);
  const auto append_aligned = [&file](std::span<const std::byte> bytes) {
    file.resize((file.size() + 63) / 64 * 64);
    const std::uint64_t offset = file.size();
    file.insert(file.end(), bytes.begin(), bytes.end());
    return offset;
  };
  for (PlainBrick& b : bricks) {
    b.entry.size = b.payload.size();
    b.entry.crc32c = crc32c(b.payload.data(), b.payload.size());
    b.entry.offset = b.payload.empty() ? 0 : append_aligned(b.payload);
  }
  nlohmann::json meta = metadata;
  meta["sections"] = nlohmann::json::object();
  const std::string text = meta.dump();
  const auto text_bytes = std::as_bytes(std::span(text));
  const std::uint64_t metadata_offset = append_aligned(text_bytes);
  std::vector<std::byte> index(bricks.size() * 64);
  for (std::size_t i = 0; i < bricks.size(); ++i) {
    const BrickEntry& e = bricks[i].entry;
    const std::span<std::byte> r = std::span(index).subspan(i * 64, 64);
    store_field(r, 0, e.key.level);
    store_field(r, 1, std::uint8_t(e.kind));
    store_field(r, 4, e.crc32c);
    store_field(r, 8, e.key.x);
    store_field(r, 12, e.key.y);
    store_field(r, 16, e.key.z);
    store_field(r, 24, e.offset);
    store_field(r, 32, e.size);
    store_field(r, 40, e.min);
    store_field(r, 44, e.max);
    store_field(r, 48, e.histogram);
  }
  const std::uint64_t index_offset = append_aligned(index);
  const std::span<std::byte> h(file.data(), kHeaderSize);
  const std::array<unsigned char, 8> magic{0x89, 'S', 'T', 'R', 'A', 'T', 'A', '\n'};
  std::memcpy(h.data(), magic.data(), magic.size());
  store_field(h, 8, std::uint16_t(1));
  store_field(h, kMinorField, minor);
  store_field(h, kFlagsField, flags);
  store_field(h, kIndexOffsetField, index_offset);
  store_field(h, kIndexCountField, std::uint64_t(bricks.size()));
  store_field(h, 32, metadata_offset);
  store_field(h, 40, std::uint64_t(text.size()));
  store_field(h, 48, std::uint32_t(64));
  store_field(h, 52, crc32c(text.data(), text.size()));
  store_field(h, kIndexCrcField, crc32c(index.data(), index.size()));
  store_field(h, kHeaderCrcField, crc32c(h.data(), kHeaderCrcField));
  write_bytes(path, file);
}

// A histogram as the compressor makes them: a run of bins, sometimes with a hole.
std::uint64_t histogram_run(std::mt19937& rng) {
  const unsigned lo = rng() % 60, hi = lo + 1 + rng() % (63 - lo);
  std::uint64_t h = (hi == 63 ? ~0ull : (1ull << (hi + 1)) - 1) & ~((1ull << lo) - 1);
  if (rng() % 3 == 0) h &= ~(1ull << ((lo + hi) / 2));
  return h;
}

// Built piecewise: GCC 12 reports a false -Wrestrict for "s" + std::to_string(n).
std::string section_name(int n) {
  std::string name = "s";
  name += std::to_string(n);
  return name;
}

}  // namespace

TEST(StoreContainer, RoundTripsBricksSectionsAndMetadata) {
  test::TempDir dir;
  auto path = dir / "a.strata";
  auto p1 = random_bytes(1000, 2), p2 = random_bytes(77, 3), sec = random_bytes(500, 4);
  {
    ContainerWriter w(path);
    w.add_brick({{0, 1, 2, 3}, PayloadKind::tucker, 0, 0, 0, -1.5f, 2.5f, 0xF0F0ull}, p1);
    w.add_brick({{1, 0, 0, 0}, PayloadKind::constant, 0, 0, 0, 7.0f, 7.0f, 1ull}, {});
    w.add_brick({{0, 0, 0, 0}, PayloadKind::tucker, 0, 0, 0, 0.0f, 1.0f, 2ull}, p2);
    w.add_section("global_bases", sec);
    w.finish({{"codec", "test"}, {"levels", 2}});
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "a.strata.tmp"));
  ContainerReader r(path);
  EXPECT_EQ(r.metadata()["codec"], "test");
  ASSERT_EQ(r.bricks().size(), 3u);
  const BrickEntry* e = r.find({0, 1, 2, 3});
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->kind, PayloadKind::tucker);
  EXPECT_EQ(e->min, -1.5f);
  EXPECT_EQ(e->histogram, 0xF0F0ull);
  EXPECT_EQ(e->offset % kPayloadAlignment, 0u);
  auto bytes = r.payload(*e);
  EXPECT_TRUE(std::equal(bytes.begin(), bytes.end(), p1.begin(), p1.end()));
  EXPECT_EQ(r.find({0, 0, 0, 0})->size, 77u);
  EXPECT_EQ(r.find({1, 0, 0, 0})->kind, PayloadKind::constant);
  EXPECT_EQ(r.find({2, 0, 0, 0}), nullptr);
  auto s = r.section("global_bases");
  EXPECT_TRUE(std::equal(s.begin(), s.end(), sec.begin(), sec.end()));
  EXPECT_FALSE(r.has_section("nope"));
  EXPECT_TRUE(is_strata_file(path));
}

TEST(StoreContainer, CorruptPayloadIsReportedWithTheBrick) {
  test::TempDir dir;
  auto path = dir / "c.strata";
  auto p1 = random_bytes(256, 5);
  {
    ContainerWriter w(path);
    w.add_brick({{2, 4, 5, 6}, PayloadKind::tucker, 0, 0, 0, 0, 1, 0}, p1);
    w.finish({});
  }
  std::uint64_t offset = ContainerReader(path).find({2, 4, 5, 6})->offset;
  test::flip_byte(path, offset + 100);
  ContainerReader r(path);  // header, index and metadata are still intact
  std::string msg = error_of([&] { r.payload(*r.find({2, 4, 5, 6})); });
  EXPECT_NE(msg.find("c.strata"), std::string::npos) << msg;
  EXPECT_NE(msg.find("level 2, 4,5,6"), std::string::npos) << msg;
  EXPECT_NE(msg.find("checksum"), std::string::npos) << msg;
}

TEST(StoreContainer, RejectsBadHeadersAndTruncation) {
  test::TempDir dir;
  auto path = dir / "t.strata";
  {
    ContainerWriter w(path);
    w.add_brick({{0, 0, 0, 0}, PayloadKind::tucker, 0, 0, 0, 0, 1, 0}, random_bytes(4096, 6));
    w.finish({{"x", 1}});
  }
  const auto size = std::filesystem::file_size(path);
  auto copy = dir / "t2.strata";
  std::filesystem::copy_file(path, copy);
  std::filesystem::resize_file(copy, size - 100);
  std::string msg = error_of([&] { ContainerReader r(copy); });
  EXPECT_NE(msg.find("t2.strata"), std::string::npos) << msg;
  EXPECT_NE(msg.find("outside"), std::string::npos) << msg;

  test::flip_byte(path, 9);  // version field: caught by the header checksum
  msg = error_of([&] { ContainerReader r(path); });
  EXPECT_NE(msg.find("header"), std::string::npos) << msg;

  std::ofstream(dir / "n.strata") << "NRRD0004 definitely not strata";
  msg = error_of([&] { ContainerReader r(dir / "n.strata"); });
  EXPECT_NE(msg.find("magic"), std::string::npos) << msg;
}

TEST(StoreContainer, UnfinishedWriterLeavesNothing) {
  test::TempDir dir;
  {
    ContainerWriter w(dir / "u.strata");
    w.add_brick({{0, 0, 0, 0}, PayloadKind::tucker, 0, 0, 0, 0, 1, 0}, random_bytes(64, 7));
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "u.strata"));
  EXPECT_FALSE(std::filesystem::exists(dir / "u.strata.tmp"));
}

// Format 1.2 and later: many bricks of every kind, constant ones among them, payloads packed and aligned,
// sections written between bricks (offsets the packing rule cannot predict): every field of
// every entry comes back, in the order written, from an index far smaller than 64 bytes a brick.
TEST(StoreContainer, CompressedIndexRoundTripsManyBricksOfAllKinds) {
  test::TempDir dir;
  const auto path = dir / "many.strata";
  std::mt19937 rng(11);
  const std::array<PayloadKind, 5> kinds{PayloadKind::constant, PayloadKind::tucker, PayloadKind::tucker_zstd,
                                         PayloadKind::tucker_coded, PayloadKind::raw_zstd};
  std::vector<BrickEntry> written;
  std::vector<std::vector<std::byte>> payloads;
  {
    ContainerWriter w(path);
    int n = 0;
    for (int level = 0; level < 4; ++level)
      for (int z = -1; z < 5; ++z)
        for (int y = 0; y < 6; ++y)
          for (int x = 0; x < 7 - level; ++x, ++n) {
            const PayloadKind kind = kinds[rng() % kinds.size()];
            // A tucker_coded brick may be empty too: offset 0 is not reserved for constants.
            const std::size_t size = kind == PayloadKind::constant ? 0 : n % 97 == 5 ? 0 : 1 + rng() % 300;
            const float lo = float(rng() % 1000) / 8, hi = kind == PayloadKind::constant ? lo : lo + float(rng() % 500) / 8;
            const BrickEntry e{{std::uint8_t(level), x * 3 - 2, y, z}, kind, 0, 0, 0, lo, hi, histogram_run(rng)};
            payloads.push_back(random_bytes(size, unsigned(n)));
            w.add_brick(e, payloads.back());
            written.push_back(e);
            if (n % 50 == 17) w.add_section(section_name(n), random_bytes(1 + rng() % 100, unsigned(n) + 7));
          }
    w.finish({{"codec", "test"}});
  }
  const auto file = read_bytes(path);
  EXPECT_EQ(load_field<std::uint16_t>(file, kMinorField), kFormatVersionMinor);
  EXPECT_EQ(load_field<std::uint32_t>(file, kFlagsField), 1u);
  ContainerReader r(path);
  EXPECT_TRUE(r.index_compressed());
  ASSERT_EQ(r.bricks().size(), written.size());
  std::size_t constant = 0, gaps = 0;
  std::uint64_t previous_end = kHeaderSize;
  for (std::size_t i = 0; i < written.size(); ++i) {
    const BrickEntry& got = r.bricks()[i];
    const BrickEntry& want = written[i];
    ASSERT_EQ(got.key, want.key) << i;
    EXPECT_EQ(got.kind, want.kind) << brick_name(want.key);
    EXPECT_EQ(got.min, want.min) << brick_name(want.key);
    EXPECT_EQ(got.max, want.max) << brick_name(want.key);
    EXPECT_EQ(got.histogram, want.histogram) << brick_name(want.key);
    ASSERT_EQ(got.size, payloads[i].size()) << brick_name(want.key);
    EXPECT_EQ(got.crc32c, payload_check_value(crc32c(payloads[i].data(), payloads[i].size()), payloads[i].size(), want.key,
                                              want.kind, load_field<std::uint32_t>(file, forge::kMetadataCrcField)))
        << brick_name(want.key);
    EXPECT_EQ(r.find(want.key), &got);
    const auto bytes = r.payload(got);  // checks the checksum too
    EXPECT_TRUE(std::equal(bytes.begin(), bytes.end(), payloads[i].begin(), payloads[i].end())) << brick_name(want.key);
    if (got.size == 0) {
      EXPECT_EQ(got.offset, 0u) << brick_name(want.key);
      constant += got.kind == PayloadKind::constant;
      continue;
    }
    if (needs_alignment(got.kind)) {
      EXPECT_EQ(got.offset % kPayloadAlignment, 0u) << brick_name(want.key);
    }
    gaps += got.offset >= previous_end + kPayloadAlignment;  // a section lies between
    previous_end = got.offset + got.size;
  }
  EXPECT_GT(constant, 50u);
  EXPECT_GT(gaps, 3u);
  for (int n = 17; n < int(written.size()); n += 50) EXPECT_TRUE(r.has_section(section_name(n))) << n;
  // The index is the file's tail; what the reader reports is what it occupies there.
  EXPECT_EQ(load_field<std::uint64_t>(file, kIndexOffsetField) + r.index_bytes(), file.size());
  EXPECT_LT(r.index_bytes(), written.size() * kIndexEntrySize / 3);

  // No bricks at all (a label file): an empty index still round-trips.
  {
    ContainerWriter w(dir / "empty.strata");
    w.add_section("only", random_bytes(10, 1));
    w.finish({});
  }
  ContainerReader empty(dir / "empty.strata");
  EXPECT_TRUE(empty.bricks().empty());
  EXPECT_TRUE(empty.index_compressed());
  EXPECT_EQ(empty.section("only").size(), 10u);
}

TEST(StoreContainer, EntropyCodedPayloadsArePackedTuckerPayloadsAligned) {
  EXPECT_TRUE(needs_alignment(PayloadKind::tucker));
  EXPECT_TRUE(needs_alignment(PayloadKind::tucker_zstd));
  EXPECT_FALSE(needs_alignment(PayloadKind::tucker_coded));
  EXPECT_FALSE(needs_alignment(PayloadKind::raw_zstd));
  EXPECT_FALSE(needs_alignment(PayloadKind::constant));

  test::TempDir dir;
  const auto path = dir / "packed.strata";
  const auto add = [](ContainerWriter& w, int x, PayloadKind kind, std::size_t size) {
    // A constant brick's value is its min == max.
    w.add_brick({{0, x, 0, 0}, kind, 0, 0, 0, 0, kind == PayloadKind::constant ? 0.0f : 1.0f, 1}, random_bytes(size, unsigned(x)));
  };
  {
    ContainerWriter w(path);
    add(w, 0, PayloadKind::tucker_coded, 37);
    add(w, 1, PayloadKind::tucker_coded, 50);
    add(w, 2, PayloadKind::raw_zstd, 13);
    add(w, 3, PayloadKind::tucker, 100);
    add(w, 4, PayloadKind::tucker_coded, 5);
    add(w, 5, PayloadKind::constant, 0);
    add(w, 6, PayloadKind::tucker_zstd, 7);
    w.add_section("between", random_bytes(3, 9));
    add(w, 7, PayloadKind::raw_zstd, 11);
    w.finish({});
  }
  ContainerReader r(path);
  const auto at = [&](int x) { return *r.find({0, x, 0, 0}); };
  const auto end = [&](int x) { return at(x).offset + at(x).size; };
  EXPECT_EQ(at(0).offset, kHeaderSize);
  EXPECT_EQ(at(1).offset, end(0));
  EXPECT_EQ(at(2).offset, end(1));
  EXPECT_EQ(end(2), kHeaderSize + 37 + 50 + 13);
  EXPECT_EQ(at(3).offset, 192u);  // 164 rounded up to 64
  EXPECT_EQ(at(4).offset, end(3));
  EXPECT_EQ(at(5).offset, 0u);
  EXPECT_EQ(at(6).offset % kPayloadAlignment, 0u);
  EXPECT_GT(at(6).offset, end(4));
  const auto section = r.metadata()["sections"]["between"]["offset"].get<std::uint64_t>();
  EXPECT_EQ(section % kPayloadAlignment, 0u);
  EXPECT_EQ(at(7).offset, section + 3);
  for (int x = 0; x < 8; ++x) EXPECT_EQ(r.payload(at(x)).size(), at(x).size) << x;
}

// Files of formats 1.0 and 1.1 (and 1.2 without the flag) keep their 64-byte entries and read
// as before.
TEST(StoreContainer, ReadsThePlainIndexOfFormats10And11) {
  test::TempDir dir;
  for (const std::uint16_t minor : {0, 1, 2}) {
    const auto path = dir / ("plain" + std::to_string(minor) + ".strata");
    std::vector<PlainBrick> bricks{{{{0, 1, 2, 3}, PayloadKind::tucker, 0, 0, 0, -1.5f, 2.5f, 0xF0ull}, random_bytes(300, 1)},
                                   {{{1, 0, 0, 0}, PayloadKind::constant, 0, 0, 0, 7, 7, 1}, {}},
                                   {{{0, 5, 2, 3}, PayloadKind::tucker_coded, 0, 0, 0, 0, 1, 2}, random_bytes(20, 2)},
                                   {{{0, 6, 2, 3}, PayloadKind::raw_zstd, 0, 0, 0, 3, 4, 4}, random_bytes(9, 3)}};
    write_plain_index_file(path, bricks, {{"codec", "test"}}, minor);
    ContainerReader r(path);
    EXPECT_FALSE(r.index_compressed());
    EXPECT_EQ(r.index_bytes(), 4u * kIndexEntrySize);
    EXPECT_EQ(r.metadata()["codec"], "test");
    ASSERT_EQ(r.bricks().size(), 4u);
    for (std::size_t i = 0; i < bricks.size(); ++i) {
      const BrickEntry& got = r.bricks()[i];
      const BrickEntry& want = bricks[i].entry;
      EXPECT_EQ(got.key, want.key);
      EXPECT_EQ(got.kind, want.kind);
      EXPECT_EQ(got.offset, want.offset);
      EXPECT_EQ(got.size, want.size);
      EXPECT_EQ(got.min, want.min);
      EXPECT_EQ(got.max, want.max);
      EXPECT_EQ(got.histogram, want.histogram);
      const auto bytes = r.payload(got);
      EXPECT_TRUE(std::equal(bytes.begin(), bytes.end(), bricks[i].payload.begin(), bricks[i].payload.end()));
    }
    // Old writers aligned every payload, the entropy-coded kinds too.
    EXPECT_EQ(r.find({0, 5, 2, 3})->offset % kPayloadAlignment, 0u);
  }
}

TEST(StoreContainer, CorruptCompressedIndexIsAFormatErrorNamingTheIndex) {
  test::TempDir dir;
  const auto original = dir / "o.strata";
  {
    ContainerWriter w(original);
    for (int x = 0; x < 40; ++x)
      w.add_brick({{0, x, 0, 0}, x % 4 ? PayloadKind::tucker_coded : PayloadKind::constant, 0, 0, 0, float(x), float(x), 1},
                  x % 4 ? random_bytes(30 + std::size_t(x), unsigned(x)) : std::vector<std::byte>{});
    w.finish({});
  }
  const auto index_offset = ContainerReader(original).file_size() - ContainerReader(original).index_bytes();
  const auto copy = [&](const std::string& name) {
    const auto p = dir / name;
    std::filesystem::copy_file(original, p);
    return p;
  };

  // A flipped byte inside the frame: the index checksum covers the stored bytes.
  auto p = copy("flipped.strata");
  test::flip_byte(p, index_offset + 8 + 5);
  std::string msg = format_error_of([&] { ContainerReader r(p); });
  EXPECT_TRUE(contains(msg, "flipped.strata") && contains(msg, "index") && contains(msg, "checksum")) << msg;

  // index_count one off either way (header checksum recomputed): the columns do not fit it.
  for (const std::int64_t delta : {-1, 1, 5}) {
    p = copy("count" + std::to_string(delta) + ".strata");
    patch_header(p, [&](std::span<std::byte> h) { store_field(h, kIndexCountField, std::uint64_t(40 + delta)); });
    msg = format_error_of([&] { ContainerReader r(p); });
    EXPECT_TRUE(contains(msg, p.filename().string()) && contains(msg, ": index: ")) << delta << ": " << msg;
  }

  // A count no frame of this size can describe is refused before anything is allocated.
  p = copy("huge_count.strata");
  patch_header(p, [&](std::span<std::byte> h) { store_field(h, kIndexCountField, std::uint64_t(1) << 40); });
  msg = format_error_of([&] { ContainerReader r(p); });
  EXPECT_TRUE(contains(msg, "huge_count.strata: index_count: ") && contains(msg, "inflate")) << msg;

  // A count a frame of this size could describe (8 MiB of incompressible columns may inflate
  // to 32768 x 8 MiB), but whose index would take more than half of any machine this runs on
  // (7.2e9 entries, about 1.3 TiB to open): refused before anything is allocated.
  p = copy("memory_count.strata");
  rewrite_index_columns(p, [](std::vector<std::byte>& c) {
    const auto noise = random_bytes(std::size_t(8) << 20, 7);
    c.insert(c.end(), noise.begin(), noise.end());
  });
  {
    const auto bytes = read_bytes(p);
    const auto frame_size = load_field<std::uint64_t>(bytes, index_offset);
    patch_header(p, [&](std::span<std::byte> h) { store_field(h, kIndexCountField, frame_size * 32768 / 38); });
  }
  msg = format_error_of([&] { ContainerReader r(p); });
  EXPECT_TRUE(contains(msg, "memory_count.strata: index_count: ") && contains(msg, "GiB to open")) << msg;

  // A frame size beyond the file.
  p = copy("frame_size.strata");
  {
    auto bytes = read_bytes(p);
    store_field(std::span(bytes).subspan(index_offset), 0, std::uint64_t(1) << 62);
    write_bytes(p, bytes);
  }
  msg = format_error_of([&] { ContainerReader r(p); });
  EXPECT_TRUE(contains(msg, "index") && contains(msg, "outside")) << msg;

  // Valid checksums around columns of the wrong length: one byte too many, one too few.
  for (const int extra : {1, -1}) {
    p = copy("columns" + std::to_string(extra) + ".strata");
    rewrite_index_columns(p, [&](std::vector<std::byte>& c) {
      if (extra > 0) c.push_back(std::byte{0});
      else c.pop_back();
    });
    msg = format_error_of([&] { ContainerReader r(p); });
    EXPECT_TRUE(contains(msg, p.filename().string()) && contains(msg, ": index: ")) << extra << ": " << msg;
  }

  // An offset gap past the end of the file names the brick, and so does one that would wrap
  // the offset around to 64 bytes before the previous payload's end. Columns: level, kind (40
  // bytes each), x, y, z (160 each), size, min, max, histogram (38 bytes an entry in all), then
  // the gaps of the 30 bricks with payload bytes (u64: 8 byte planes of 30 bytes). Gap 2 is
  // brick x = 3's.
  const std::array<std::uint64_t, 2> gaps{std::uint64_t(0x40) << 56, ~std::uint64_t(0) - 63};
  for (std::size_t g = 0; g < gaps.size(); ++g) {
    p = copy("gap" + std::to_string(g) + ".strata");
    rewrite_index_columns(p, [&](std::vector<std::byte>& c) {
      for (std::size_t plane = 0; plane < 8; ++plane) c[40 * 38 + plane * 30 + 2] = std::byte(gaps[g] >> (8 * plane));
    });
    msg = format_error_of([&] { ContainerReader r(p); });
    EXPECT_TRUE(contains(msg, p.filename().string()) && contains(msg, "level 0, 3,0,0") && contains(msg, "outside")) << msg;
  }

  // The untouched original still reads.
  EXPECT_EQ(ContainerReader(original).bricks().size(), 40u);
}

TEST(StoreContainer, UnknownHeaderFlagsAreRejected) {
  test::TempDir dir;
  const auto path = dir / "f.strata";
  {
    ContainerWriter w(path);
    w.add_brick({{0, 0, 0, 0}, PayloadKind::tucker_coded, 0, 0, 0, 0, 1, 1}, random_bytes(64, 1));
    w.finish({});
  }
  const auto with = [&](const std::string& name, std::uint16_t minor, std::uint32_t flags) {
    const auto p = dir / name;
    std::filesystem::copy_file(path, p);
    patch_header(p, [&](std::span<std::byte> h) {
      store_field(h, kMinorField, minor);
      store_field(h, kFlagsField, flags);
    });
    return p;
  };
  for (const std::uint32_t flags : {0x3u, 0x80000001u}) {
    const auto p = with("unknown" + std::to_string(flags) + ".strata", 2, flags);
    const std::string msg = format_error_of([&] { ContainerReader r(p); });
    EXPECT_TRUE(contains(msg, p.filename().string()) && contains(msg, "flags") && contains(msg, "unknown")) << msg;
  }
  // The compressed index came with 1.2: a 1.1 header with the flag is inconsistent.
  const auto old = with("old.strata", 1, 1);
  std::string msg = format_error_of([&] { ContainerReader r(old); });
  EXPECT_TRUE(contains(msg, "old.strata") && contains(msg, "flags") && contains(msg, "1.2")) << msg;
  // Minor versions are not checked (additions that matter set a flag or a new kind): a 1.4
  // file without unknown flags reads.
  EXPECT_EQ(ContainerReader(with("newer.strata", 4, 1)).bricks().size(), 1u);
  // Without the flag the tail is taken for 64-byte entries and the file does not read.
  msg = format_error_of([&] { ContainerReader r(with("cleared.strata", 2, 0)); });
  EXPECT_TRUE(contains(msg, "cleared.strata") && contains(msg, "index")) << msg;
}

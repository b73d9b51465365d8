// Format 1.3: a payload's checksum is bound to its key, its kind and the metadata, a section's
// to its name (docs/format.md, "Checksums"); files of 1.0-1.2 keep the old rule. Format 1.6: the
// metadata binds the index (bricks_crc32c), and a section holding a container is checked through
// its header when opened. And what the container itself checks in the metadata and the index of
// a hostile file.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"
#include "strata/store/container.hpp"
#include "strata/store/crc32c.hpp"
#include "store/forge.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::store;
namespace forge = strata::test::forge;

namespace {

using forge::random_bytes;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// The FormatError's message; another exception shows as "Error: ..." or "FOREIGN: ...".
std::string format_error_of(const std::function<void()>& f) { return forge::failure_of(f); }

// Reads every payload and section of `path`.
void read_everything(const std::filesystem::path& path) {
  const ContainerReader r(path);
  for (const auto& e : r.bricks()) r.payload(e);
  for (const auto& [name, s] : r.metadata()["sections"].items()) r.section(name);
}

// Two tucker_coded bricks of equal size at x = 0 and 1, a constant one, and two sections.
void write_sample(const std::filesystem::path& path) {
  ContainerWriter w(path);
  w.add_brick({{0, 0, 0, 0}, PayloadKind::tucker_coded, 0, 0, 0, 0, 1, 1}, random_bytes(40, 1));
  w.add_brick({{0, 1, 0, 0}, PayloadKind::tucker_coded, 0, 0, 0, 0, 1, 1}, random_bytes(40, 2));
  w.add_brick({{1, 0, 0, 0}, PayloadKind::constant, 0, 0, 0, 3, 3, 1}, {});
  w.add_brick({{0, 2, 0, 0}, PayloadKind::tucker, 0, 0, 0, 0, 1, 1}, random_bytes(70, 3));
  w.add_section("first", random_bytes(30, 4));
  w.add_section("second", random_bytes(30, 5));
  w.finish({{"codec", "test"}});
}

// The header says format 1.5: the checks of 1.6 (bricks_crc32c) are off, those of 1.3 on.
void as_format_1_5(const std::filesystem::path& path) {
  forge::patch_header(path, [](std::span<std::byte> h) { store_field(h, forge::kMinorField, std::uint16_t(5)); });
}

// Columns of the sample's compressed index (4 entries, 3 with payload bytes): level, kind (4
// bytes each), x, y, z (16 each), size (32), min, max (16 each), histogram (32), ...; a column of
// a multi-byte type is stored as byte planes (byte p of entry i at column + p * kEntries + i).
constexpr std::size_t kEntries = 4, kKindColumn = kEntries, kXColumn = 2 * kEntries, kMinColumn = 22 * kEntries,
                      kMaxColumn = 26 * kEntries, kHistogramColumn = 30 * kEntries;

}  // namespace

// The check value is what docs/format.md says: the payload's CRC-32C continued over the 20-byte
// binding record, computed here from the table rather than through the library.
TEST(StoreBoundChecksums, CheckValueIsThePayloadThenTheBindingRecord) {
  test::TempDir dir;
  const auto path = dir / "a.strata";
  write_sample(path);
  const auto file = forge::file_bytes(path);
  EXPECT_EQ(load_field<std::uint16_t>(file, forge::kMinorField), store::kFormatVersionMinor);
  const auto metadata_crc = load_field<std::uint32_t>(file, forge::kMetadataCrcField);
  const ContainerReader r(path);
  EXPECT_EQ(r.version_minor(), store::kFormatVersionMinor);
  for (const BrickEntry& e : r.bricks()) {
    if (e.size == 0) {
      EXPECT_EQ(e.crc32c, 0u);
      continue;
    }
    std::array<std::byte, 20> record{};
    store_field(std::span(record), 0, e.key.level);
    store_field(std::span(record), 1, std::uint8_t(e.kind));
    store_field(std::span(record), 4, e.key.x);
    store_field(std::span(record), 8, e.key.y);
    store_field(std::span(record), 12, e.key.z);
    store_field(std::span(record), 16, metadata_crc);
    const auto payload = r.payload(e);
    EXPECT_EQ(e.crc32c, crc32c(record.data(), record.size(), crc32c(payload.data(), payload.size()))) << brick_name(e.key);
  }
  for (const std::string name : {"first", "second"}) {
    const auto bytes = r.section(name);
    std::vector<std::byte> covered(bytes.begin(), bytes.end());
    for (char c : name) covered.push_back(std::byte(c));
    for (int i = 0; i < 4; ++i) covered.push_back(std::byte(i == 0 ? name.size() : 0));
    EXPECT_EQ(r.metadata()["sections"][name]["crc32c"].get<std::uint32_t>(), crc32c(covered.data(), covered.size())) << name;
  }
  // metadata.bricks_crc32c (1.6): the CRC-32C of columns 1-9, here laid out by hand.
  std::vector<std::byte> columns;
  const auto column = [&](auto value) {
    using T = decltype(value(r.bricks().front()));
    for (std::size_t byte = 0; byte < sizeof(T); ++byte)
      for (const BrickEntry& e : r.bricks()) {
        const T v = value(e);
        columns.push_back(reinterpret_cast<const std::byte*>(&v)[byte]);
      }
  };
  column([](const BrickEntry& e) { return e.key.level; });
  column([](const BrickEntry& e) { return std::uint8_t(e.kind); });
  column([](const BrickEntry& e) { return e.key.x; });
  column([](const BrickEntry& e) { return e.key.y; });
  column([](const BrickEntry& e) { return e.key.z; });
  column([](const BrickEntry& e) { return e.size; });
  column([](const BrickEntry& e) { return e.min; });
  column([](const BrickEntry& e) { return e.max; });
  column([](const BrickEntry& e) { return e.histogram; });
  ASSERT_EQ(columns.size(), 38 * kEntries);
  EXPECT_EQ(r.metadata()["bricks_crc32c"].get<std::uint32_t>(), crc32c(columns.data(), columns.size()));
}

// A section holding a container (1.6): its check value covers its first 60 bytes (the inner
// header without its own checksum), its name, the name's length (u32) and its size (u64), and
// its entry says "container": true.
TEST(StoreBoundChecksums, ContainerSectionCheckValueIsItsHeaderNameAndSize) {
  test::TempDir dir;
  const auto inner = dir / "inner.strata", outer = dir / "outer.strata";
  write_sample(inner);
  const auto bytes = forge::file_bytes(inner);
  {
    ContainerWriter w(outer);
    w.add_container_section("inner", bytes);
    w.add_section("plain", bytes);
    w.finish({{"codec", "test"}});
  }
  const ContainerReader r(outer);
  const nlohmann::json& sections = r.metadata()["sections"];
  EXPECT_EQ(sections["inner"]["container"], true);
  EXPECT_FALSE(sections["plain"].contains("container"));
  std::vector<std::byte> covered(bytes.begin(), bytes.begin() + 60);
  for (char c : std::string("inner")) covered.push_back(std::byte(c));
  for (int i = 0; i < 4; ++i) covered.push_back(std::byte(i == 0 ? 5 : 0));
  for (int i = 0; i < 8; ++i) covered.push_back(std::byte(bytes.size() >> (8 * i)));
  EXPECT_EQ(sections["inner"]["crc32c"].get<std::uint32_t>(), crc32c(covered.data(), covered.size()));
  EXPECT_EQ(sections["plain"]["crc32c"].get<std::uint32_t>(), section_check_value(bytes, "plain"));
  // Both read whole; only the marked one opens in place, and it is the inner file.
  EXPECT_EQ(r.section("inner").size(), bytes.size());
  EXPECT_EQ(r.section("plain").size(), bytes.size());
  const ContainerReader opened(r, "inner", "outer (inner)");
  EXPECT_EQ(opened.bricks().size(), kEntries);
  read_everything(inner);
  const std::string msg = format_error_of([&] { ContainerReader(r, "plain", "outer (plain)"); });
  EXPECT_TRUE(contains(msg, "outer.strata: metadata.sections.plain.container: missing")) << msg;
}

// Two index entries swapped (each keeps its offset, size and checksum but takes the other's
// key): before 1.3 both bricks decoded silently from each other's payload.
TEST(StoreBoundChecksums, SwappedIndexEntriesFailNamingTheBrick) {
  test::TempDir dir;
  const auto path = dir / "swapped.strata";
  write_sample(path);
  forge::rewrite_index_columns(path, [](std::vector<std::byte>& c) { std::swap(c[kXColumn], c[kXColumn + 1]); });
  // Since 1.6 the metadata's bricks_crc32c refuses the edited index on open; the payloads' own
  // binding (1.3) shows as the file of 1.5 it otherwise is.
  std::string msg = format_error_of([&] { ContainerReader r(path); });
  EXPECT_TRUE(contains(msg, "swapped.strata: index: ") && contains(msg, "metadata.bricks_crc32c")) << msg;
  as_format_1_5(path);
  const ContainerReader r(path);  // the index itself is consistent
  msg = format_error_of([&] { r.payload(*r.find({0, 1, 0, 0})); });
  EXPECT_TRUE(contains(msg, "swapped.strata: brick (level 0, 1,0,0): payload checksum mismatch")) << msg;
  EXPECT_NE(format_error_of([&] { r.payload(*r.find({0, 0, 0, 0})); }), "");

  // The same swap in a 1.2 file (old rule) still reads: the old rule is kept for old files.
  const auto old = dir / "old.strata";
  write_sample(old);
  forge::downgrade_to_1_2(old);
  read_everything(old);
  forge::rewrite_index_columns(old, [](std::vector<std::byte>& c) { std::swap(c[kXColumn], c[kXColumn + 1]); });
  EXPECT_EQ(format_error_of([&] { read_everything(old); }), "");
}

TEST(StoreBoundChecksums, ChangedKindFailsNamingTheBrick) {
  test::TempDir dir;
  const auto path = dir / "kind.strata";
  write_sample(path);
  // tucker_coded -> raw_zstd: both packed, so the offsets stay where they were.
  forge::rewrite_index_columns(path, [](std::vector<std::byte>& c) { c[kKindColumn + 1] = std::byte(5); });
  std::string msg = format_error_of([&] { ContainerReader r(path); });
  EXPECT_TRUE(contains(msg, "kind.strata: index: ") && contains(msg, "metadata.bricks_crc32c")) << msg;
  as_format_1_5(path);
  const ContainerReader r(path);
  msg = format_error_of([&] { r.payload(*r.find({0, 1, 0, 0})); });
  EXPECT_TRUE(contains(msg, "kind.strata: brick (level 0, 1,0,0): payload checksum mismatch")) << msg;
}

// The metadata rewritten and re-checksummed under the payloads (what a forger who changes
// `overlap` does): the container accepts the metadata, every payload fails.
TEST(StoreBoundChecksums, MetadataEditedUnderThePayloadsFailsEveryPayload) {
  test::TempDir dir;
  const auto path = dir / "meta.strata";
  write_sample(path);
  forge::edit_metadata_in_place(path, [](nlohmann::json& m) { m["overlap"] = 3; });
  const ContainerReader r(path);
  EXPECT_EQ(r.metadata()["overlap"], 3);
  for (const BrickEntry& e : r.bricks()) {
    if (e.size == 0) continue;
    const std::string msg = format_error_of([&] { r.payload(e); });
    EXPECT_TRUE(contains(msg, "meta.strata: " + brick_name(e.key) + ": payload checksum mismatch") && contains(msg, "metadata"))
        << msg;
  }
  // Sections are listed in the metadata, so they are bound to their names instead, and read.
  EXPECT_EQ(r.section("first").size(), 30u);
}

TEST(StoreBoundChecksums, SwappedSectionsFailNamingTheSection) {
  test::TempDir dir;
  const auto path = dir / "sections.strata";
  write_sample(path);
  forge::edit_metadata_in_place(path, [](nlohmann::json& m) { std::swap(m["sections"]["first"], m["sections"]["second"]); });
  const ContainerReader r(path);
  const std::string msg = format_error_of([&] { r.section("first"); });
  EXPECT_TRUE(contains(msg, "sections.strata: section first: checksum mismatch")) << msg;

  // Under the 1.2 rule the swap went unnoticed.
  const auto old = dir / "old.strata";
  write_sample(old);
  forge::downgrade_to_1_2(old);
  forge::edit_metadata_in_place(old, [](nlohmann::json& m) { std::swap(m["sections"]["first"], m["sections"]["second"]); });
  EXPECT_EQ(format_error_of([&] { read_everything(old); }), "");
}

// The index's min, max and histogram columns edited, the index and header checksums fixed: no
// check value covered them, and renders followed the edit (a constant brick's value, culling).
TEST(StoreBoundChecksums, EditedMinMaxOrHistogramIsRefused) {
  test::TempDir dir;
  struct Case {
    std::string what;
    std::function<void(std::vector<std::byte>&)> edit;
  };
  const std::vector<Case> cases{
      {"constant value", [](std::vector<std::byte>& c) {  // brick 2: 3.0f -> 5.0f as min and max
         c[kMinColumn + 2 * kEntries + 2] = std::byte{0xa0};
         c[kMaxColumn + 2 * kEntries + 2] = std::byte{0xa0};
       }},
      {"max", [](std::vector<std::byte>& c) { c[kMaxColumn + 3 * kEntries + 0] = std::byte{0x40}; }},  // 1.0f -> 4.0f
      {"histogram", [](std::vector<std::byte>& c) { c[kHistogramColumn + 7 * kEntries + 1] = std::byte{0x80}; }},
  };
  for (const Case& c : cases) {
    const auto path = dir / "ranges.strata";
    write_sample(path);
    forge::rewrite_index_columns(path, c.edit);
    const std::string msg = format_error_of([&] { ContainerReader r(path); });
    EXPECT_TRUE(contains(msg, "ranges.strata: index: ") && contains(msg, "metadata.bricks_crc32c")) << c.what << ": " << msg;
  }
}

// The index edited and metadata.bricks_crc32c fixed to match (the metadata checksum too): the
// metadata no longer is the one the payloads were bound to, so every payload fails.
TEST(StoreBoundChecksums, EditedIndexWithItsCheckValueFixedFailsEveryPayload) {
  test::TempDir dir;
  const auto path = dir / "ranges.strata", consistent = dir / "consistent.strata";
  write_sample(path);
  // What bricks_crc32c becomes with brick 0's max at 4: a file written with it.
  forge::rewrite(path, consistent, nullptr, [](std::vector<forge::Brick>& bricks) { bricks[0].entry.max = 4.0f; });
  nlohmann::json m = ContainerReader(path).metadata();
  m["bricks_crc32c"] = ContainerReader(consistent).metadata()["bricks_crc32c"];
  forge::rewrite_index_columns(path, [](std::vector<std::byte>& c) { c[kMaxColumn + 3 * kEntries + 0] = std::byte{0x40}; });
  forge::replace_metadata_text(path, m.dump());
  const ContainerReader r(path);
  EXPECT_EQ(r.find({0, 0, 0, 0})->max, 4.0f);
  for (const BrickEntry& e : r.bricks()) {
    if (e.size == 0) continue;
    const std::string msg = format_error_of([&] { r.payload(e); });
    EXPECT_TRUE(contains(msg, "ranges.strata: " + brick_name(e.key) + ": payload checksum mismatch")) << msg;
  }
}

TEST(StoreBoundChecksums, MissingBricksCheckValueIsRefused) {
  test::TempDir dir;
  const auto path = dir / "missing.strata";
  write_sample(path);
  forge::edit_metadata_in_place(path, [](nlohmann::json& m) { m.erase("bricks_crc32c"); });
  const std::string msg = format_error_of([&] { ContainerReader r(path); });
  EXPECT_TRUE(contains(msg, "missing.strata: metadata.bricks_crc32c: missing")) << msg;
}

// A 1.2 file (written with the old rule: checksums of the bytes alone) reads unchanged.
TEST(StoreBoundChecksums, FilesOfFormat12KeepTheOldRule) {
  test::TempDir dir;
  const auto path = dir / "v12.strata";
  write_sample(path);
  const ContainerReader now(path);
  const auto want = now.payload(*now.find({0, 2, 0, 0}));
  const std::vector<std::byte> expected(want.begin(), want.end());
  forge::downgrade_to_1_2(path);
  const ContainerReader r(path);
  EXPECT_EQ(r.version_minor(), 2u);
  const auto got = r.payload(*r.find({0, 2, 0, 0}));
  EXPECT_TRUE(std::equal(got.begin(), got.end(), expected.begin(), expected.end()));
  EXPECT_EQ(r.find({0, 2, 0, 0})->crc32c, crc32c(got.data(), got.size()));
  read_everything(path);
}

TEST(StoreContainerChecks, ConstantBrickWithPayloadBytesIsRejected) {
  test::TempDir dir;
  const auto path = dir / "constant.strata";
  {
    ContainerWriter w(path);
    w.add_brick({{0, 0, 0, 0}, PayloadKind::constant, 0, 0, 0, 2, 2, 1}, random_bytes(16, 1));
    w.finish({});
  }
  std::string msg = format_error_of([&] { ContainerReader r(path); });
  EXPECT_TRUE(contains(msg, "constant.strata: brick (level 0, 0,0,0): a constant brick has no payload") && contains(msg, "16"))
      << msg;
  {
    ContainerWriter w(path);
    w.add_brick({{0, 0, 0, 0}, PayloadKind::constant, 0, 0, 0, 2, 5, 1}, {});
    w.finish({});
  }
  msg = format_error_of([&] { ContainerReader r(path); });
  EXPECT_TRUE(contains(msg, "constant.strata: brick (level 0, 0,0,0): a constant brick needs min == max")) << msg;
}

// Wrong JSON types in "sections" or metadata that is not an object: one message naming the file
// and the field, never the JSON library's text.
TEST(StoreContainerChecks, MalformedSectionsAndMetadataNameTheField) {
  test::TempDir dir;
  struct Case {
    std::string expect;
    std::string text;
  };
  const std::vector<Case> cases{
      {"metadata.sections.first.offset: expected an integer", R"({"sections": {"first": {"offset": "64", "size": 1, "crc32c": 0}}})"},
      {"metadata.sections.first.size: expected an integer", R"({"sections": {"first": {"offset": 64, "size": -1, "crc32c": 0}}})"},
      {"metadata.sections.first.crc32c: expected an integer in [0, 4294967295]",
       R"({"sections": {"first": {"offset": 64, "size": 1, "crc32c": 4294967296}}})"},
      {"metadata.sections.first.crc32c: missing", R"({"sections": {"first": {"offset": 64, "size": 1}}})"},
      {"metadata.sections.first: expected an object", R"({"sections": {"first": [64, 1, 0]}})"},
      {"metadata.sections: expected an object", R"({"sections": [1, 2]})"},
      {"section first: range [64, +100000)", R"({"sections": {"first": {"offset": 64, "size": 100000, "crc32c": 0}}})"},
      {"metadata: expected a JSON object, got array", R"([1, 2, 3])"},
      {"metadata: invalid JSON", R"({"codec": "ta-bricked", )"},
  };
  int i = 0;
  for (const Case& c : cases) {
    const auto path = dir / fmt::format("m{}.strata", i++);
    write_sample(path);
    forge::replace_metadata_text(path, c.text);
    const std::string msg = format_error_of([&] { ContainerReader r(path); });
    EXPECT_TRUE(contains(msg, path.filename().string() + ": " + c.expect)) << c.text << "\n" << msg;
    EXPECT_FALSE(contains(msg, "json.exception") || contains(msg, "FOREIGN")) << msg;
  }
}

// Every truncation and a flipped byte anywhere in the header, metadata or index: a FormatError,
// never a crash, a foreign exception or a huge allocation.
TEST(StoreContainerChecks, TruncatedOrDamagedFilesAreFormatErrors) {
  test::TempDir dir;
  const auto good = dir / "good.strata";
  write_sample(good);
  const auto bytes = forge::file_bytes(good);
  const auto damaged = dir / "damaged.strata";
  for (std::size_t size = 0; size < bytes.size(); ++size) {
    forge::write_file(damaged, std::span(bytes).first(size));
    const std::string msg = format_error_of([&] { read_everything(damaged); });
    EXPECT_TRUE(contains(msg, "damaged.strata: ") && !contains(msg, "FOREIGN")) << size << ": " << msg;
  }
  for (std::size_t at = 0; at < bytes.size(); ++at) {
    auto copy = bytes;
    copy[at] ^= std::byte{0x5A};
    forge::write_file(damaged, copy);
    const std::string msg = format_error_of([&] { read_everything(damaged); });
    EXPECT_TRUE(msg.empty() || (contains(msg, "damaged.strata: ") && !contains(msg, "FOREIGN"))) << at << ": " << msg;  // padding is not covered
  }
}

// The labels' `normals` section holds a whole container, opened in place like a volume set's
// member: its check value was never compared, so 0 (or another section's) went through. Here a
// file of format 1.5, whose sections' check values cover their bytes.
TEST(StoreBoundChecksums, ANormalsSectionIsCheckedWhenOpened) {
  test::TempDir dir;
  const auto path = dir / "labels.strata";
  std::filesystem::copy_file(test::test_data("labels_normals_v1_5.strata"), path);
  {
    const ContainerReader outer(path);
    EXPECT_EQ(ContainerReader(outer, "normals", "labels (normals)").metadata()["codec"], "mixture-graph");
  }
  forge::edit_metadata_in_place(path, [](nlohmann::json& m) { m["sections"]["normals"]["crc32c"] = 0; });
  const ContainerReader outer(path);
  const std::string msg = format_error_of([&] { ContainerReader(outer, "normals", "labels (normals)"); });
  EXPECT_TRUE(contains(msg, "labels.strata: section normals: checksum mismatch")) << msg;
}

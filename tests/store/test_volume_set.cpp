// Volume sets (format 1.5, store/volume_set.hpp): several complete containers as sections of
// one file. A member opens like a file of its own (same metadata, bricks and payloads, with
// every check applied inside its section), messages name the member, and a set is refused
// without a choice of volume.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "io/io_test_util.hpp"
#include "store/forge.hpp"
#include "strata/core/error.hpp"
#include "strata/store/volume_set.hpp"
#include "support/test_support.hpp"

namespace strata::store {
namespace {

namespace fs = std::filesystem;
using test::error_of;
namespace forge = strata::test::forge;

// A container of `bricks` payload bricks of different kinds and sizes (aligned and packed
// payloads, so a member's offsets are exercised both ways), and one section.
void write_member(const fs::path& path, int bricks, std::uint32_t seed) {
  std::mt19937 rng(seed);
  ContainerWriter w(path);
  for (int i = 0; i < bricks; ++i) {
    std::vector<std::byte> payload(std::size_t(17 + 29 * i));
    for (auto& b : payload) b = std::byte(rng());
    BrickEntry e;
    e.key = {0, i, 0, 0};
    e.kind = i % 2 ? PayloadKind::tucker_coded : PayloadKind::tucker_zstd;
    e.min = float(i);
    e.max = float(i + 1);
    w.add_brick(e, payload);
  }
  const std::vector<std::byte> extra(100, std::byte(seed));
  w.add_section("extra", extra);
  w.finish({{"codec", "ta-bricked"}, {"seed", seed}});
}

struct StoreVolumeSet : ::testing::Test {
  test::TempDir dir;
  fs::path a = dir / "a.strata", b = dir / "b.strata", set = dir / "set.strata";
  void SetUp() override {
    write_member(a, 3, 1);
    write_member(b, 5, 2);
    write_volume_set(set, {a, b}, {{"file", "series.nii"}});
  }
};

void expect_same_container(const ContainerReader& member, const ContainerReader& original) {
  EXPECT_EQ(member.metadata(), original.metadata());
  ASSERT_EQ(member.bricks().size(), original.bricks().size());
  for (const BrickEntry& e : original.bricks()) {
    const BrickEntry* m = member.find(e.key);
    ASSERT_NE(m, nullptr);
    const auto x = member.payload(*m), y = original.payload(e);
    EXPECT_TRUE(std::equal(x.begin(), x.end(), y.begin(), y.end()));
  }
  const auto x = member.section("extra"), y = original.section("extra");
  EXPECT_TRUE(std::equal(x.begin(), x.end(), y.begin(), y.end()));
  EXPECT_EQ(member.file_size(), fs::file_size(original.path()));
}

TEST_F(StoreVolumeSet, EveryMemberOpensLikeItsOwnFile) {
  const ContainerReader outer(set);
  ASSERT_TRUE(is_volume_set(outer));
  EXPECT_EQ(volume_count(outer), 2);
  EXPECT_EQ(outer.metadata()["source"]["file"], "series.nii");
  expect_same_container(*open_volume(set, 0), ContainerReader(a));
  expect_same_container(*open_volume(set, 1), ContainerReader(b));
  EXPECT_EQ(open_volume(set, 1)->name(), set.string() + " (volume 1)");
  EXPECT_EQ(open_volume(set, 1)->path(), set);
  // A member's tucker payloads stay 64-byte aligned in memory (sections are aligned).
  const auto member = open_volume(set, 1);
  for (const BrickEntry& e : member->bricks()) {
    if (needs_alignment(e.kind)) {
      EXPECT_EQ(reinterpret_cast<std::uintptr_t>(member->payload(e).data()) % 64, 0u);
    }
  }
}

TEST_F(StoreVolumeSet, AVolumeMustBeChosenAndExist) {
  const std::string none = error_of([&] { open_volume(set, std::nullopt); });
  EXPECT_NE(none.find("holds 2 volumes; choose one with --volume T (0..1)"), std::string::npos) << none;
  EXPECT_THROW(open_volume(set, 2), ParameterError);
  EXPECT_NE(error_of([&] { open_volume(set, 2); }).find("volume 2 does not exist; the file holds 2 (0..1)"),
            std::string::npos);
  // A file of one volume opens without a choice or as volume 0, and refuses any other.
  EXPECT_FALSE(is_volume_set(*open_volume(a, std::nullopt)));
  EXPECT_EQ(open_volume(a, 0)->name(), a.string());
  EXPECT_NE(error_of([&] { open_volume(a, 1); }).find("holds one volume"), std::string::npos);
}

TEST_F(StoreVolumeSet, AOneMemberSetOpensWithoutAChoice) {
  const fs::path one = dir / "one.strata";
  write_volume_set(one, {b}, {});
  expect_same_container(*open_volume(one, std::nullopt), ContainerReader(b));
}

TEST_F(StoreVolumeSet, ACorruptMemberIsNamedByItsVolume) {
  auto bytes = test::io::read_bytes(set);
  const ContainerReader outer(set);
  const auto member = open_volume(set, 1);
  // Flip a byte inside member 1's first payload: its own checksum catches it, naming the member.
  const BrickEntry& e = member->bricks().front();
  const std::size_t at = std::size_t(outer.metadata()["sections"]["volume_1"]["offset"].get<std::uint64_t>() + e.offset);
  bytes[at] ^= std::byte{1};
  const fs::path bad = dir / "bad.strata";
  test::io::write_bytes(bad, bytes);
  const auto opened = open_volume(bad, 1);
  const std::string message = error_of([&] { opened->payload(opened->bricks().front()); });
  EXPECT_NE(message.find("bad.strata (volume 1): brick (level 0, 0,0,0)"), std::string::npos) << message;
  EXPECT_NE(message.find("payload checksum mismatch"), std::string::npos) << message;
  // The outer section's check value covers the member's header, which roots the payload's check
  // value: a byte of the header flipped fails it, when the member is opened or read whole.
  bytes[at] ^= std::byte{1};
  bytes[std::size_t(outer.metadata()["sections"]["volume_1"]["offset"].get<std::uint64_t>() + 20)] ^= std::byte{1};
  test::io::write_bytes(bad, bytes);
  EXPECT_NE(error_of([&] { open_volume(bad, 1); }).find("bad.strata: section volume_1: checksum mismatch"), std::string::npos);
  EXPECT_THROW(ContainerReader(bad).section("volume_1"), FormatError);
}

// Sections volume_0 and volume_1 swapped in metadata.sections, only the metadata checksum fixed:
// `--volume 1` read volume 0, silently, while members were not checked against their sections.
TEST_F(StoreVolumeSet, SwappedMembersAreRefusedNamingTheSection) {
  forge::edit_metadata_in_place(set, [](nlohmann::json& m) { std::swap(m["sections"]["volume_0"], m["sections"]["volume_1"]); });
  for (const int i : {0, 1}) {
    const std::string message = error_of([&] { open_volume(set, i); });
    EXPECT_NE(message.find(set.string() + ": section volume_" + std::to_string(i) + ": checksum mismatch"), std::string::npos)
        << message;
    EXPECT_NE(message.find("belongs to another section"), std::string::npos) << message;
  }
}

// A member's check value of 0 (a forger's "no checksum") was accepted: nothing compared it.
TEST_F(StoreVolumeSet, AMemberCheckValueOfZeroIsRefused) {
  forge::edit_metadata_in_place(set, [](nlohmann::json& m) { m["sections"]["volume_1"]["crc32c"] = 0; });
  const std::string message = error_of([&] { open_volume(set, 1); });
  EXPECT_NE(message.find(set.string() + ": section volume_1: checksum mismatch"), std::string::npos) << message;
  EXPECT_NE(message.find("0x00000000"), std::string::npos) << message;
  expect_same_container(*open_volume(set, 0), ContainerReader(a));
}

// Member 0's bytes replaced by another valid container of the same size: every check of the
// member passes, the section's check value does not.
TEST_F(StoreVolumeSet, AMemberReplacedByAnotherContainerIsRefused) {
  const fs::path other = dir / "other.strata";
  write_member(other, 3, 7);
  const auto replacement = test::io::read_bytes(other);
  ASSERT_EQ(replacement.size(), fs::file_size(a));
  auto bytes = test::io::read_bytes(set);
  const auto offset = ContainerReader(set).metadata()["sections"]["volume_0"]["offset"].get<std::size_t>();
  std::copy(replacement.begin(), replacement.end(), bytes.begin() + std::ptrdiff_t(offset));
  test::io::write_bytes(set, bytes);
  EXPECT_NO_THROW(ContainerReader{set});
  const std::string message = error_of([&] { open_volume(set, 0); });
  EXPECT_NE(message.find(set.string() + ": section volume_0: checksum mismatch"), std::string::npos) << message;
  expect_same_container(*open_volume(set, 1), ContainerReader(b));
}

// A set written by format 1.5 (fuzz seed of then: two members of one 10x9x8 series) still opens,
// and its members are checked against their sections' check values of then (the whole bytes).
TEST(StoreVolumeSetV15, OpensAndChecksItsMembers) {
  test::TempDir dir;
  const fs::path old = dir / "old.strata";
  fs::copy_file(test::test_data("volume_set_v1_5.strata"), old);
  ASSERT_EQ(ContainerReader(old).version_minor(), 5u);
  for (const int i : {0, 1}) {
    const auto member = open_volume(old, i);
    for (const BrickEntry& e : member->bricks()) member->payload(e);
  }
  forge::edit_metadata_in_place(old, [](nlohmann::json& m) { std::swap(m["sections"]["volume_0"], m["sections"]["volume_1"]); });
  std::string message = error_of([&] { open_volume(old, 1); });
  EXPECT_NE(message.find(old.string() + ": section volume_1: checksum mismatch"), std::string::npos) << message;
  forge::edit_metadata_in_place(old, [](nlohmann::json& m) {
    std::swap(m["sections"]["volume_0"], m["sections"]["volume_1"]);
    m["sections"]["volume_0"]["crc32c"] = 0;
  });
  EXPECT_NO_THROW(open_volume(old, 1));
  message = error_of([&] { open_volume(old, 0); });
  EXPECT_NE(message.find(old.string() + ": section volume_0: checksum mismatch"), std::string::npos) << message;
}

TEST_F(StoreVolumeSet, ForgedSetsAreRefusedByField) {
  const auto write_set = [&](const fs::path& path, const nlohmann::json& metadata, const std::vector<fs::path>& members) {
    ContainerWriter w(path);
    for (std::size_t i = 0; i < members.size(); ++i) {
      const auto bytes = test::io::read_bytes(members[i]);
      w.add_container_section("volume_" + std::to_string(i), bytes);
    }
    w.finish(metadata);
  };
  const fs::path forged = dir / "forged.strata";
  write_set(forged, {{"codec", kVolumeSetCodec}, {"volume_count", 3}}, {a, b});
  EXPECT_NE(error_of([&] { open_volume(forged, 0); }).find("metadata.sections: no section 'volume_2'"), std::string::npos);
  write_set(forged, {{"codec", kVolumeSetCodec}, {"volume_count", 0}}, {a});
  EXPECT_NE(error_of([&] { open_volume(forged, 0); }).find("metadata.volume_count"), std::string::npos);
  write_set(forged, {{"codec", kVolumeSetCodec}}, {a});
  EXPECT_NE(error_of([&] { open_volume(forged, 0); }).find("metadata.volume_count"), std::string::npos);
  // A set inside a set, and a member that is not a container, are refused naming the member.
  write_set(forged, {{"codec", kVolumeSetCodec}, {"volume_count", 1}}, {set});
  EXPECT_NE(error_of([&] { open_volume(forged, 0); }).find("(volume 0): metadata.codec"), std::string::npos);
  EXPECT_THROW(write_volume_set(dir / "nested.strata", {set}, {}), ParameterError);
  EXPECT_FALSE(fs::exists(dir / "nested.strata"));
  const fs::path junk = dir / "junk.bin";
  test::io::write_bytes(junk, std::vector<std::byte>(300, std::byte{7}));
  write_set(forged, {{"codec", kVolumeSetCodec}, {"volume_count", 1}}, {junk});
  EXPECT_NE(error_of([&] { open_volume(forged, 0); }).find("forged.strata (volume 0): magic"), std::string::npos);
  // A member cut short: its ranges are checked against the section, not the whole file.
  auto cut = test::io::read_bytes(a);
  cut.resize(cut.size() - 10);
  test::io::write_bytes(junk, cut);
  write_set(forged, {{"codec", kVolumeSetCodec}, {"volume_count", 1}}, {junk, b});
  EXPECT_THROW(open_volume(forged, 0), FormatError);
}

}  // namespace
}  // namespace strata::store

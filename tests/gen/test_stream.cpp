// generate_to_file: streamed slabs equal the in-memory volume, and progress adds up.
#include <gtest/gtest.h>

#include <string>

#include "gen/gen_test_util.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata::gen {
namespace {

class RecordingSink : public ProgressSink {
 public:
  void begin(std::string_view task, std::uint64_t total, std::string_view) override {
    task_ = task;
    total_ = total;
    ++begun_;
  }
  void advance(std::uint64_t units) override { done_ += units; }
  void end() override { ++ended_; }
  std::string task_;
  std::uint64_t total_ = 0, done_ = 0;
  int begun_ = 0, ended_ = 0;
};

TEST(GenStream, FileEqualsInMemoryVolume) {
  strata::test::TempDir dir;
  // 100 slices: several streamed slabs of 16..64 slices plus a partial one.
  const auto p = helpers::params(Kind::fibres, {40, 30, 100}, 5, 50);
  RecordingSink sink;
  generate_to_file(p, dir / "fibres.nrrd", sink);
  EXPECT_TRUE(io::read_volume(dir / "fibres.nrrd") == generate(p));
  EXPECT_EQ(sink.task_, "generate");
  EXPECT_EQ(sink.total_, 40u * 30u * 100u);
  EXPECT_EQ(sink.done_, sink.total_);
  EXPECT_EQ(sink.begun_, 1);
  EXPECT_EQ(sink.ended_, 1);
}

TEST(GenStream, ScalarKindToRaw) {
  strata::test::TempDir dir;
  const auto p = helpers::params(Kind::prisms, {33, 17, 70}, 2);
  generate_to_file(p, dir / "prisms.raw", silent_progress());
  io::ReadOptions options;
  options.raw_dims = p.dims;
  options.raw_dtype = DType::u16;
  EXPECT_TRUE(io::read_volume(dir / "prisms.raw", options) == generate(p));
}

TEST(GenStream, BadParamsLeaveNoFile) {
  strata::test::TempDir dir;
  EXPECT_THROW(generate_to_file(helpers::params(Kind::sphere, {0, 4, 4}), dir / "bad.nrrd", silent_progress()), Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.nrrd"));
}

}  // namespace
}  // namespace strata::gen

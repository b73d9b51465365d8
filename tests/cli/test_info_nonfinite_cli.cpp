// `strata info` and `strata compare` on float volumes with NaN (masked voxels) and infinities:
// they are counted apart and the figures describe the finite voxels.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include <nlohmann/json.hpp>

#include "cli/cli_test_util.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata {
namespace {

TEST(CliNonFinite, InfoAndCompareCountNanAndInfinitiesApart) {
  test::TempDir dir;
  Volume v(Extent{4, 3, 2}, DType::f32);
  auto s = v.samples<float>();
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = float(i);  // 0..23
  s[0] = std::numeric_limits<float>::quiet_NaN();
  s[5] = std::numeric_limits<float>::quiet_NaN();
  s[23] = std::numeric_limits<float>::infinity();
  io::write_volume(dir / "masked.nrrd", v);
  std::string out;
  ASSERT_EQ(test::run_command(test::strata_cmd("info " + test::shell_quoted(dir / "masked.nrrd") + " --json"), &out), 0)
      << out;
  const auto j = nlohmann::json::parse(out);
  EXPECT_EQ(j["non_finite"]["nan"], 2);
  EXPECT_EQ(j["non_finite"]["positive_infinity"], 1);
  EXPECT_EQ(j["non_finite"]["negative_infinity"], 0);
  EXPECT_EQ(j["min"].get<double>(), 1.0);
  EXPECT_EQ(j["max"].get<double>(), 22.0);
  // 1..22 without 5: 21 values summing to 253 - 5.
  EXPECT_DOUBLE_EQ(j["mean"].get<double>(), 248.0 / 21.0);
  std::uint64_t binned = 0;
  for (const auto& c : j["histogram"]) binned += c.get<std::uint64_t>();
  EXPECT_EQ(binned, 21u);
  ASSERT_EQ(test::run_command(test::strata_cmd("info " + test::shell_quoted(dir / "masked.nrrd")), &out), 0) << out;
  EXPECT_NE(out.find("non-finite:  2 NaN, 1 +inf, 0 -inf"), std::string::npos) << out;
  EXPECT_NE(out.find("range:       [1, 22]"), std::string::npos) << out;

  // A copy that lost one NaN (decoded as 7) and is 0.5 off elsewhere: the NaN it kept and the
  // infinity match, the lost one does not, and the error is that of the finite voxels.
  Volume lost = v;
  auto l = lost.samples<float>();
  l[5] = 7;
  l[10] += 0.5f;
  io::write_volume(dir / "lost.nrrd", lost);
  ASSERT_EQ(test::run_command(test::strata_cmd("compare " + test::shell_quoted(dir / "masked.nrrd") + " " +
                                               test::shell_quoted(dir / "lost.nrrd") + " --json"),
                              &out),
            0)
      << out;
  const auto c = nlohmann::json::parse(out);
  EXPECT_EQ(c["voxels"], 21);
  EXPECT_EQ(c["masked_matched"], 2);
  EXPECT_EQ(c["masked_mismatched"], 1);
  EXPECT_EQ(c["max_abs_error"].get<double>(), 0.5);
}

}  // namespace
}  // namespace strata

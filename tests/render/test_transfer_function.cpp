// Transfer functions: JSON format and its errors, evaluation, opacity correction, tables and
// the histogram-bin mask lod culls with.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "strata/core/error.hpp"
#include "strata/render/transfer_function.hpp"
#include "support/test_support.hpp"

using namespace strata;
using namespace strata::render;

namespace {

std::string load_error(const test::TempDir& dir, const std::string& text) {
  const auto path = dir / "tf.json";
  std::ofstream(path) << text;
  try {
    TransferFunction::load(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

bool has(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// alpha 0 up to x0, then a ramp to a1 at x1 and flat after; white.
TransferFunction ramp(double x0, double x1, float a1) {
  return TransferFunction({{0, {1, 1, 1, 0}}, {x0, {1, 1, 1, 0}}, {x1, {1, 1, 1, a1}}, {1, {1, 1, 1, a1}}});
}

}  // namespace

TEST(RenderTransferFunction, LoadsTheDocumentedFormat) {
  test::TempDir dir;
  const auto path = dir / "tf.json";
  std::ofstream(path) << R"({"range": [10, 20], "points": [{"x": 0, "rgba": [0, 0, 0, 0]},
                                                             {"x": 0.5, "rgba": [1, 0.5, 0.25, 0.5]},
                                                             {"x": 1, "rgba": [1, 1, 1, 1]}]})";
  const TransferFunction tf = TransferFunction::load(path);
  ASSERT_EQ(tf.points().size(), 3u);
  ASSERT_TRUE(tf.range().has_value());
  EXPECT_EQ(tf.mapping(0, 100).lo, 10);
  EXPECT_EQ(tf.mapping(0, 100).hi, 20);
  const Rgbaf c = tf.evaluate(0.25);
  EXPECT_FLOAT_EQ(c.r, 0.5f);
  EXPECT_FLOAT_EQ(c.g, 0.25f);
  EXPECT_FLOAT_EQ(c.a, 0.25f);
  // Round trip through to_json.
  const TransferFunction again = TransferFunction::from_json(tf.to_json(), "copy");
  EXPECT_EQ(again.points().size(), 3u);
  EXPECT_FLOAT_EQ(again.evaluate(0.75).a, tf.evaluate(0.75).a);
}

TEST(RenderTransferFunction, ErrorsNameTheFileAndTheField) {
  test::TempDir dir;
  const std::string file = (dir / "tf.json").string();
  struct Case {
    const char* text;
    const char* field;
  };
  const Case cases[] = {
      {R"({"point": []})", "points"},
      {R"({"points": []})", "points"},
      {R"({"points": [{"x": 0.5}]})", "points[0].rgba"},
      {R"({"points": [{"rgba": [1, 1, 1, 1]}]})", "points[0].x"},
      {R"({"points": [{"x": 0.1, "rgba": [1, 1, 1, 1]}, {"x": 0.5, "rgba": [1, 1, 1]}]})", "points[1].rgba"},
      {R"({"points": [{"x": 0.1, "rgba": [1, 1, 1, 1]}, {"x": 0.5, "rgba": [1, 1, 2, 1]}]})", "points[1].rgba[2]"},
      {R"({"points": [{"x": 0.5, "rgba": [1, 1, 1, 1]}, {"x": 0.2, "rgba": [1, 1, 1, 1]}]})", "points[1].x"},
      {R"({"points": [{"x": 1.5, "rgba": [1, 1, 1, 1]}]})", "points[0].x"},
      {R"({"points": [{"x": "a", "rgba": [1, 1, 1, 1]}]})", "points[0].x"},
      {R"({"points": [{"x": 0, "rgba": [1, 1, 1, 1]}], "range": [5, 5]})", "range"},
      {R"({"points": [{"x": 0, "rgba": [1, 1, 1, 1]}], "range": [5]})", "range"},
      {R"({"points": [)", "(document)"},
  };
  for (const Case& c : cases) {
    const std::string msg = load_error(dir, c.text);
    EXPECT_TRUE(has(msg, file)) << c.text << " -> " << msg;
    EXPECT_TRUE(has(msg, std::string(": ") + c.field + ":")) << c.text << " -> " << msg;
  }
  EXPECT_TRUE(has(load_error(dir, "{}"), file));
  try {
    TransferFunction::load(dir / "absent.json");
    FAIL();
  } catch (const Error& e) {
    EXPECT_TRUE(has(e.what(), "absent.json"));
  }
}

TEST(RenderTransferFunction, PresetsLoadAndUnknownNamesAreListed) {
  for (std::string_view name : TransferFunction::preset_names()) {
    const TransferFunction tf = TransferFunction::preset(name);
    EXPECT_NE(tf.visible_bins(0, 1), 0u) << name;
  }
  try {
    TransferFunction::preset("nope");
    FAIL();
  } catch (const Error& e) {
    EXPECT_TRUE(has(e.what(), "grayscale")) << e.what();
  }
  EXPECT_EQ(TransferFunction::from_argument("fire").points().size(), TransferFunction::preset("fire").points().size());
  EXPECT_EQ(test::parameter_of([] { TransferFunction::from_argument("no-such-file.json"); }), "preset_or_path");
}

TEST(RenderTransferFunction, EqualXMakesARightContinuousStep) {
  const TransferFunction tf({{0.5, {1, 0, 0, 0}}, {0.5, {0, 1, 0, 1}}});
  EXPECT_FLOAT_EQ(tf.evaluate(0.4999).a, 0);
  EXPECT_FLOAT_EQ(tf.evaluate(0.5).a, 1);
  EXPECT_FLOAT_EQ(tf.evaluate(0.5).g, 1);
  EXPECT_FLOAT_EQ(tf.evaluate(-3).r, 1);  // clamped to the end points
  EXPECT_FLOAT_EQ(tf.evaluate(7).g, 1);
}

TEST(RenderTransferFunction, OpacityCorrectionComposesOverSubsteps) {
  const float a = 0.3f;
  EXPECT_FLOAT_EQ(correct_opacity(a, 1.0), a);
  // Two half steps composite to one full step: 1 - (1 - a')^2 = a.
  const float half = correct_opacity(a, 0.5);
  EXPECT_NEAR(1 - (1 - half) * (1 - half), a, 1e-6);
  EXPECT_NEAR(correct_opacity(a, 4.0), 1 - std::pow(0.7, 4.0), 1e-6);
  EXPECT_EQ(correct_opacity(1.0f, 0.01), 1.0f);
  EXPECT_EQ(correct_opacity(0.0f, 100), 0.0f);
}

TEST(RenderTransferFunction, LookupTableIsPremultipliedAndCorrected) {
  const TransferFunction tf({{0, {1, 0.5f, 0, 0.2f}}, {1, {1, 0.5f, 0, 0.2f}}});
  const LookupTable lut = tf.lookup_table(64, 2.0);
  const float a = 1 - 0.8f * 0.8f;
  for (const Rgbaf& e : lut.entries) {
    EXPECT_NEAR(e.a, a, 1e-6);
    EXPECT_NEAR(e.r, a, 1e-6);
    EXPECT_NEAR(e.g, 0.5f * a, 1e-6);
  }
}

TEST(RenderTransferFunction, PreintegratedTableIntegratesTheRamp) {
  // Opaque-ish white above x = 0.5 only. A segment going from 0 to 1 spends half its length
  // above the step, so its opacity is that of half a segment: 1 - (1 - a)^(ratio / 2).
  const float a = 0.4f;
  const TransferFunction tf({{0.5, {1, 1, 1, 0}}, {0.5, {1, 1, 1, a}}});
  const double ratio = 1.5;
  const PreintegratedTable t = tf.preintegrated_table(65, ratio);
  auto at = [&](int f, int b) { return t.entries[std::size_t(f) * 65 + std::size_t(b)]; };
  const double expected = 1 - std::pow(1 - a, ratio / 2);
  // The step is resolved to one sub-segment (1/64 of the segment here).
  const double tol = (1 - std::pow(1 - a, ratio / 64)) + 1e-6;
  EXPECT_NEAR(at(0, 64).a, expected, tol);
  EXPECT_NEAR(at(64, 0).a, expected, tol);
  // Diagonal entries equal the opacity-corrected classification.
  EXPECT_NEAR(at(64, 64).a, correct_opacity(a, ratio), 1e-6);
  EXPECT_EQ(at(0, 0).a, 0);
  EXPECT_EQ(at(0, 31).a, 0);
  // Back-to-front vs front-to-back differ in colour only through self-attenuation; white stays white.
  EXPECT_NEAR(at(0, 64).r, at(0, 64).a, 1e-6);
}

TEST(RenderTransferFunction, PreintegratedColourHasSelfAttenuation) {
  // Red for x < 0.5, green above, both fairly opaque: entering red first hides the green.
  const TransferFunction tf({{0, {1, 0, 0, 0.9f}}, {0.5, {1, 0, 0, 0.9f}}, {0.5, {0, 1, 0, 0.9f}}, {1, {0, 1, 0, 0.9f}}});
  const PreintegratedTable t = tf.preintegrated_table(33, 1.0);
  const Rgbaf red_first = t.entries[std::size_t(0) * 33 + 32], green_first = t.entries[std::size_t(32) * 33 + 0];
  EXPECT_GT(red_first.r, red_first.g);
  EXPECT_GT(green_first.g, green_first.r);
  EXPECT_NEAR(red_first.a, green_first.a, 1e-5);
}

TEST(RenderTransferFunction, VisibleBinsMatchABruteForceScan) {
  const std::vector<TransferFunction> tfs = {
      ramp(0.3, 0.6, 0.5f),
      TransferFunction({{0.2, {1, 1, 1, 0}}, {0.25, {1, 1, 1, 0.3f}}, {0.3, {1, 1, 1, 0}}, {0.9, {1, 1, 1, 0}}}),
      TransferFunction(ramp(0.3, 0.6, 0.5f).points(), std::pair{50.0, 150.0}),
      TransferFunction({{0.0, {1, 1, 1, 0.1f}}, {0.1, {1, 1, 1, 0}}})};
  const double lo = 0, hi = 100;
  for (const TransferFunction& tf : tfs) {
    const std::uint64_t mask = tf.visible_bins(lo, hi);
    const ValueMapping m = tf.mapping(lo, hi);
    for (int bin = 0; bin < 64; ++bin) {
      // Dense scan of the bin's half-open value interval; bins 0 and 63 also take values
      // beyond the range, as the compressor's binning clamps them.
      const double b0 = lo + bin * (hi - lo) / 64, b1 = lo + (bin + 1) * (hi - lo) / 64;
      bool visible = false;
      for (int i = 0; i < 4000 && !visible; ++i) visible = tf.evaluate(m.normalise(b0 + (b1 - b0) * i / 4000.0)).a > 0;
      if (bin == 0) visible = visible || tf.evaluate(m.normalise(lo - 1000)).a > 0;
      if (bin == 63) visible = visible || tf.evaluate(m.normalise(hi + 1000)).a > 0;
      const bool in_mask = (mask >> bin) & 1;
      // The mask is conservative (closed intervals) and exact away from breakpoints: a bin may
      // only be extra when a visible interval starts exactly at its upper edge.
      if (visible) {
        EXPECT_TRUE(in_mask) << "bin " << bin;
      }
      if (!visible && in_mask) {
        EXPECT_GT(tf.evaluate(m.normalise(b1) + 1e-9).a, 0) << "bin " << bin << " is marked but invisible";
      }
    }
  }
  // Exact expectations for the simple ramp: alpha > 0 above x = 0.3, i.e. values above 30,
  // which lie in bins 19 (29.69 .. 31.25) and up.
  EXPECT_EQ(ramp(0.3, 0.6, 0.5f).visible_bins(0, 100), ~std::uint64_t(0) << 19);
  // With a TF range of [50, 150], alpha > 0 above 80: bins 51 (79.69 .. 81.25) and up.
  EXPECT_EQ(tfs[2].visible_bins(0, 100), ~std::uint64_t(0) << 51);
  // A fully transparent TF culls everything.
  EXPECT_EQ(TransferFunction({{0, {1, 1, 1, 0}}, {1, {1, 1, 1, 0}}}).visible_bins(0, 100), 0u);
}

TEST(RenderTransferFunction, VisibleIntervalTest) {
  const TransferFunction tf = ramp(0.3, 0.6, 0.5f);
  EXPECT_FALSE(tf.visible(0.0, 0.29));
  EXPECT_TRUE(tf.visible(0.29, 0.31));
  EXPECT_TRUE(tf.visible(0.9, 2.0));
  EXPECT_FALSE(tf.visible(-5, -1));
}

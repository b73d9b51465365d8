// RenderSource (src/render/render_source.hpp): the openers' table picks one source per kind of
// file, operations a kind does not support raise the documented errors (before any argument is
// checked), supported ones check their arguments, and RenderSession answers through the source.
#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "render/render_source.hpp"
#include "render/render_source_kinds.hpp"
#include "strata/core/error.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/encoded_labels.hpp"
#include "strata/render/render_session.hpp"
#include "strata/ta/compress.hpp"
#include "support/label_volumes.hpp"
#include "support/test_support.hpp"
#include "ta/ta_test_util.hpp"

namespace strata::render {
namespace {

// One file of each kind the openers tell apart, written once: a plain NRRD volume, the same
// volume as a ta-bricked and a ta-global .strata file, and a label file.
class RenderSourceFiles : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir;
    const Volume ball = test::label_ball(24, 7, 12, 9);
    io::write_volume(plain(), ball);
    ta::CompressParams params = ta::testing::params(8, 2, 4, "u16,b8log+");
    ta::testing::compress(ta::testing::as_f32(ball), bricked(), params);
    params.codec_name = ta::kGlobalCodecName;
    ta::testing::compress(ta::testing::as_f32(ball), global(), params);
    mixture::EncodeOptions o;
    o.measure_error = false;
    mixture::encode_labels(ball, labels(), o);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::filesystem::path plain() { return *dir_ / "ball.nrrd"; }
  static std::filesystem::path bricked() { return *dir_ / "ball.strata"; }
  static std::filesystem::path global() { return *dir_ / "ball-global.strata"; }
  static std::filesystem::path labels() { return *dir_ / "labels.strata"; }
  static test::TempDir* dir_;
};

test::TempDir* RenderSourceFiles::dir_ = nullptr;

// The name of the first opener that accepts `path`: the one that opens it.
std::string first_accepting(const std::filesystem::path& path) {
  SourceFile file(path, std::nullopt);
  for (const SourceOpener& opener : source_openers())
    if (opener.accepts(file)) return std::string(opener.name);
  return "";
}

// Throws Error (and not ParameterError) whose message starts with `message`.
void expect_kind_error(const std::function<void()>& call, const std::string& message) {
  try {
    call();
    ADD_FAILURE() << "no error; expected " << message;
  } catch (const ParameterError& e) {
    ADD_FAILURE() << "an argument was checked before the kind: " << e.what();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(message, 0), 0u) << e.what();
  }
}

// Throws ParameterError naming `parameter`.
void expect_parameter_error(const std::function<void()>& call, const std::string& parameter) {
  try {
    call();
    ADD_FAILURE() << "no error; expected one naming " << parameter;
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.parameter(), parameter) << e.what();
  }
}

TEST_F(RenderSourceFiles, TheTableAsksPlainThenLabelsThenScalar) {
  std::vector<std::string> names;
  for (const SourceOpener& opener : source_openers()) names.emplace_back(opener.name);
  EXPECT_EQ(names, (std::vector<std::string>{"plain", "labels", "scalar"}));
  // The names are the kinds the sources report.
  for (const SourceOpener& opener : source_openers())
    EXPECT_TRUE(opener.name == dataset_kind_name(DatasetKind::plain) ||
                opener.name == dataset_kind_name(DatasetKind::labels) ||
                opener.name == dataset_kind_name(DatasetKind::scalar));
}

TEST_F(RenderSourceFiles, EachFileKindOpensItsOwnSource) {
  EXPECT_EQ(first_accepting(plain()), "plain");
  EXPECT_EQ(first_accepting(bricked()), "scalar");
  EXPECT_EQ(first_accepting(global()), "scalar");
  EXPECT_EQ(first_accepting(labels()), "labels");

  const SessionOptions options;
  const auto p = open_render_source(plain(), options);
  EXPECT_NE(dynamic_cast<const PlainSource*>(p.get()), nullptr);
  EXPECT_EQ(p->kind(), DatasetKind::plain);
  const auto b = open_render_source(bricked(), options);
  EXPECT_NE(dynamic_cast<const TaSource*>(b.get()), nullptr);
  EXPECT_EQ(b->kind(), DatasetKind::scalar);
  EXPECT_TRUE(b->feature_scale_ladder().empty());
  const auto g = open_render_source(global(), options);
  EXPECT_NE(dynamic_cast<const TaSource*>(g.get()), nullptr);
  EXPECT_FALSE(g->feature_scale_ladder().empty()) << "ta-global: the feature-scale table";
  const auto l = open_render_source(labels(), options);
  EXPECT_NE(dynamic_cast<const LabelSource*>(l.get()), nullptr);
  EXPECT_EQ(l->kind(), DatasetKind::labels);
  for (const auto* source : {p.get(), b.get(), g.get(), l.get()}) EXPECT_EQ(source->level_dims(0), (Extent{24, 24, 24}));
}

TEST_F(RenderSourceFiles, AContainerIsOpenedOnceAndHandedOver) {
  SourceFile plain_file(plain(), std::nullopt);
  EXPECT_FALSE(plain_file.is_container());
  SourceFile label_file(labels(), std::nullopt);
  ASSERT_TRUE(label_file.is_container());
  EXPECT_EQ(label_file.codec(), mixture::kMixtureCodecName);
  const std::unique_ptr<store::ContainerReader> reader = label_file.take_container();
  ASSERT_NE(reader, nullptr);
  EXPECT_EQ(reader->metadata().value("codec", std::string()), mixture::kMixtureCodecName);
}

TEST_F(RenderSourceFiles, OpeningErrorsComeFromTheOpenerThatAccepted) {
  const std::filesystem::path junk = *dir_ / "junk.nrrd";
  std::ofstream(junk) << "not a volume";
  EXPECT_THROW(RenderSession{junk}, Error);
  SessionOptions tiny;
  tiny.cache_bytes = 16;  // less than one 8^3 brick: refused by the TA source itself
  expect_parameter_error([&] { RenderSession{bricked(), tiny}; }, "SessionOptions::cache_bytes");
}

TEST_F(RenderSourceFiles, LabelOperationsOnOtherKindsNameTheKind) {
  for (const auto& [path, kind] : {std::pair{plain(), "plain"}, std::pair{bricked(), "scalar"}}) {
    RenderSession session(path);
    const std::string message = path.string() + ": not a label volume (this is a " + kind + " volume)";
    const SliceSpec bad{SliceAxis::z, 999, 99, 0};  // the kind is refused before the slice is checked
    expect_kind_error([&] { session.label_slice(bad); }, message);
    expect_kind_error([&] { session.label_fraction_slice(bad, 9); }, message);
    expect_kind_error([&] { session.palette_slice(bad); }, message);
    expect_kind_error([&] { session.label_at({-1, 0, 0}); }, message);
    expect_kind_error([&] { session.set_label_colors(LabelColorMap{}); }, message);
    expect_kind_error([&] { (void)session.labels(); }, message);
    EXPECT_FALSE(session.has_label(9));
    EXPECT_FALSE(session.has_normals());
  }
}

TEST_F(RenderSourceFiles, ValueOperationsOnLabelsAskForLabels) {
  RenderSession session(labels());
  const SliceSpec bad{SliceAxis::z, 999, 99, 0};
  expect_kind_error([&] { session.value_slice(bad); },
                    labels().string() + ": a label volume has no sample values; ask for label slices");
  expect_kind_error([&] { session.value_at({-1, 0, 0}); },
                    labels().string() + ": a label volume has no sample values; ask for the label");
  EXPECT_FALSE(session.has_feature_scale());
  EXPECT_EQ(session.stored_rank(), 0);
}

TEST_F(RenderSourceFiles, SupportedOperationsCheckTheirArguments) {
  RenderSession scalar(bricked()), plain_session(plain()), label_session(labels());
  for (RenderSession* s : {&scalar, &plain_session}) {
    expect_parameter_error([&] { s->value_slice({SliceAxis::z, 3, s->level_count(), 0}); }, "SliceSpec::level");
    expect_parameter_error([&] { s->value_slice({SliceAxis::y, 24, 0, 0}); }, "SliceSpec::index");
    expect_parameter_error([&] { s->value_at({0, 24, 0}); }, "voxel");
    expect_parameter_error([&] { (void)s->level_dims(s->level_count()); }, "level");
  }
  expect_parameter_error([&] { label_session.label_slice({SliceAxis::z, 3, -1, 0}); }, "SliceSpec::level");
  expect_parameter_error([&] { label_session.palette_slice({SliceAxis::x, -1, 0, 0}); }, "SliceSpec::index");
  expect_parameter_error([&] { label_session.label_fraction_slice({SliceAxis::x, 24, 0, 0}, 9); }, "SliceSpec::index");
  expect_parameter_error([&] { label_session.label_at({24, 0, 0}); }, "voxel");
}

TEST_F(RenderSourceFiles, TheSessionAnswersFromItsSource) {
  RenderSession scalar(bricked()), global_session(global()), plain_session(plain()), label_session(labels());
  // The ball: label 9 at the centre, 0 around it.
  EXPECT_EQ(plain_session.value_at({12, 12, 12}), 9.0);
  EXPECT_EQ(plain_session.value_at({0, 0, 0}), 0.0);
  EXPECT_EQ(label_session.label_at({12, 12, 12}), 9);
  EXPECT_NEAR(scalar.value_at({12, 12, 12}), 9.0, 2.0);  // rank 4 of a step edge
  EXPECT_TRUE(label_session.has_label(9));
  EXPECT_FALSE(label_session.has_label(5));
  EXPECT_TRUE(global_session.has_feature_scale());
  EXPECT_FALSE(scalar.has_feature_scale());

  const nlohmann::json p = plain_session.describe(), s = scalar.describe(), l = label_session.describe();
  EXPECT_EQ(p["kind"], "plain");
  EXPECT_EQ(s["kind"], "scalar");
  EXPECT_EQ(l["kind"], "labels");
  EXPECT_EQ(p["levels"], 1);
  EXPECT_EQ(s["levels"], scalar.level_count());
  EXPECT_GT(scalar.level_count(), 1);
  EXPECT_EQ(l["levels"], label_session.level_count());
  EXPECT_EQ(p["rank"], 0);
  EXPECT_EQ(s["rank"], 4);
  EXPECT_EQ(p["dtype"], "u8");
  EXPECT_EQ(l["dtype"], "u8");
  EXPECT_EQ(p["histogram"].size(), 64u);
  EXPECT_EQ(s["histogram"].size(), 64u);
  EXPECT_TRUE(l["histogram"].empty());
  EXPECT_EQ(l["label_count"], 2);
  EXPECT_EQ(p["label_count"], 0);
  EXPECT_TRUE(s["feature_scale_ladder"].empty());
  EXPECT_FALSE(global_session.describe()["feature_scale_ladder"].empty());
  EXPECT_EQ(l["value_range"], (nlohmann::json{0.0, 9.0}));
  EXPECT_EQ(p["value_range"], (nlohmann::json{0.0, 9.0}));

  // Slices of every kind at level 0 show the ball's centre.
  const Slice<float> values = plain_session.value_slice({SliceAxis::z, 12, 0, 0});
  EXPECT_EQ(values.values[std::size_t(12 * values.width + 12)], 9.0f);
  const Slice<std::int64_t> ids = label_session.label_slice({SliceAxis::z, 12, 0, 0});
  EXPECT_EQ(ids.values[std::size_t(12 * ids.width + 12)], 9);
  EXPECT_EQ(ids.values[0], 0);
}

}  // namespace
}  // namespace strata::render

// Transfer functions: the JSON file of `strata render --tf tf.json` (TransferFunction::load) and
// the compact text form of the viewer's `tf` parameter (from_points_text), both over the same
// input; whatever parses is turned into the tables the ray caster samples.
#include <string_view>

#include <nlohmann/json.hpp>

#include "support.hpp"
#include "strata/render/transfer_function.hpp"

namespace {

void use(const strata::render::TransferFunction& tf) {
  (void)tf.to_json();
  (void)tf.mapping(0.0, 4095.0);
  (void)tf.evaluate(0.5);
  (void)tf.visible(0.25, 0.75);
  (void)tf.visible_bins(0.0, 4095.0);
  (void)tf.visible_bins(-1.0, 1.0);
  (void)tf.lookup_table(16 * 32, 0.5);
  (void)tf.preintegrated_table(32, 0.5);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto path = strata::fuzz::write_input("tf.json", text);
  strata::fuzz::run_guarded([&] { use(strata::render::TransferFunction::load(path)); });
  strata::fuzz::run_guarded([&] { use(strata::render::TransferFunction::from_points_text(text)); });
  return 0;
}

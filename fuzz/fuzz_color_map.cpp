// Label colour maps: the JSON file of `strata render --colors` and `labels palette --colors`
// (LabelColorMap::load), then the colours of a few labels and the per-source premultiplied
// table the palette propagation starts from.
#include <cstdint>
#include <vector>

#include "support.hpp"
#include "strata/render/label_color_map.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = strata::fuzz::write_input("colors.json", strata::fuzz::as_bytes(data, size));
  strata::fuzz::run_guarded([&] {
    const auto map = strata::render::LabelColorMap::load(path);
    for (std::int64_t label : {std::int64_t(0), std::int64_t(1), std::int64_t(17), std::int64_t(-3), INT64_MIN, INT64_MAX})
      (void)map.color_of(label);
    static const strata::mixture::LabelMap labels(strata::DType::i32, {-3, 0, 1, 2, 17, 255, 1000});
    (void)map.premultiplied_sources(labels);
  });
  return 0;
}

// A raw volume with its JSON sidecar (`vol.raw` + `vol.raw.json`). The input is the sidecar,
// a line "--", then the raw bytes; without the separator it is all sidecar and the raw file is
// empty.
#include <string_view>

#include "support.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  constexpr std::string_view kSeparator = "\n--\n";
  const std::size_t cut = text.find(kSeparator);
  const std::string_view sidecar = text.substr(0, cut);
  const std::string_view raw = cut == std::string_view::npos ? std::string_view() : text.substr(cut + kSeparator.size());
  strata::fuzz::write_input("input.raw.json", sidecar);
  const auto path = strata::fuzz::write_input("input.raw", raw);
  strata::fuzz::run_guarded([&] { strata::fuzz::read_volume_file(path); });
  return 0;
}

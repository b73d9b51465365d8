// MRC (.mrc), read as `strata info` reads it: the header's dims, mode, axis order, cell and
// extended-header size checked against the file before any sample is mapped.
#include "support.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = strata::fuzz::write_input("input.mrc", strata::fuzz::as_bytes(data, size));
  strata::fuzz::run_guarded([&] { strata::fuzz::read_volume_file(path, {}); });
  return 0;
}

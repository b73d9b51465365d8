// TIFF (one multi-page file), read as `strata info` reads it.
#include <tiffio.h>

#include "support.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  // libtiff's own warnings on stderr would drown the fuzzer's output (errors still reach the reader).
  TIFFSetWarningHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = strata::fuzz::write_input("input.tif", strata::fuzz::as_bytes(data, size));
  strata::fuzz::run_guarded([&] { strata::fuzz::read_volume_file(path); });
  return 0;
}

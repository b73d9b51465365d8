// NIfTI-1 and NIfTI-2 (.nii; a gzip stream is read as .nii.gz), read as `strata info` reads it,
// with volume 0, 1 or 2 chosen by the input's size (files of several volumes need a choice).
#include "support.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const bool gzip = size >= 2 && data[0] == 0x1f && data[1] == 0x8b;
  const auto path = strata::fuzz::write_input(gzip ? "input.nii.gz" : "input.nii", strata::fuzz::as_bytes(data, size));
  strata::io::ReadOptions options;
  options.volume = std::int64_t(size % 3);
  strata::fuzz::run_guarded([&] { strata::fuzz::read_volume_file(path, options); });
  return 0;
}

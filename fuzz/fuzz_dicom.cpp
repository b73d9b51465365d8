// DICOM (.dcm), one file's bytes read as a one-slice (or multi-frame) series, as `strata info`
// reads it: GDCM parses the header up to the pixel data, then our checks (tags present and well
// formed, NumberOfFrames bounded by the pixel data's size, native pixel data long enough) run
// before any pixel data is decoded.
#include "support.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = strata::fuzz::write_input("input.dcm", strata::fuzz::as_bytes(data, size));
  strata::fuzz::run_guarded([&] { strata::fuzz::read_volume_file(path, {}); });
  return 0;
}

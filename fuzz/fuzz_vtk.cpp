// VTK image data (.vti and legacy .vtk, told apart by content), read as `strata info` and
// `strata convert` read it: the XML tags, extents, types and component counts, the base64, zlib
// block tables and ASCII numbers checked before any sample is decoded or mapped.
#include "support.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = strata::fuzz::write_input("input.vti", strata::fuzz::as_bytes(data, size));
  strata::fuzz::run_guarded([&] { strata::fuzz::read_volume_file(path, {}); });
  return 0;
}

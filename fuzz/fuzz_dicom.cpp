// DICOM, our header handling: the input bytes are consumed as tag values (present or not, any
// US number, any text for the DS/IS/UI tags, pixel data of any length) of a well-formed
// explicit-VR little-endian file, which is then read as a one-file series as `strata info` reads
// it: tags parsed, NumberOfFrames bounded by the pixel data, bits, rescale, orientation and
// positions checked, every slab decoded. The file is sometimes cut short, for the element walk
// (src/io/dicom/structure.cpp) that refuses truncated files before GDCM parses them.
//
// Arbitrary bytes are not handed to GDCM: Debian builds it with its `assert`s on, and its parser
// aborts on element structures it finds inconsistent (docs/formats.md); this target checks our
// handling of what it parses.
#include <fuzzer/FuzzedDataProvider.h>

#include "../tests/io/dicom_data.hpp"
#include "support.hpp"

namespace {

using strata::test::io::DicomData;

struct UsTag {
  std::uint16_t group, element;
};
// Rows, Columns, SamplesPerPixel, BitsAllocated, BitsStored, HighBit, PixelRepresentation.
constexpr UsTag kUsTags[] = {{0x0028, 0x0010}, {0x0028, 0x0011}, {0x0028, 0x0002}, {0x0028, 0x0100},
                             {0x0028, 0x0101}, {0x0028, 0x0102}, {0x0028, 0x0103}};
struct TextTag {
  std::uint16_t group, element;
  const char* vr;
};
// SliceThickness, SpacingBetweenSlices, SeriesInstanceUID, ImagePositionPatient,
// ImageOrientationPatient, NumberOfFrames, PixelSpacing, RescaleIntercept, RescaleSlope.
constexpr TextTag kTextTags[] = {{0x0018, 0x0050, "DS"}, {0x0018, 0x0088, "DS"}, {0x0020, 0x000E, "UI"},
                                 {0x0020, 0x0032, "DS"}, {0x0020, 0x0037, "DS"}, {0x0028, 0x0008, "IS"},
                                 {0x0028, 0x0030, "DS"}, {0x0028, 0x1052, "DS"}, {0x0028, 0x1053, "DS"}};

DicomData fuzzed_file(FuzzedDataProvider& in) {
  DicomData d;
  for (const UsTag& t : kUsTags)
    if (in.ConsumeBool()) d.us(t.group, t.element, in.ConsumeIntegral<std::uint16_t>());
  for (const TextTag& t : kTextTags)
    if (in.ConsumeBool()) d.text(t.group, t.element, t.vr, in.ConsumeRandomLengthString(80));
  if (in.ConsumeBool()) {
    const std::vector<std::uint8_t> bytes = in.ConsumeBytes<std::uint8_t>(in.ConsumeIntegralInRange(0, 1 << 16));
    std::vector<std::int16_t> samples((bytes.size() + 1) / 2);
    if (!bytes.empty()) std::memcpy(samples.data(), bytes.data(), bytes.size());
    d.pixels(samples);
  }
  return d;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  const auto path = strata::fuzz::temp_dir() / "input.dcm";
  fuzzed_file(in).write(path);
  if (in.ConsumeBool())  // cut short: the element walk must refuse it before GDCM's parser sees it
    std::filesystem::resize_file(path, in.ConsumeIntegralInRange<std::uintmax_t>(0, std::filesystem::file_size(path)));
  strata::fuzz::run_guarded([&] { strata::fuzz::read_volume_file(path, {}); });
  return 0;
}

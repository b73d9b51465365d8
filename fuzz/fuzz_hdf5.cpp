// HDF5 (.h5), read as `strata info` reads it, from files built out of the fuzz input with the
// HDF5 C API: the input chooses the dataset's rank, shape, sample type (numeric of either byte
// order, strings, 16-bit floats), layout and filters, the geometry attributes with their counts and
// values, a second dataset, and the dataset and volume asked for. The bytes of the file are never
// the fuzz input itself: Debian's libhdf5 1.10 has known crashes on damaged object headers
// (CVE-2020-10810, CVE-2021-37501 and others), which would hide ours. What is fuzzed is our code:
// the dataset listing and choice, the shape and overflow checks, the attribute parsing and the
// hyperslab reads.
#include <hdf5.h>

#include <fuzzer/FuzzedDataProvider.h>

#include <array>
#include <string>
#include <vector>

#include "support.hpp"

namespace {

constexpr std::array<const char*, 6> kAttributes{"spacing", "element_size_um", "origin", "direction", "unit", "space"};
constexpr std::size_t kMaxWrittenBytes = 1 << 16;  // samples written only when the dataset is this small

hid_t sample_type(FuzzedDataProvider& in) {
  static const std::array<hid_t, 20> kTypes{
      H5T_STD_U8LE,  H5T_STD_I8LE,  H5T_STD_U16LE, H5T_STD_I16LE, H5T_STD_U32LE,  H5T_STD_I32LE,  H5T_STD_U64LE,
      H5T_STD_I64LE, H5T_STD_U16BE, H5T_STD_I32BE, H5T_STD_U64BE, H5T_IEEE_F32LE, H5T_IEEE_F64LE, H5T_IEEE_F32BE,
      H5T_IEEE_F64BE, H5T_C_S1,     H5T_STD_B8LE,  H5T_STD_U8BE,  H5T_NATIVE_HBOOL, H5T_STD_I64BE};
  return H5Tcopy(kTypes[in.ConsumeIntegralInRange<std::size_t>(0, kTypes.size() - 1)]);
}

void add_attribute(hid_t dataset, FuzzedDataProvider& in) {
  const char* name = kAttributes[in.ConsumeIntegralInRange<std::size_t>(0, kAttributes.size() - 1)];
  if (H5Aexists(dataset, name) > 0) return;
  if (in.ConsumeBool()) {  // a string, fixed length
    const std::string text = in.ConsumeRandomLengthString(300);
    const hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, text.size() + 1);
    const hid_t space = H5Screate(H5S_SCALAR);
    const hid_t a = H5Acreate2(dataset, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
    if (a >= 0) H5Awrite(a, type, text.c_str()), H5Aclose(a);
    H5Sclose(space), H5Tclose(type);
    return;
  }
  std::vector<double> values(in.ConsumeIntegralInRange<std::size_t>(0, 12));
  for (double& v : values) v = in.ConsumeFloatingPoint<double>();
  const hsize_t count = values.size();
  const hid_t space = count ? H5Screate_simple(1, &count, nullptr) : H5Screate(H5S_NULL);
  const hid_t a = H5Acreate2(dataset, name, in.ConsumeBool() ? H5T_IEEE_F32LE : H5T_STD_I64BE, space, H5P_DEFAULT,
                             H5P_DEFAULT);
  if (a >= 0 && count) H5Awrite(a, H5T_NATIVE_DOUBLE, values.data());
  if (a >= 0) H5Aclose(a);
  H5Sclose(space);
}

// A dataset creation list from the input; `writable` false when libhdf5 cannot write samples through
// it: scale-offset after deflate or fletcher32 corrupts the library's heap on H5Dwrite (a bug in
// libhdf5, not in what is fuzzed). Such a dataset is still created, empty, for the reader to refuse.
hid_t creation_list(FuzzedDataProvider& in, const std::vector<hsize_t>& shape, bool& writable) {
  writable = true;
  const hid_t creation = H5Pcreate(H5P_DATASET_CREATE);
  if (!in.ConsumeBool()) return creation;  // contiguous
  std::vector<hsize_t> chunk(shape.size());
  for (std::size_t a = 0; a < shape.size(); ++a) chunk[a] = in.ConsumeIntegralInRange<hsize_t>(1, std::min<hsize_t>(shape[a], 64));
  H5Pset_chunk(creation, int(chunk.size()), chunk.data());
  const auto filters = in.ConsumeIntegral<std::uint8_t>();
  if (filters & 1) H5Pset_shuffle(creation);
  if (filters & 2) H5Pset_deflate(creation, filters >> 4);
  if (filters & 4) H5Pset_fletcher32(creation);
  if (filters & 8) H5Pset_scaleoffset(creation, H5Z_SO_INT, H5Z_SO_INT_MINBITS_DEFAULT);
  writable = !((filters & 8) && (filters & 6));
  return creation;
}

// One dataset from the input; its samples too when it is small.
void add_dataset(hid_t file, const std::string& name, FuzzedDataProvider& in) {
  std::vector<hsize_t> shape(in.ConsumeIntegralInRange<std::size_t>(1, 6));
  for (hsize_t& d : shape) d = in.ConsumeBool() ? in.ConsumeIntegralInRange<hsize_t>(1, 9) : in.ConsumeIntegralInRange<hsize_t>(1, hsize_t(1) << 40);
  const hid_t type = sample_type(in);
  bool writable = true;
  const hid_t creation = creation_list(in, shape, writable);
  const hid_t links = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(links, 1);
  const hid_t space = H5Screate_simple(int(shape.size()), shape.data(), nullptr);
  const hid_t dataset = H5Dcreate2(file, name.c_str(), type, space, links, creation, H5P_DEFAULT);
  if (dataset >= 0) {
    double bytes = double(H5Tget_size(type));
    for (hsize_t d : shape) bytes *= double(d);
    if (writable && bytes <= kMaxWrittenBytes && H5Tget_class(type) != H5T_STRING) {
      std::vector<std::uint8_t> samples(static_cast<std::size_t>(bytes));
      for (auto& s : samples) s = in.ConsumeIntegral<std::uint8_t>();
      H5Dwrite(dataset, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, samples.data());
    }
    for (int n = in.ConsumeIntegralInRange<int>(0, 6); n > 0; --n) add_attribute(dataset, in);
    H5Dclose(dataset);
  }
  H5Sclose(space), H5Pclose(links), H5Pclose(creation), H5Tclose(type);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  strata::fuzz::init();
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  const auto path = strata::fuzz::temp_dir() / "input.h5";
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (file < 0) return 0;
  add_dataset(file, "/volume", in);
  if (in.ConsumeBool()) add_dataset(file, "/group/" + in.ConsumeRandomLengthString(16), in);
  H5Fclose(file);
  strata::io::ReadOptions options;
  if (in.ConsumeBool()) options.dataset = in.ConsumeRandomLengthString(24);
  if (in.ConsumeBool()) options.volume = in.ConsumeIntegral<std::int64_t>();
  strata::fuzz::run_guarded([&] { strata::fuzz::read_volume_file(path, options); });
  return 0;
}

// HDF5 files (synchrotron micro-CT, simulation output, ilastik and Fiji exports) through the HDF5
// C library (libhdf5, Debian's serial build). A volume is one numeric dataset of shape (z, y, x)
// in C order (x varies fastest), or (t, z, y, x) / (t, c, z, y, x) whose leading axes are the
// volumes of the file. Reads take the dataset named as `file.h5:/group/dataset` or
// ReadOptions::dataset, else the file's only such dataset; each box is one hyperslab read
// (H5Dread applies every filter the library has: deflate, shuffle, fletcher32, szip,
// scale-offset, n-bit). Writes one chunked dataset (default "/volume"), deflate level 4 after
// shuffle, as `<file>.tmp` renamed at finish(). Voxel size and placement travel as dataset
// attributes (hdf5/geometry_attributes.hpp).
//
// What is read from the dataset (HDF5 object header messages, through the C API):
// | message      | call                      | here                                                 |
// | ------------ | ------------------------- | ---------------------------------------------------- |
// | dataspace    | H5Sget_simple_extent_dims | rank 3 (z, y, x), 4 or 5 (leading: volumes)          |
// | datatype     | H5Tget_class/size/sign    | integer or float of 1..8 bytes, either byte order    |
// | layout       | H5Pget_chunk              | chunk shape: sizes the chunk cache                   |
// | filter pipe  | H5Pget_filter2            | every filter must be available (H5Zfilter_avail)     |
// | attributes   | H5Aread                   | spacing, element_size_um, origin, direction, unit    |
#include <hdf5.h>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <limits>
#include <vector>

#include "io/builtin_formats.hpp"
#include "io/hdf5/datasets.hpp"
#include "io/hdf5/geometry_attributes.hpp"
#include "io/hdf5/library.hpp"
#include "io/io_detail.hpp"
#include "strata/core/error.hpp"
#include "strata/io/file_names.hpp"
#include "strata/io/formats.hpp"

namespace strata::io::detail {

namespace {

using hdf5::checked;
using hdf5::error_text;
using hdf5::Handle;
using hdf5::lock_library;

// The HDF5 signature; the library also finds it at 512, 1024, 2048, ... (a user block before it).
constexpr std::array<unsigned char, 8> kSignature{0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
constexpr std::size_t kSniffBytes = 2048 + kSignature.size();
// The chunk cache of a read dataset holds one row of chunks across y and x, within these bounds.
constexpr std::uint64_t kMinChunkCache = 1 << 20, kMaxChunkCache = 64 << 20;
// What the writer holds in memory: the slices of one row of chunks, at most this many bytes
// (the chunk depth is cut to fit; a single larger slice is held alone).
constexpr std::uint64_t kWriteBufferBytes = 64 << 20;
constexpr hsize_t kChunkEdge = 64;
constexpr unsigned kDeflateLevel = 4;
constexpr std::string_view kDefaultDataset = "/volume";

bool has_hdf5_signature(std::span<const std::byte> head) {
  for (std::size_t at = 0; at + kSignature.size() <= head.size(); at = at ? 2 * at : 512)
    if (std::memcmp(head.data() + at, kSignature.data(), kSignature.size()) == 0) return true;
  return false;
}

std::string absolute_name(const std::string& dataset) { return dataset.starts_with('/') ? dataset : "/" + dataset; }

// What the reader learned about the dataset before opening it for reading.
struct Layout {
  VolumeInfo info;
  std::vector<hsize_t> shape;  // C order, rank 3..5
  std::vector<hsize_t> chunk;  // empty when not chunked
};

Handle open_dataset(hid_t file, const std::string& name, hid_t access, const std::string& file_name) {
  const hid_t object = H5Oopen(file, name.c_str(), H5P_DEFAULT);
  if (object < 0) {
    H5Eclear2(H5E_DEFAULT);
    throw FormatError(file_name, "dataset",
                      fmt::format("no dataset '{}' in the file; it holds: {}", name,
                                  hdf5::datasets_text(hdf5::list_datasets(file, 1000))));
  }
  const Handle handle(object, H5Oclose);
  if (H5Iget_type(object) != H5I_DATASET)
    throw FormatError(file_name, "dataset",
                      fmt::format("'{}' is a group, not a dataset; the file holds: {}", name,
                                  hdf5::datasets_text(hdf5::list_datasets(file, 1000))));
  return checked(H5Dopen2(file, name.c_str(), access), H5Dclose, file_name, "dataset", "cannot open " + name);
}

DType dataset_dtype(hid_t dataset, const std::string& name, const std::string& file) {
  const Handle type = checked(H5Dget_type(dataset), H5Tclose, file, "type", "no datatype");
  const auto dtype = hdf5::sample_type(type.get());
  if (!dtype)
    throw FormatError(file, "type",
                      fmt::format("dataset {} holds {} values; a volume holds integers or floats of 1, 2, 4 or 8 bytes",
                                  name, hdf5::type_text(type.get())));
  return *dtype;
}

std::vector<hsize_t> dataset_shape(hid_t dataset, const std::string& name, const std::string& file) {
  const Handle space = checked(H5Dget_space(dataset), H5Sclose, file, "shape", "no dataspace");
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 3 || rank > 5)
    throw FormatError(file, "rank",
                      fmt::format("dataset {} has {} dimensions; a volume has 3 (z, y, x), or 4 or 5 whose leading "
                                  "axes (time, channel) are its volumes",
                                  name, rank));
  std::vector<hsize_t> shape(static_cast<std::size_t>(rank));
  H5Sget_simple_extent_dims(space.get(), shape.data(), nullptr);
  for (hsize_t d : shape)
    if (d == 0 || d > hsize_t(std::numeric_limits<std::int64_t>::max()))
      throw FormatError(file, "shape", fmt::format("dataset {} has an axis of {} samples", name, d));
  return shape;
}

void check_before_scale_offset(hid_t plist, int scale_offset_index, const std::string& name, const std::string& file) {
  for (int i = 0; i < scale_offset_index; ++i) {
    unsigned flags = 0;
    std::size_t values = 0;
    std::array<char, 128> filter_name{};
    const H5Z_filter_t id = H5Pget_filter2(plist, unsigned(i), &flags, &values, nullptr, filter_name.size(),
                                           filter_name.data(), nullptr);
    if (id != H5Z_FILTER_SHUFFLE)
      throw FormatError(file, "filter",
                        fmt::format("dataset {} applies scale-offset after filter {} ('{}'); the HDF5 library cannot "
                                    "decode scale-offset from a resized chunk (it must come first)",
                                    name, id, filter_name.data()));
  }
}

// Refuses a dataset whose filter pipeline needs a filter the library lacks (bitshuffle, LZ4,
// Blosc, ... registered by plugins), naming it, before any read fails deep in the library.
std::vector<hsize_t> check_storage(hid_t dataset, std::size_t rank, const std::string& name, const std::string& file) {
  const Handle plist = checked(H5Dget_create_plist(dataset), H5Pclose, file, "filter", "no creation properties");
  const int filters = H5Pget_nfilters(plist.get());
  for (int i = 0; i < filters; ++i) {
    unsigned flags = 0;
    std::size_t values = 0;
    std::array<char, 128> filter_name{};
    const H5Z_filter_t id = H5Pget_filter2(plist.get(), unsigned(i), &flags, &values, nullptr, filter_name.size(),
                                           filter_name.data(), nullptr);
    if (id < 0 || H5Zfilter_avail(id) <= 0) {
      H5Eclear2(H5E_DEFAULT);
      throw FormatError(file, "filter",
                        fmt::format("dataset {} is stored through filter {} ('{}'), which this HDF5 library does not "
                                    "have (a plugin on HDF5_PLUGIN_PATH may provide it)",
                                    name, id, filter_name.data()));
    }
    // libhdf5 decodes scale-offset assuming its input is the chunk's full size, so after a filter
    // that changes the size (deflate, fletcher32, szip, ...) it reads past the chunk's end (h5py
    // refuses to write such a pipeline). Shuffle keeps the size, so it may come first.
    if (id == H5Z_FILTER_SCALEOFFSET && i > 0) check_before_scale_offset(plist.get(), i, name, file);
  }
  if (H5Pget_layout(plist.get()) != H5D_CHUNKED) return {};
  std::vector<hsize_t> chunk(rank);
  if (H5Pget_chunk(plist.get(), int(rank), chunk.data()) != int(rank))
    throw FormatError(file, "layout", fmt::format("dataset {}: chunk shape unreadable: {}", name, error_text()));
  return chunk;
}

Layout describe(hid_t dataset, const std::string& name, const std::string& file) {
  Layout layout;
  layout.info.dtype = dataset_dtype(dataset, name, file);
  layout.shape = dataset_shape(dataset, name, file);
  const std::size_t rank = layout.shape.size();
  layout.info.dims = {std::int64_t(layout.shape[rank - 1]), std::int64_t(layout.shape[rank - 2]),
                      std::int64_t(layout.shape[rank - 3])};
  checked_volume_bytes(layout.info, file, "shape");
  std::uint64_t volumes = 1;
  for (std::size_t a = 0; a + 3 < rank; ++a) {
    if (__builtin_mul_overflow(volumes, layout.shape[a], &volumes) || volumes > std::uint64_t(std::numeric_limits<std::int64_t>::max()))
      throw FormatError(file, "shape", fmt::format("dataset {}: the leading axes hold more volumes than can be counted", name));
  }
  layout.info.volumes = std::int64_t(volumes);
  layout.chunk = check_storage(dataset, rank, name, file);
  hdf5::read_geometry_attributes(dataset, file, layout.info);
  return layout;
}

// A dataset access list whose chunk cache holds one row of chunks across y and x (a slab read
// then decodes each chunk once), bounded by kMaxChunkCache.
Handle chunk_cache_access(const Layout& layout, const std::string& file) {
  Handle access = checked(H5Pcreate(H5P_DATASET_ACCESS), H5Pclose, file, "layout", "no access properties");
  if (layout.chunk.empty()) return access;
  const std::size_t rank = layout.shape.size();
  double chunk_bytes = double(dtype_size(layout.info.dtype));
  for (hsize_t c : layout.chunk) chunk_bytes *= double(c);
  const double across = double((layout.shape[rank - 1] + layout.chunk[rank - 1] - 1) / layout.chunk[rank - 1]) *
                        double((layout.shape[rank - 2] + layout.chunk[rank - 2] - 1) / layout.chunk[rank - 2]);
  const double bytes = std::clamp(chunk_bytes * across, double(kMinChunkCache), double(kMaxChunkCache));
  // Hash slots: about ten per cached chunk, as the library's documentation advises, bounded.
  const double chunks = std::max(1.0, bytes / chunk_bytes);
  const auto slots = std::size_t(std::clamp(10 * chunks, 521.0, 100003.0)) | 1;
  H5Pset_chunk_cache(access.get(), slots, std::size_t(bytes), 1.0);
  return access;
}

class Hdf5Source final : public VolumeSource {
 public:
  Hdf5Source(std::filesystem::path path, Handle file, Handle dataset, Layout layout, std::int64_t volume,
             std::string name)
      : path_(std::move(path)), file_(std::move(file)), dataset_(std::move(dataset)), layout_(std::move(layout)),
        name_(std::move(name)) {
    // The chosen volume's coordinates on the leading axes (C order: the last varies fastest).
    leading_.resize(layout_.shape.size() - 3);
    auto rest = std::uint64_t(volume);
    for (std::size_t a = leading_.size(); a-- > 0;) {
      leading_[a] = rest % layout_.shape[a];
      rest /= layout_.shape[a];
    }
  }
  const VolumeInfo& info() const override { return layout_.info; }
  const std::filesystem::path& path() const override { return path_; }

  Volume read_box(const Box& box) override {
    check_box_inside(box, layout_.info.dims, path_);
    Volume out(box.size(), layout_.info.dtype, layout_.info.spacing);
    std::vector<hsize_t> start = leading_, count(leading_.size(), 1);
    start.insert(start.end(), {hsize_t(box.lo.z), hsize_t(box.lo.y), hsize_t(box.lo.x)});
    const Extent size = box.size();
    count.insert(count.end(), {hsize_t(size.z), hsize_t(size.y), hsize_t(size.x)});
    const auto lock = lock_library();
    const std::string file = path_.string(), field = "dataset " + name_;
    const Handle file_space = checked(H5Dget_space(dataset_.get()), H5Sclose, file, field, "no dataspace");
    if (H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr) < 0)
      throw FormatError(file, field, fmt::format("cannot select {}: {}", box.to_string(), error_text()));
    // The memory space has the selection's shape: with a flat one the library maps the selection
    // row by row through its general iterator, ten times slower on a chunked whole-volume read.
    const Handle memory_space =
        checked(H5Screate_simple(int(count.size()), count.data(), nullptr), H5Sclose, file, field, "no memory space");
    if (H5Dread(dataset_.get(), hdf5::native_type(layout_.info.dtype), memory_space.get(), file_space.get(), H5P_DEFAULT,
                out.bytes()) < 0)
      throw FormatError(file, field, fmt::format("cannot read {}: {}", box.to_string(), error_text()));
    return out;
  }

 private:
  std::filesystem::path path_;
  Handle file_, dataset_;  // the dataset closes first
  Layout layout_;
  std::string name_;
  std::vector<hsize_t> leading_;
};

std::unique_ptr<VolumeSource> open_hdf5(const std::filesystem::path& path, const ReadOptions& options) {
  const std::string file = path.string();
  const auto lock = lock_library();
  const Handle file_access = checked(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, file, "file", "no access properties");
  // Locking fails on read-only and some network file systems, and a reader needs none.
  H5Pset_file_locking(file_access.get(), false, true);
  Handle h5 = checked(H5Fopen(file.c_str(), H5F_ACC_RDONLY, file_access.get()), H5Fclose, file, "file",
                      "not a readable HDF5 file");
  const std::string name = options.dataset.empty() ? hdf5::only_volume_dataset(h5.get(), file) : absolute_name(options.dataset);
  Layout layout = describe(open_dataset(h5.get(), name, H5P_DEFAULT, file).get(), name, file);
  const std::int64_t volume = choose_volume(layout.info.volumes, layout.info.dims, options, file, "shape",
                                            fmt::format("the leading axes of dataset {}", name));
  const Handle access = chunk_cache_access(layout, file);
  Handle dataset = open_dataset(h5.get(), name, access.get(), file);
  return std::make_unique<Hdf5Source>(path, std::move(h5), std::move(dataset), std::move(layout), volume, name);
}

// Chunks of up to 64^3 (clipped to the dims), shallower when a row of them would not fit in
// kWriteBufferBytes: the writer gathers a row of chunks and writes each chunk once, whole.
std::array<hsize_t, 3> write_chunk(const VolumeInfo& info) {
  const std::uint64_t slice = info.bytes_per_slice();
  const auto depth = hsize_t(std::clamp<std::uint64_t>(kWriteBufferBytes / slice, 1, kChunkEdge));
  return {std::min(depth, hsize_t(info.dims.z)), std::min(kChunkEdge, hsize_t(info.dims.y)),
          std::min(kChunkEdge, hsize_t(info.dims.x))};
}

class Hdf5Writer final : public VolumeWriter {
 public:
  Hdf5Writer(const std::filesystem::path& path, const VolumeInfo& info, const WriteOptions& options)
      : out_(path), info_(info), chunk_(write_chunk(info)), slice_bytes_(info.bytes_per_slice()) {
    std::filesystem::path temporary = path;
    temporary += kTemporarySuffix;
    const std::string file = path.string();
    const std::string name = options.dataset.empty() ? std::string(kDefaultDataset) : absolute_name(options.dataset);
    const auto lock = lock_library();
    file_ = writing(H5Fcreate(temporary.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose, "create the file");
    const Handle links = writing(H5Pcreate(H5P_LINK_CREATE), H5Pclose, "create link properties");
    H5Pset_create_intermediate_group(links.get(), 1);
    const Handle creation = dataset_creation(options.compress);
    const std::array<hsize_t, 3> shape{hsize_t(info.dims.z), hsize_t(info.dims.y), hsize_t(info.dims.x)};
    const Handle space = writing(H5Screate_simple(3, shape.data(), nullptr), H5Sclose, "create the dataspace");
    dataset_ = writing(H5Dcreate2(file_.get(), name.c_str(), hdf5::little_endian_type(info.dtype), space.get(),
                                  links.get(), creation.get(), H5P_DEFAULT),
                       H5Dclose, "create the dataset " + name);
    hdf5::write_geometry_attributes(dataset_.get(), file, info);
    buffer_.resize(std::size_t(chunk_[0]) * slice_bytes_);
  }
  void write_slab(const Volume& slab) override {
    const std::byte* data = slab.bytes();
    for (std::int64_t z = 0; z < slab.dims().z; ++z, data += slice_bytes_) {
      std::memcpy(buffer_.data() + std::size_t(buffered_) * slice_bytes_, data, slice_bytes_);
      if (++buffered_ == std::int64_t(chunk_[0])) flush();
    }
  }

  void finish() override {
    flush();
    const auto lock = lock_library();
    // Closing writes the last metadata; only a file closed cleanly is renamed into place.
    if (!dataset_.reset() || !file_.reset())
      throw Error(fmt::format("{}: cannot finish the HDF5 file: {}", out_.path().string(), error_text()));
    out_.commit();
  }

 private:
  Handle writing(hid_t id, Handle::Closer close, std::string_view what) const {
    if (id < 0) throw Error(fmt::format("{}: cannot {}: {}", out_.path().string(), what, error_text()));
    return Handle(id, close);
  }

  Handle dataset_creation(bool compress) const {
    Handle creation = writing(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, "create dataset properties");
    H5Pset_chunk(creation.get(), 3, chunk_.data());
    if (compress) {
      // Shuffle puts the bytes of equal significance together, which deflate then compresses better.
      if (dtype_size(info_.dtype) > 1) H5Pset_shuffle(creation.get());
      H5Pset_deflate(creation.get(), kDeflateLevel);
    }
    return creation;
  }

  // Writes the buffered slices as one hyperslab at z_.
  void flush() {
    if (buffered_ == 0) return;
    const auto lock = lock_library();
    const std::array<hsize_t, 3> start{hsize_t(z_), 0, 0};
    const std::array<hsize_t, 3> count{hsize_t(buffered_), hsize_t(info_.dims.y), hsize_t(info_.dims.x)};
    const Handle file_space = writing(H5Dget_space(dataset_.get()), H5Sclose, "get the dataspace");
    const Handle memory_space = writing(H5Screate_simple(3, count.data(), nullptr), H5Sclose, "create a memory space");
    if (H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr) < 0 ||
        H5Dwrite(dataset_.get(), hdf5::native_type(info_.dtype), memory_space.get(), file_space.get(), H5P_DEFAULT,
                 buffer_.data()) < 0)
      throw Error(fmt::format("{}: cannot write slices {}..{}: {}", out_.path().string(), z_, z_ + buffered_ - 1,
                              error_text()));
    z_ += buffered_;
    buffered_ = 0;
  }

  AtomicOutputFile out_;  // declared first: the HDF5 handles close before it removes an unfinished file
  VolumeInfo info_;
  std::array<hsize_t, 3> chunk_;
  std::size_t slice_bytes_;
  Handle file_, dataset_;  // the dataset closes first
  std::vector<std::byte> buffer_;
  std::int64_t buffered_ = 0, z_ = 0;
};

std::unique_ptr<VolumeWriter> create_hdf5_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                 const WriteOptions& options) {
  return std::make_unique<Hdf5Writer>(path, info, options);
}

}  // namespace

VolumeFormat hdf5_format() {
  return {
      .name = "hdf5",
      .title = "HDF5",
      .description = "HDF5 files (synchrotron CT, simulations, ilastik, Fiji): a numeric dataset of shape (z, y, x), "
                     "or (t, z, y, x) / (t, c, z, y, x)",
      .extensions = {".h5", ".hdf5", ".hdf", ".he5"},
      .magic_bytes = kSniffBytes,
      .sniff = has_hdf5_signature,
      .open = open_hdf5,
      .create_writer = create_hdf5_writer,
      .capabilities = {.streaming = true, .multi_volume = true, .spatial_metadata = true, .datasets = true},
      .read_dtypes = DTypeSet::all(),
      .write_dtypes = DTypeSet::all(),
      .read_notes = "`file.h5:/group/dataset` or `--dataset`, else the only 3-5-D numeric dataset (several: listed); "
                    "chunked or contiguous, every filter the library has (deflate, shuffle, fletcher32, szip, "
                    "scale-offset, n-bit), either byte order; leading axes of 4-D/5-D datasets are volumes; "
                    "hyperslab reads; voxel size from `spacing` or `element_size_um`, `origin`, `direction`, `unit`",
      .write_notes = "one dataset (`/volume`, or `file.h5:/group/name`), chunks up to 64³, shuffle + deflate 4 "
                     "(none uncompressed); `spacing`, `origin`, `direction`, `unit` and Fiji's `element_size_um` "
                     "attributes",
  };
}

}  // namespace strata::io::detail

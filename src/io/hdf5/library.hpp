#pragma once
// The HDF5 C library as the HDF5 reader and writer use it: one lock around every call (Debian's
// serial build is not thread safe, and read_box may be called from several threads), handles
// that close themselves under that lock, the library's error stack turned into message text,
// and the map between HDF5 numeric types and Strata's sample types.
#include <hdf5.h>

#include <mutex>
#include <optional>
#include <string>
#include <string_view>

#include "strata/core/dtype.hpp"

namespace strata::io::detail::hdf5 {

/// @brief Holds the one lock of the HDF5 library (recursive: a handle closed while it is held
/// takes it again). The first call also turns off the library's printing of its error stack:
/// failures are reported as exceptions instead.
[[nodiscard]] std::unique_lock<std::recursive_mutex> lock_library();

/// @brief An HDF5 identifier (file, dataset, dataspace, type, property list, attribute) that is
/// closed, under the library lock, when the handle dies.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle() = default;
  Handle(hid_t id, Closer close) : id_(id), close_(close) {}
  ~Handle() { reset(); }
  Handle(Handle&& other) noexcept : id_(other.id_), close_(other.close_) { other.id_ = H5I_INVALID_HID; }
  Handle& operator=(Handle&& other) noexcept;
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;

  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  /// @brief Closes the identifier now (HDF5 writes a file's last metadata when it is closed).
  /// Returns whether the library reported success.
  bool reset();

 private:
  hid_t id_ = H5I_INVALID_HID;
  Closer close_ = nullptr;
};

/// @brief What the library's error stack says about the last failure (the innermost messages,
/// e.g. "required filter 'szip' is not registered"), and clears the stack.
std::string error_text();

/// @brief `id` in a Handle closed by `close`, or FormatError(file, field, "<what>: <error_text>")
/// when the call that returned it failed (a negative id).
Handle checked(hid_t id, Handle::Closer close, const std::string& file, const std::string& field, std::string_view what);

/// @brief The sample type of an HDF5 integer or float type of 1, 2, 4 or 8 bytes (either byte
/// order); std::nullopt for any other type (strings, compounds, 16-bit floats, ...).
std::optional<DType> sample_type(hid_t type);
/// @brief "string", "compound", "float16", ...: what an HDF5 type is, for messages.
std::string type_text(hid_t type);
/// @brief The library's native type of `dtype` samples, for H5Dread / H5Dwrite's memory side.
hid_t native_type(DType dtype);
/// @brief The little-endian file type that stores `dtype` samples.
hid_t little_endian_type(DType dtype);

}  // namespace strata::io::detail::hdf5

#include "strata/core/volume.hpp"

#include <cmath>
#include <limits>
#include <new>
#include <stdexcept>

#include "strata/core/checked.hpp"
#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"

namespace strata {

namespace {

std::optional<std::uint64_t> checked_bytes(std::initializer_list<std::int64_t> counts, DType dtype) {
  for (std::int64_t c : counts)
    if (c < 0) return std::nullopt;
  std::optional<std::int64_t> bytes = checked_product(counts);
  if (bytes) bytes = checked_mul(*bytes, std::int64_t(dtype_size(dtype)));
  if (!bytes) return std::nullopt;
  return std::uint64_t(*bytes);
}

[[noreturn]] void throw_size_overflow(const VolumeInfo& info, const char* what) {
  throw Error("dims " + info.dims.to_string() + " of " + std::string(dtype_name(info.dtype)) + ": the " + what +
              " overflows 64 bits");
}

}  // namespace

std::optional<std::uint64_t> VolumeInfo::checked_bytes_per_slice() const { return checked_bytes({dims.x, dims.y}, dtype); }

std::optional<std::uint64_t> VolumeInfo::checked_byte_size() const {
  return checked_bytes({dims.x, dims.y, dims.z}, dtype);
}

std::size_t VolumeInfo::bytes_per_slice() const {
  if (const auto bytes = checked_bytes_per_slice()) return std::size_t(*bytes);
  throw_size_overflow(*this, "byte size of a slice");
}

std::size_t VolumeInfo::byte_size() const {
  if (const auto bytes = checked_byte_size()) return std::size_t(*bytes);
  throw_size_overflow(*this, "byte size");
}

Volume::Volume(Extent dims, DType dtype, Spacing spacing) : info_{dims, dtype, spacing} {
  if (dims.x < 0 || dims.y < 0 || dims.z < 0) throw Error("Volume: negative dimensions " + dims.to_string());
  const std::size_t bytes = info_.byte_size();
  // A size that passed every header check can still exceed memory: say so instead of letting
  // std::bad_alloc reach the user without the volume it was for.
  const auto cannot_allocate = [&](const char* why) {
    return OutOfMemoryError("Volume: cannot allocate " + std::to_string(bytes) + " bytes for " + dims.to_string() + " " +
                 std::string(dtype_name(dtype)) + " samples (" + why + ")");
  };
  try {
    bytes_.resize(bytes);
  } catch (const std::bad_alloc&) {
    throw cannot_allocate("out of memory");
  } catch (const std::length_error&) {
    throw cannot_allocate("more than the address space");
  }
}

void Volume::check_type(DType requested) const {
  if (requested != info_.dtype)
    throw Error("Volume: requested " + std::string(dtype_name(requested)) + " view of a " +
                std::string(dtype_name(info_.dtype)) + " volume");
}

double Volume::value(std::int64_t x, std::int64_t y, std::int64_t z) const {
  std::size_t i = std::size_t((z * info_.dims.y + y) * info_.dims.x + x);
  return visit_dtype(info_.dtype, [&](auto tag) {
    using T = decltype(tag);
    T v;
    std::memcpy(&v, bytes_.data() + i * sizeof(T), sizeof(T));
    return double(v);
  });
}

namespace {
// Rounds and clamps for integer targets so conversions never wrap silently.
template <class T>
T cast_sample(double v) {
  if constexpr (std::is_floating_point_v<T>) {
    return T(v);
  } else {
    if (std::isnan(v)) return T(0);
    double r = std::nearbyint(v);
    r = std::min(std::max(r, double(std::numeric_limits<T>::lowest())), double(std::numeric_limits<T>::max()));
    return T(r);
  }
}
}  // namespace

void Volume::set_value(std::int64_t x, std::int64_t y, std::int64_t z, double v) {
  std::size_t i = std::size_t((z * info_.dims.y + y) * info_.dims.x + x);
  visit_dtype(info_.dtype, [&](auto tag) {
    using T = decltype(tag);
    T s = cast_sample<T>(v);
    std::memcpy(bytes_.data() + i * sizeof(T), &s, sizeof(T));
  });
}

Volume Volume::crop(const Box& box) const {
  if (!Box::whole(info_.dims).contains(box) || box.empty())
    throw Error("Volume::crop: box " + box.to_string() + " is not inside " + info_.dims.to_string());
  Volume out(box.size(), info_.dtype, info_.spacing);
  const std::size_t sample = dtype_size(info_.dtype);
  const std::size_t row = std::size_t(box.size().x) * sample;
  for (std::int64_t z = box.lo.z; z < box.hi.z; ++z)
    for (std::int64_t y = box.lo.y; y < box.hi.y; ++y) {
      std::size_t src = std::size_t((z * info_.dims.y + y) * info_.dims.x + box.lo.x) * sample;
      std::size_t dst = std::size_t(((z - box.lo.z) * box.size().y + (y - box.lo.y)) * box.size().x) * sample;
      std::memcpy(out.bytes_.data() + dst, bytes_.data() + src, row);
    }
  return out;
}

Volume Volume::converted(DType to) const {
  Volume out(info_.dims, to, info_.spacing);
  out.info_.geometry = info_.geometry;  // the same volume in other sample values: same place in space
  visit_dtype(info_.dtype, [&](auto from_tag) {
    using From = decltype(from_tag);
    visit_dtype(to, [&](auto to_tag) {
      using To = decltype(to_tag);
      const From* src = reinterpret_cast<const From*>(bytes_.data());
      To* dst = reinterpret_cast<To*>(out.bytes_.data());
      const std::int64_t n = voxel_count();
      // Every thread: converting a decoded volume for output was a serial pass after a
      // parallel decode (13% of `strata decompress` on 2 threads).
#pragma omp parallel for schedule(static) num_threads(thread_count()) if (n >= (std::int64_t(1) << 20))
      for (std::int64_t i = 0; i < n; ++i) dst[i] = cast_sample<To>(double(src[i]));
    });
  });
  return out;
}

}  // namespace strata

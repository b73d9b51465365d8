#pragma once
// Shared by the fuzz targets (fuzz/fuzz_*.cpp).
//
// The contract every target checks: reading hostile bytes either succeeds or throws
// strata::Error. Anything else is a bug: a sanitizer report, a crash, another exception type
// escaping (run_guarded aborts on it, so libFuzzer saves the input), a timeout or an
// allocation beyond -rss_limit_mb.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>

#include "strata/io/volume_io.hpp"

namespace strata::fuzz {

// `bytes` written to `<per-process temp dir>/<name>` (the same path on every call, truncated
// first), for readers that take a path. The folder is removed when the process exits.
std::filesystem::path write_input(const std::string& name, std::span<const std::byte> bytes);
std::filesystem::path write_input(const std::string& name, std::string_view text);
// What the CLI does with an opened volume file (`strata info`): open it, then stream every
// slab through the statistics when it holds at most 64 Mi voxels, else read its corner voxels.
// Temporaries (decoded gzip data) go to temp_dir().
void read_volume_file(const std::filesystem::path& path, const io::ReadOptions& options = {});

// The per-process temp dir itself.
const std::filesystem::path& temp_dir();

// Runs `body`; strata::Error is the expected outcome for garbage and is swallowed, any other
// exception prints its type and message and aborts.
template <class F>
void run_guarded(F&& body);

// Called once per process by LLVMFuzzerInitialize of every target: one thread for the
// library's data-parallel loops (reproducible, no thread start-up per input).
void init();

[[noreturn]] void unexpected_exception(const char* what, const char* type);

// True when d is positive and holds at most `max_voxels` (no overflow on hostile extents).
inline bool small_extent(std::int64_t x, std::int64_t y, std::int64_t z, std::int64_t max_voxels) {
  std::int64_t xy = 0, xyz = 0;
  return x > 0 && y > 0 && z > 0 && !__builtin_mul_overflow(x, y, &xy) && !__builtin_mul_overflow(xy, z, &xyz) &&
         xyz <= max_voxels;
}

inline std::span<const std::byte> as_bytes(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const std::byte*>(data), size};
}

}  // namespace strata::fuzz

#include <exception>
#include <new>
#include <typeinfo>

#include "strata/core/error.hpp"

namespace strata::fuzz {

template <class F>
void run_guarded(F&& body) {
  try {
    body();
  } catch (const strata::Error&) {
    // the correct answer to a malformed input
  } catch (const std::exception& e) {
    unexpected_exception(e.what(), typeid(e).name());
  } catch (...) {
    unexpected_exception("(not a std::exception)", "unknown");
  }
}

}  // namespace strata::fuzz

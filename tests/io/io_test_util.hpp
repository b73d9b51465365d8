#pragma once
// Helpers shared by the io tests: seeded test volumes, whole-file bytes and text, error-message
// checks and a progress sink that counts.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "io/io_detail.hpp"
#include "strata/core/error.hpp"
#include "strata/core/progress.hpp"
#include "strata/core/volume.hpp"
#include "strata/io/files.hpp"
#include "strata/io/volume_io.hpp"

namespace strata::test::io {

inline constexpr auto kAllDtypes = kAllDTypes;

// Every bit pattern for integers (so extremes and negatives occur) and spread-out floats;
// the first two samples are the type's lowest and highest values.
inline Volume random_volume(Extent dims, DType dtype, std::uint64_t seed, Spacing spacing = {0.5, 1.25, 2.0}) {
  Volume v(dims, dtype, spacing);
  std::mt19937_64 rng(seed);
  visit_dtype(dtype, [&](auto tag) {
    using T = decltype(tag);
    auto s = v.samples<T>();
    for (T& x : s) {
      if constexpr (std::is_floating_point_v<T>)
        x = T(std::uniform_real_distribution<double>(-1e4, 1e4)(rng));
      else
        x = T(rng());
    }
    s[0] = std::numeric_limits<T>::lowest();
    s[1] = std::numeric_limits<T>::max();
  });
  return v;
}

// Every byte differs from its neighbours, so a swapped, shifted or transposed read shows.
inline Volume random_bytes_volume(Extent dims, DType t, std::uint64_t seed) {
  Volume v(dims, t, Spacing{0.5, 1.25, 2.0});
  std::uint64_t s = seed;
  for (std::size_t i = 0; i < v.byte_size(); ++i) {
    s = s * 6364136223846793005ULL + 1442695040888963407ULL;
    v.bytes()[i] = std::byte(s >> 56);
  }
  return v;
}

// Dims, dtype, spacing and every sample equal; `stage` names the step in failure messages.
inline void expect_same(const Volume& got, const Volume& expected, const std::string& stage = "") {
  EXPECT_EQ(got.dims(), expected.dims()) << stage;
  EXPECT_EQ(got.dtype(), expected.dtype()) << stage;
  EXPECT_EQ(got.spacing(), expected.spacing()) << stage;
  EXPECT_TRUE(got == expected) << stage << ": samples differ";
}

// Write options with compression on or off; the format follows the file name.
inline strata::io::WriteOptions with_compression(bool compress) {
  strata::io::WriteOptions options;
  options.compress = compress;
  return options;
}

// ---------------------------------------------------------------------------------------------
// Whole files

inline std::string read_text(const std::filesystem::path& p) {
  std::ostringstream s;
  s << std::ifstream(p, std::ios::binary).rdbuf();
  return s.str();
}

inline void write_text(const std::filesystem::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

inline std::vector<std::byte> read_bytes(const std::filesystem::path& p) {
  const std::string text = read_text(p);
  std::vector<std::byte> bytes(text.size());
  std::memcpy(bytes.data(), text.data(), text.size());
  return bytes;
}

inline void write_bytes(const std::filesystem::path& p, const void* data, std::size_t n) {
  std::ofstream(p, std::ios::binary).write(static_cast<const char*>(data), std::streamsize(n));
}

inline void write_bytes(const std::filesystem::path& p, const std::vector<std::byte>& bytes) {
  write_bytes(p, bytes.data(), bytes.size());
}

// Gzips `n` bytes into `p` with our own GzipWriter, in two writes so the stream is built
// incrementally as the volume writers build it.
inline void write_gzipped(const std::filesystem::path& p, const void* data, std::size_t n) {
  strata::io::AtomicOutputFile out(p);
  strata::io::detail::GzipWriter gz(out);
  const std::size_t half = n / 2;
  gz.write(data, half);
  gz.write(static_cast<const char*>(data) + half, n - half);
  gz.finish();
  out.commit();
}

// Whether this process maps a file that lives (or lived: unlinked files count) in `dir`.
inline bool maps_a_file_in(const std::filesystem::path& dir) {
  std::ifstream maps("/proc/self/maps");
  const std::string prefix = dir.string() + "/";
  for (std::string line; std::getline(maps, line);)
    if (line.find(prefix) != std::string::npos) return true;
  return false;
}

inline std::size_t file_count(const std::filesystem::path& dir) {
  return std::size_t(std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator{}));
}

// ---------------------------------------------------------------------------------------------
// Errors

// `action` throws a strata::Error whose message holds every one of `parts`.
template <class F>
void expect_error(F&& action, const std::vector<std::string>& parts) {
  try {
    action();
  } catch (const Error& e) {
    const std::string message = e.what();
    for (const auto& part : parts)
      EXPECT_NE(message.find(part), std::string::npos) << "\"" << part << "\" missing from: " << message;
    return;
  }
  ADD_FAILURE() << "expected a strata::Error";
}

// ---------------------------------------------------------------------------------------------

// Counts what a task reports.
class CountingProgress : public ProgressSink {
 public:
  void begin(std::string_view, std::uint64_t total, std::string_view) override {
    ++begins;
    this->total = total;
  }
  void advance(std::uint64_t units) override { advanced += units; }
  void end() override { ++ends; }
  int begins = 0, ends = 0;
  std::uint64_t total = 0, advanced = 0;
};

}  // namespace strata::test::io

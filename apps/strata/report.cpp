#include "report.hpp"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include "cli_checks.hpp"
#include "commands.hpp"
#include "strata/core/error.hpp"
#include "strata/io/files.hpp"

namespace strata::cli {

void RawInputArgs::add_to(CLI::App& cmd) {
  cmd.add_option("--dims", dims, "Raw input: dimensions X,Y,Z (else read from <file>.json)");
  cmd.add_option("--dtype", dtype, "Raw input: sample type u8|i8|u16|i16|u32|i32|f32|f64");
  cmd.add_option("--spacing", spacing, "Raw input: voxel spacing SX,SY,SZ");
  cmd.add_flag("--big-endian", big_endian, "Raw input: samples are big endian");
  add_volume_option(cmd, volume);
  cmd.add_option("--dataset", dataset,
                 "The array inside a container: an HDF5 dataset (/group/data; also written file.h5:/group/data) or "
                 "the array of a Zarr group");
  cmd.add_option("--level", level, "Resolution level of a multiscale input (OME-Zarr, Neuroglancer precomputed), "
                                   "0 = finest (default)")
      ->check(non_negative_integer<std::int64_t>());
}

void add_volume_option(CLI::App& cmd, std::optional<std::int64_t>& volume) {
  cmd.add_option("--volume,--component,--time", volume,
                 "Which 3D volume of a file that holds several, from 0: a time point or component (NIfTI dim[4..7], "
                 "a NRRD fourth axis: interleaved components first or a series last, told apart by `kinds`; a TIFF "
                 "channel; a member of a .strata volume set)")
      ->check(non_negative_integer<std::int64_t>());
}

io::ReadOptions RawInputArgs::to_read_options() const {
  io::ReadOptions o;
  if (!dims.empty()) o.raw_dims = parse_extent(dims);
  if (!dtype.empty()) o.raw_dtype = parse_dtype(dtype, "--dtype");
  if (!spacing.empty()) {
    Spacing s;
    char c1 = 0, c2 = 0;
    std::istringstream in(spacing);
    if (!(in >> s.x >> c1 >> s.y >> c2 >> s.z) || c1 != ',' || c2 != ',')
      throw UsageError("--spacing", "expected SX,SY,SZ, got '" + spacing + "'");
    o.raw_spacing = s;
  }
  o.raw_big_endian = big_endian;
  o.volume = volume;
  o.dataset = dataset;
  o.level = level;
  return o;
}

nlohmann::json transfer_json(const io::TransferStats& stats) {
  return {{"bytes_fetched", stats.bytes_fetched}, {"requests", stats.requests}, {"retries", stats.retries},
          {"cache_hits", stats.cache_hits}};
}

void print_transfer(const nlohmann::json& t) {
  std::printf("fetched:     %s in %llu HTTP requests (%llu retried, %llu reads from the cache)\n",
              human_bytes(t["bytes_fetched"].get<std::uint64_t>()).c_str(), t["requests"].get<unsigned long long>(),
              t["retries"].get<unsigned long long>(), t["cache_hits"].get<unsigned long long>());
}

}  // namespace strata::cli

namespace strata::cli {

std::uint64_t parse_byte_size(const std::string& text, const std::string& option) {
  std::size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    throw UsageError(option, "expected a size such as 512M or 2G, got '" + text + "'");
  }
  std::string suffix = text.substr(used);
  double scale = 1;
  if (suffix == "k" || suffix == "K" || suffix == "KiB") scale = 1024.0;
  else if (suffix == "m" || suffix == "M" || suffix == "MiB") scale = 1024.0 * 1024;
  else if (suffix == "g" || suffix == "G" || suffix == "GiB") scale = 1024.0 * 1024 * 1024;
  else if (!suffix.empty()) throw UsageError(option, "unknown unit '" + suffix + "' (use k, M or G)");
  // Up to 1 PiB: a budget no machine reaches, and far inside the 64-bit range.
  constexpr double kMaxBytes = double(std::uint64_t(1) << 50);
  if (!(value > 0)) throw UsageError(option, "must be positive, got '" + text + "'");
  if (!(value * scale <= kMaxBytes)) throw UsageError(option, "must be at most 1 PiB (1048576G), got '" + text + "'");
  return std::max<std::uint64_t>(1, std::uint64_t(value * scale));
}

void write_json_file(const std::filesystem::path& path, const nlohmann::json& j, int indent) {
  const std::string text = j.dump(indent) + "\n";
  io::AtomicOutputFile out(path);
  out.write(text.data(), text.size());
  out.commit();
}

}  // namespace strata::cli

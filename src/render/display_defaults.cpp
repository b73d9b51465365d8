#include "strata/render/display_defaults.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numeric>

#include "strata/io/formats.hpp"

namespace strata::render {

int value_bin(double v, double lo, double hi, int bins) {
  if (!(hi > lo)) return 0;
  return std::clamp(int((v - lo) / (hi - lo) * bins), 0, bins - 1);
}

std::vector<std::uint64_t> value_histogram(std::span<const float> samples, double lo, double hi, int bins) {
  std::vector<std::uint64_t> counts(std::size_t(bins), 0);
  for (const float v : samples)
    if (std::isfinite(v)) ++counts[std::size_t(value_bin(v, lo, hi, bins))];
  return counts;
}

std::vector<std::uint64_t> coarser_histogram(std::span<const std::uint64_t> counts, int bins) {
  if (counts.empty()) return {};
  std::vector<std::uint64_t> out(std::size_t(bins), 0);
  const std::size_t group = counts.size() / std::size_t(bins);
  for (std::size_t i = 0; i < counts.size(); ++i) out[std::min(i / group, out.size() - 1)] += counts[i];
  return out;
}

namespace {

// The value where the running count reaches `target`, interpolated inside its bin.
double value_at_count(std::span<const std::uint64_t> counts, double lo, double width, double target) {
  double below = 0;
  for (std::size_t i = 0; i < counts.size(); ++i) {
    const double c = double(counts[i]);
    if (below + c >= target && c > 0) return lo + width * (double(i) + (target - below) / c);
    below += c;
  }
  return lo + width * double(counts.size());
}

bool names_any(const std::string& lower_name, std::initializer_list<const char*> words) {
  // A word counts when it stands alone between separators (so "mr" is not found in "smrt").
  for (const char* w : words) {
    const std::string word(w);
    for (std::size_t at = lower_name.find(word); at != std::string::npos; at = lower_name.find(word, at + 1)) {
      const bool start = at == 0 || !std::isalnum(static_cast<unsigned char>(lower_name[at - 1]));
      const std::size_t end = at + word.size();
      const bool stop = end == lower_name.size() || !std::isalpha(static_cast<unsigned char>(lower_name[end]));
      if (start && stop) return true;
    }
  }
  return false;
}

}  // namespace

std::pair<double, double> percentile_window(std::span<const std::uint64_t> counts, double lo, double hi,
                                            double fraction) {
  const double total = double(std::accumulate(counts.begin(), counts.end(), std::uint64_t(0)));
  if (total <= 0 || !(hi > lo)) return {lo, hi};
  const double width = (hi - lo) / double(counts.size());
  const double a = value_at_count(counts, lo, width, fraction * total);
  const double b = value_at_count(counts, lo, width, (1 - fraction) * total);
  if (!(b - a >= width)) return {lo, hi};
  return {std::max(lo, a), std::min(hi, b)};
}

std::pair<double, double> whole_window(std::pair<double, double> window, bool integer_samples) {
  if (!integer_samples) return window;
  return {std::floor(window.first), std::ceil(window.second)};
}

std::string default_preset(const std::string& file_name, double lo, double hi, bool anatomical) {
  std::string name = file_name;
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if ((lo < -500 && hi > 500) || names_any(name, {"ct", "cta", "hu"})) return "ct";
  const io::VolumeFormat* format = io::format_by_extension(file_name);
  const bool nifti = format && format->name == "nifti";
  if (nifti || anatomical || names_any(name, {"mri", "mr", "t1", "t1w", "t2", "t2w", "flair", "dwi", "bold"})) return "mri";
  return "grayscale";
}

}  // namespace strata::render

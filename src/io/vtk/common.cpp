// What the .vti and legacy .vtk readers share: number lists, the image geometry, the mapped source
// of one component.
#include <charconv>
#include <cmath>

#include <fmt/format.h>

#include "io/vtk/vtk_detail.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail::vtk {

namespace {

std::vector<std::string_view> words(std::string_view text) {
  std::vector<std::string_view> out;
  std::size_t at = 0;
  while (true) {
    at = text.find_first_not_of(" \t\r\n", at);
    if (at == std::string_view::npos) return out;
    const std::size_t end = std::min(text.find_first_of(" \t\r\n", at), text.size());
    out.push_back(text.substr(at, end - at));
    at = end;
  }
}

template <class T>
std::vector<T> parse_numbers(std::string_view text, std::size_t count, const std::string& file, const std::string& field) {
  const std::vector<std::string_view> parts = words(text);
  if (parts.size() != count)
    throw FormatError(file, field, fmt::format("expected {} numbers, found {} in \"{}\"", count, parts.size(), text.substr(0, 80)));
  std::vector<T> out;
  for (std::string_view w : parts) {
    T v{};
    const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
    bool ok = ec == std::errc{} && end == w.data() + w.size();
    if constexpr (std::is_floating_point_v<T>) ok = ok && std::isfinite(v);
    if (!ok) throw FormatError(file, field, fmt::format("\"{}\" is not a {}", w.substr(0, 40), std::is_floating_point_v<T> ? "finite number" : "64-bit integer"));
    out.push_back(v);
  }
  return out;
}

}  // namespace

std::vector<double> parse_doubles(std::string_view text, std::size_t count, const std::string& file,
                                  const std::string& field) {
  return parse_numbers<double>(text, count, file, field);
}

std::vector<std::int64_t> parse_ints(std::string_view text, std::size_t count, const std::string& file,
                                     const std::string& field) {
  return parse_numbers<std::int64_t>(text, count, file, field);
}

ArrayLayout array_layout(const Extent& dims, const Vector3& first, DType dtype, std::int64_t components,
                         const Vector3& origin, const Vector3& spacing, const Matrix3& direction, const std::string& file,
                         const std::string& field, const std::string& size_field) {
  ArrayLayout layout;
  layout.info.dims = dims;
  layout.info.dtype = dtype;
  layout.info.volumes = components;
  const std::uint64_t one = checked_volume_bytes(layout.info, file, size_field);
  if (components < 1 || components > kMaxComponents)
    throw FormatError(file, size_field, fmt::format("{} components (expected 1..{})", components, kMaxComponents));
  if (one > std::uint64_t(std::numeric_limits<std::int64_t>::max()) / std::uint64_t(components))
    throw FormatError(file, size_field, fmt::format("{} components of {} bytes do not fit in a 64-bit byte count", components, one));
  layout.bytes = one * std::uint64_t(components);
  // The index-to-world affine: columns direction[:, c] * spacing[c], translation at voxel 0.
  Matrix4 affine{};
  for (int r = 0; r < 3; ++r) {
    double translation = origin[r];
    for (int c = 0; c < 3; ++c) {
      affine[r][c] = direction[r][c] * spacing[c];
      translation += affine[r][c] * first[c];
    }
    affine[r][3] = translation;
  }
  affine[3] = {0, 0, 0, 1};
  try {
    layout.info.geometry = geometry_from_affine(affine, layout.info.spacing, WorldSpace::unspecified, field);
  } catch (const FormatError&) {
    throw;
  } catch (const Error& e) {
    throw FormatError(file, field, fmt::format("spacing and direction give no valid axes ({})", e.what()));
  }
  return layout;
}

std::unique_ptr<VolumeSource> component_source(std::shared_ptr<MappedFile> mapped, std::uint64_t offset,
                                               const ArrayLayout& layout, bool big_endian,
                                               const std::filesystem::path& path, const ReadOptions& options,
                                               const std::string& field) {
  const std::string file = path.string();
  const std::int64_t components = layout.info.volumes;
  const std::int64_t index = choose_volume(components, layout.info.dims, options, file, field, "components");
  return make_mapped_source(std::move(mapped), offset, layout.info, big_endian, path, field,
                            Interleave{.count = components, .index = index});
}

}  // namespace strata::io::detail::vtk

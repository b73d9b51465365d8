#include "io/hdf5/geometry_attributes.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstring>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "io/hdf5/library.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail::hdf5 {

namespace {

// Longer unit or space strings are not what these attributes hold; nothing past this is read.
constexpr std::size_t kMaxStringAttribute = 256;

std::string field_of(std::string_view name) { return fmt::format("attribute {}", name); }

Handle open_attribute(hid_t object, const char* name, const std::string& file) {
  const htri_t exists = H5Aexists(object, name);
  if (exists <= 0) return {};
  return checked(H5Aopen(object, name, H5P_DEFAULT), H5Aclose, file, field_of(name), "cannot open");
}

// The values of a numeric attribute of exactly `count` elements, converted to double by the
// library; std::nullopt when the attribute is absent.
std::optional<std::vector<double>> numbers(hid_t object, const char* name, std::size_t count, const std::string& file) {
  const Handle attribute = open_attribute(object, name, file);
  if (!attribute.valid()) return std::nullopt;
  const Handle type = checked(H5Aget_type(attribute.get()), H5Tclose, file, field_of(name), "no type");
  const H5T_class_t type_class = H5Tget_class(type.get());
  if (type_class != H5T_INTEGER && type_class != H5T_FLOAT)
    throw FormatError(file, field_of(name), fmt::format("holds {}, expected {} numbers", type_text(type.get()), count));
  const Handle space = checked(H5Aget_space(attribute.get()), H5Sclose, file, field_of(name), "no dataspace");
  const hssize_t points = H5Sget_simple_extent_npoints(space.get());
  if (points < 0 || std::size_t(points) != count)
    throw FormatError(file, field_of(name), fmt::format("holds {} values, expected {}", points, count));
  std::vector<double> values(count);
  if (H5Aread(attribute.get(), H5T_NATIVE_DOUBLE, values.data()) < 0)
    throw FormatError(file, field_of(name), fmt::format("cannot read: {}", error_text()));
  for (double v : values)
    if (!std::isfinite(v)) throw FormatError(file, field_of(name), fmt::format("holds {}, expected finite numbers", v));
  return values;
}

// A scalar string attribute, fixed or variable length; std::nullopt when absent.
std::optional<std::string> text(hid_t object, const char* name, const std::string& file) {
  const Handle attribute = open_attribute(object, name, file);
  if (!attribute.valid()) return std::nullopt;
  const Handle type = checked(H5Aget_type(attribute.get()), H5Tclose, file, field_of(name), "no type");
  if (H5Tget_class(type.get()) != H5T_STRING)
    throw FormatError(file, field_of(name), fmt::format("holds {}, expected a string", type_text(type.get())));
  const Handle space = checked(H5Aget_space(attribute.get()), H5Sclose, file, field_of(name), "no dataspace");
  if (H5Sget_simple_extent_npoints(space.get()) != 1)
    throw FormatError(file, field_of(name), "holds several strings, expected one");
  std::string value;
  if (H5Tis_variable_str(type.get()) > 0) {
    const Handle memory = checked(H5Tcopy(H5T_C_S1), H5Tclose, file, field_of(name), "no string type");
    H5Tset_size(memory.get(), H5T_VARIABLE);
    H5Tset_cset(memory.get(), H5Tget_cset(type.get()));
    char* read = nullptr;
    if (H5Aread(attribute.get(), memory.get(), &read) < 0)
      throw FormatError(file, field_of(name), fmt::format("cannot read: {}", error_text()));
    if (read) value.assign(read, strnlen(read, kMaxStringAttribute));
    H5free_memory(read);
  } else {
    const std::size_t size = H5Tget_size(type.get());
    if (size == 0 || size > kMaxStringAttribute)
      throw FormatError(file, field_of(name), fmt::format("a string of {} bytes (at most {} read)", size, kMaxStringAttribute));
    std::vector<char> buffer(size + 1, '\0');
    if (H5Aread(attribute.get(), type.get(), buffer.data()) < 0)
      throw FormatError(file, field_of(name), fmt::format("cannot read: {}", error_text()));
    value.assign(buffer.data(), strnlen(buffer.data(), size));
  }
  return value;
}

// Micrometres per unit, for element_size_um; std::nullopt for a unit that is not a length.
std::optional<double> micrometres_per(std::string_view unit) {
  constexpr std::array<std::pair<std::string_view, double>, 6> kScale{
      {{"m", 1e6}, {"cm", 1e4}, {"mm", 1e3}, {"um", 1.0}, {"nm", 1e-3}, {"angstrom", 1e-4}}};
  for (const auto& [name, scale] : kScale)
    if (name == unit) return scale;
  return std::nullopt;
}

Spacing positive_spacing(double x, double y, double z, const char* name, const std::string& file) {
  for (double v : {x, y, z})
    if (!(v > 0)) throw FormatError(file, field_of(name), fmt::format("voxel size {} {} {} is not positive", x, y, z));
  return {x, y, z};
}

Matrix3 unit_columns(const std::vector<double>& rows, const std::string& file) {
  Matrix3 m{};
  for (std::size_t r = 0; r < 3; ++r)
    for (std::size_t c = 0; c < 3; ++c) m[r][c] = rows[3 * r + c];
  for (std::size_t c = 0; c < 3; ++c) {
    const double norm = std::sqrt(m[0][c] * m[0][c] + m[1][c] * m[1][c] + m[2][c] * m[2][c]);
    if (std::abs(norm - 1) > 1e-3)
      throw FormatError(file, field_of("direction"), fmt::format("column {} has length {}, expected a unit vector", c, norm));
  }
  return m;
}

}  // namespace

void read_geometry_attributes(hid_t dataset, const std::string& file, VolumeInfo& info) {
  Geometry& geometry = info.geometry;
  if (const auto unit = text(dataset, "unit", file)) geometry.unit = canonical_length_unit(*unit);
  if (const auto s = numbers(dataset, "spacing", 3, file)) {
    info.spacing = positive_spacing((*s)[0], (*s)[1], (*s)[2], "spacing", file);
  } else if (const auto um = numbers(dataset, "element_size_um", 3, file)) {
    info.spacing = positive_spacing((*um)[2], (*um)[1], (*um)[0], "element_size_um", file);
    geometry.unit = "um";
  }
  if (const auto o = numbers(dataset, "origin", 3, file)) geometry.origin = {(*o)[0], (*o)[1], (*o)[2]};
  if (const auto d = numbers(dataset, "direction", 9, file)) geometry.direction = unit_columns(*d, file);
  if (const auto space = text(dataset, "space", file)) {
    try {
      geometry.space = parse_world_space(*space, "space");
    } catch (const Error&) {
      throw FormatError(file, field_of("space"), fmt::format("'{}' (expected RAS or LPS)", *space));
    }
  }
}

namespace {

void write_numbers(hid_t dataset, const char* name, std::span<const double> values, hid_t file_type,
                   const std::string& file) {
  const hsize_t count = values.size();
  const Handle space = checked(H5Screate_simple(1, &count, nullptr), H5Sclose, file, field_of(name), "cannot write");
  const Handle attribute = checked(H5Acreate2(dataset, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                                   file, field_of(name), "cannot write");
  if (H5Awrite(attribute.get(), H5T_NATIVE_DOUBLE, values.data()) < 0)
    throw Error(fmt::format("{}: cannot write the attribute {}: {}", file, name, error_text()));
}

// A variable-length UTF-8 string, which h5py reads as `str` (a fixed-length one reads as bytes).
void write_text(hid_t dataset, const char* name, const std::string& value, const std::string& file) {
  const Handle type = checked(H5Tcopy(H5T_C_S1), H5Tclose, file, field_of(name), "cannot write");
  H5Tset_size(type.get(), H5T_VARIABLE);
  H5Tset_cset(type.get(), H5T_CSET_UTF8);
  const Handle space = checked(H5Screate(H5S_SCALAR), H5Sclose, file, field_of(name), "cannot write");
  const Handle attribute = checked(H5Acreate2(dataset, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                                   file, field_of(name), "cannot write");
  const char* data = value.c_str();
  if (H5Awrite(attribute.get(), type.get(), &data) < 0)
    throw Error(fmt::format("{}: cannot write the attribute {}: {}", file, name, error_text()));
}

}  // namespace

void write_geometry_attributes(hid_t dataset, const std::string& file, const VolumeInfo& info) {
  const Spacing& s = info.spacing;
  const Geometry& g = info.geometry;
  const std::array<double, 3> spacing{s.x, s.y, s.z};
  write_numbers(dataset, "spacing", spacing, H5T_IEEE_F64LE, file);
  write_numbers(dataset, "origin", g.origin, H5T_IEEE_F64LE, file);
  std::array<double, 9> direction{};
  for (std::size_t r = 0; r < 3; ++r)
    for (std::size_t c = 0; c < 3; ++c) direction[3 * r + c] = g.direction[r][c];
  write_numbers(dataset, "direction", direction, H5T_IEEE_F64LE, file);
  if (!g.unit.empty()) write_text(dataset, "unit", g.unit, file);
  if (g.space != WorldSpace::unspecified) write_text(dataset, "space", std::string(world_space_name(g.space)), file);
  // Fiji's HDF5 plugin and ilastik read the voxel size from here, z first, as 32-bit floats.
  if (const auto scale = micrometres_per(g.unit)) {
    const std::array<double, 3> um{s.z * *scale, s.y * *scale, s.x * *scale};
    write_numbers(dataset, "element_size_um", um, H5T_IEEE_F32LE, file);
  }
}

}  // namespace strata::io::detail::hdf5

// NRRD (teem.sourceforge.net/nrrd/format.html): attached (.nrrd) and detached (.nhdr) headers,
// raw and gzip encodings, either byte order. Raw data is memory-mapped in place; gzip data is
// decoded once to a temporary file which is then memory-mapped.
#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include <fmt/format.h>

#include "io/builtin_formats.hpp"
#include "io/io_detail.hpp"
#include "strata/core/checked.hpp"

namespace strata::io::detail {

namespace {

enum class Encoding { raw, gzip };

// The first line of every NRRD file: "NRRD000" and the version digit.
bool is_magic_line(std::string_view line) {
  return line.size() == 8 && line.starts_with("NRRD000") && line[7] >= '1' && line[7] <= '9';
}

// The header fields we use, as written; validated together by make_layout().
struct NrrdHeader {
  std::optional<DType> dtype;
  std::optional<int> dimension;
  std::vector<std::int64_t> sizes;
  std::vector<double> spacings;          // NaN where the header says nan
  std::vector<double> direction_norms;   // from `space directions`; NaN for `none`
  std::vector<std::optional<Vector3>> directions;  // the same vectors; nullopt for `none`
  std::optional<WorldSpace> space;       // from `space` (or `space dimension`)
  bool space_is_las = false;             // left-anterior-superior: RAS with x reversed
  std::optional<Vector3> space_origin;
  std::string space_unit;                // the first of `space units`, canonical; "" unknown
  std::vector<std::string> kinds;        // lower case, one per axis when given
  std::optional<Encoding> encoding;
  std::optional<bool> big_endian;
  std::int64_t byte_skip = 0;
  std::int64_t line_skip = 0;
  std::optional<std::string> data_file;
  std::optional<std::uint64_t> data_start;  // first byte after the blank line (attached data)
};

struct HeaderParser {
  std::string file;  // for error messages
  NrrdHeader header;

  [[noreturn]] void fail(const std::string& field, const std::string& problem) const {
    throw FormatError(file, field, problem);
  }

  static std::string trim(std::string_view s) {
    auto first = s.find_first_not_of(" \t\r");
    if (first == std::string_view::npos) return {};
    auto last = s.find_last_not_of(" \t\r");
    return std::string(s.substr(first, last - first + 1));
  }

  static std::vector<std::string> words(const std::string& value) {
    std::istringstream in(value);
    std::vector<std::string> out;
    for (std::string w; in >> w;) out.push_back(w);
    return out;
  }

  std::int64_t parse_int(const std::string& text, const std::string& field) const {
    std::int64_t v = 0;
    auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
    if (ec != std::errc{} || end != text.data() + text.size())
      fail(field, fmt::format("expected an integer, found \"{}\"", text));
    return v;
  }

  double parse_double(const std::string& text, const std::string& field) const {
    if (ascii_lower(text) == "nan") return std::nan("");
    double v = 0;
    auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
    if (ec != std::errc{} || end != text.data() + text.size() || !std::isfinite(v))
      fail(field, fmt::format("expected a number, found \"{}\"", text));
    return v;
  }

  DType parse_type(const std::string& value) const {
    static const std::map<std::string, DType> kTypes = {
        {"uchar", DType::u8},        {"unsigned char", DType::u8},      {"uint8", DType::u8},
        {"uint8_t", DType::u8},      {"signed char", DType::i8},        {"int8", DType::i8},
        {"int8_t", DType::i8},       {"short", DType::i16},             {"short int", DType::i16},
        {"signed short", DType::i16}, {"signed short int", DType::i16}, {"int16", DType::i16},
        {"int16_t", DType::i16},     {"ushort", DType::u16},            {"unsigned short", DType::u16},
        {"unsigned short int", DType::u16}, {"uint16", DType::u16},     {"uint16_t", DType::u16},
        {"int", DType::i32},         {"signed int", DType::i32},        {"int32", DType::i32},
        {"int32_t", DType::i32},     {"uint", DType::u32},              {"unsigned int", DType::u32},
        {"uint32", DType::u32},      {"uint32_t", DType::u32},          {"float", DType::f32},
        {"double", DType::f64},
        {"longlong", DType::i64},    {"long long", DType::i64},         {"long long int", DType::i64},
        {"signed long long", DType::i64}, {"signed long long int", DType::i64}, {"int64", DType::i64},
        {"int64_t", DType::i64},     {"ulonglong", DType::u64},         {"unsigned long long", DType::u64},
        {"unsigned long long int", DType::u64}, {"uint64", DType::u64}, {"uint64_t", DType::u64},
    };
    static const std::vector<std::string> kUnsupported = {"block"};
    // Spellings may use several spaces ("unsigned  char"); normalise to single spaces.
    std::string key;
    for (const auto& w : words(ascii_lower(value))) key += (key.empty() ? "" : " ") + w;
    if (auto it = kTypes.find(key); it != kTypes.end()) return it->second;
    if (std::find(kUnsupported.begin(), kUnsupported.end(), key) != kUnsupported.end())
      fail("type", fmt::format("\"{}\" samples are not supported (blocks have no dtype here)", value));
    fail("type", fmt::format("unknown type \"{}\" (expected e.g. uint8, int16, uint16, int32, uint32, float, double)",
                             value));
  }

  Encoding parse_encoding(const std::string& value) const {
    const std::string v = ascii_lower(value);
    if (v == "raw") return Encoding::raw;
    if (v == "gzip" || v == "gz") return Encoding::gzip;
    fail("encoding", fmt::format("\"{}\" is not supported (supported: raw, gzip)", value));
  }

  bool parse_endian(const std::string& value) const {
    const std::string v = ascii_lower(value);
    if (v == "little") return false;
    if (v == "big") return true;
    fail("endian", fmt::format("expected little or big, found \"{}\"", value));
  }

  // "(1,0,0) (0,1,0) none" -> each vector (nullopt for none) and its length (the voxel spacing
  // along that axis; NaN for none).
  void parse_directions(const std::string& value) {
    header.direction_norms.clear();
    header.directions.clear();
    std::size_t i = 0;
    while (true) {
      i = value.find_first_not_of(" \t", i);
      if (i == std::string::npos) return;
      if (value.compare(i, 4, "none") == 0) {
        header.direction_norms.push_back(std::nan(""));
        header.directions.push_back(std::nullopt);
        i += 4;
        continue;
      }
      const std::size_t close = value.find(')', i);
      if (value[i] != '(' || close == std::string::npos)
        fail("space directions", fmt::format("expected vectors like (1,0,0) or none, found \"{}\"", value));
      const std::vector<double> v = parse_vector(value.substr(i, close - i + 1), "space directions");
      if (v.size() != 3)
        fail("space directions", fmt::format("vector {} has {} components; expected 3 (a 3-D space)",
                                             value.substr(i, close - i + 1), v.size()));
      header.direction_norms.push_back(std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]));
      header.directions.push_back(Vector3{v[0], v[1], v[2]});
      i = close + 1;
    }
  }

  // "(1.5,-2,3)" -> its components; nan is refused (NRRD writes `none` for an unknown vector).
  std::vector<double> parse_vector(const std::string& text, const std::string& field) const {
    if (text.size() < 2 || text.front() != '(' || text.back() != ')')
      fail(field, fmt::format("expected a vector like (1,0,0), found \"{}\"", text));
    std::string inside = text.substr(1, text.size() - 2);
    std::replace(inside.begin(), inside.end(), ',', ' ');
    std::vector<double> v;
    for (const auto& w : words(inside)) {
      const double c = parse_double(w, field);
      if (!std::isfinite(c))
        fail(field, fmt::format("vector {} has a non-finite component; write none for an axis without a direction",
                                text));
      v.push_back(c);
    }
    return v;
  }

  // NRRD's anatomical spaces. RAS and LPS are what Strata keeps; LAS (Analyze) is RAS with x
  // reversed, and the scanner or right-handed frames have no anatomy.
  void parse_space(const std::string& value) {
    const std::string s = ascii_lower(trim(value));
    header.space_is_las = s == "left-anterior-superior" || s == "las";
    if (s == "right-anterior-superior" || s == "ras" || header.space_is_las) header.space = WorldSpace::ras;
    else if (s == "left-posterior-superior" || s == "lps") header.space = WorldSpace::lps;
    else if (s == "scanner-xyz" || s == "3d-right-handed" || s == "3d-left-handed") header.space = WorldSpace::unspecified;
    else fail("space", fmt::format("\"{}\" is not a 3-D space (expected e.g. left-posterior-superior)", value));
  }

  // `space units: "mm" "mm" "mm"`: one unit for all three axes, as Strata keeps one.
  void parse_space_units(const std::string& value) {
    std::vector<std::string> units;
    for (std::size_t i = value.find('"'); i != std::string::npos; i = value.find('"', i)) {
      const std::size_t close = value.find('"', i + 1);
      if (close == std::string::npos) fail("space units", fmt::format("unterminated quote in \"{}\"", value));
      units.push_back(value.substr(i + 1, close - i - 1));
      i = close + 1;
    }
    if (!units.empty() && std::all_of(units.begin(), units.end(), [&](const std::string& u) { return u == units[0]; }))
      header.space_unit = canonical_length_unit(units[0]);
  }

  std::vector<double> parse_doubles(const std::string& value, const std::string& field) const {
    std::vector<double> out;
    for (const auto& w : words(value)) out.push_back(parse_double(w, field));
    return out;
  }

  // "LIST" (names on the following lines) and "pattern min max step" split the data over
  // several files; we read one file per volume.
  std::string check_single_data_file(const std::string& value) const {
    if (value.rfind("LIST", 0) == 0 || words(value).size() != 1)
      fail("data file", fmt::format("\"{}\": data split over several files is not supported", value));
    return value;
  }

  void apply_field(const std::string& field, const std::string& value) {
    if (field == "type") header.dtype = parse_type(value);
    else if (field == "dimension") {
      const std::int64_t d = parse_int(value, field);
      if (d < 1 || d > 16) fail(field, fmt::format("{} is not a dimension count (a 3-D volume is expected)", d));
      header.dimension = int(d);
    }
    else if (field == "sizes") {
      header.sizes.clear();
      for (const auto& w : words(value)) header.sizes.push_back(parse_int(w, field));
    } else if (field == "spacings") header.spacings = parse_doubles(value, field);
    else if (field == "space directions") parse_directions(value);
    else if (field == "space") parse_space(value);
    else if (field == "space dimension") {
      if (parse_int(value, field) != 3) fail(field, fmt::format("{} is not supported (a 3-D space is expected)", value));
      header.space = WorldSpace::unspecified;
    } else if (field == "space origin") {
      const std::vector<double> o = parse_vector(trim(value), field);
      if (o.size() != 3) fail(field, fmt::format("\"{}\" has {} components; expected 3", value, o.size()));
      header.space_origin = Vector3{o[0], o[1], o[2]};
    } else if (field == "space units") parse_space_units(value);
    else if (field == "kinds") {
      header.kinds.clear();
      for (const auto& w : words(value)) header.kinds.push_back(ascii_lower(w));
    }
    else if (field == "encoding") header.encoding = parse_encoding(value);
    else if (field == "endian") header.big_endian = parse_endian(value);
    else if (field == "byte skip" || field == "byteskip") header.byte_skip = parse_int(value, "byte skip");
    else if (field == "line skip" || field == "lineskip") header.line_skip = parse_int(value, "line skip");
    else if (field == "data file" || field == "datafile") header.data_file = check_single_data_file(value);
    // Every other field (content, units, measurement frame, ...) does not affect the samples.
  }

  void parse_line(const std::string& line, std::size_t line_number) {
    if (line.empty() || line[0] == '#') return;
    const std::size_t colon = line.find(':');
    if (colon == std::string::npos)
      fail("header", fmt::format("line {} is neither \"field: value\", \"key:=value\" nor a # comment: \"{}\"",
                                 line_number, line.substr(0, 80)));
    if (colon + 1 < line.size() && line[colon + 1] == '=') return;  // key:=value pairs carry no layout
    apply_field(ascii_lower(trim(std::string_view(line).substr(0, colon))), trim(std::string_view(line).substr(colon + 1)));
  }

  // Reads the magic line and then fields up to the blank line that starts attached data, or
  // to the end of a detached header.
  void parse(const std::byte* data, std::uint64_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    std::uint64_t pos = 0;
    std::size_t line_number = 0;
    while (pos < size) {
      std::size_t newline = text.find('\n', pos);
      std::uint64_t end = newline == std::string_view::npos ? size : newline;
      std::string line(text.substr(pos, end - pos));
      if (!line.empty() && line.back() == '\r') line.pop_back();
      pos = newline == std::string_view::npos ? size : newline + 1;
      if (++line_number == 1) {
        check_magic(line);
        continue;
      }
      if (line.empty()) {
        header.data_start = pos;
        return;
      }
      parse_line(line, line_number);
    }
    if (line_number == 0) check_magic("");
  }

  void check_magic(const std::string& line) const {
    if (!is_magic_line(line))
      fail("magic", fmt::format("not a NRRD file: the first line is \"{}\", expected NRRD0001..NRRD0005",
                                line.substr(0, 40)));
  }
};

// The validated meaning of a header.
struct NrrdLayout {
  VolumeInfo info;  // of one 3D volume; info.volumes of them
  bool interleaved = false;  // the volume axis comes first (component fastest), else last
  Encoding encoding = Encoding::raw;
  bool big_endian = false;
  std::int64_t byte_skip = 0;
  std::int64_t line_skip = 0;
  std::filesystem::path data_path;
  std::uint64_t data_start = 0;
};

// A 4-D header whose first axis has one sample (e.g. a one-component vector field) is a 3-D volume.
void drop_leading_unit_axis(NrrdHeader& h) {
  if (h.dimension != 4 || h.sizes.size() != 4 || h.sizes[0] != 1) return;
  h.sizes.erase(h.sizes.begin());
  if (h.spacings.size() == 4) h.spacings.erase(h.spacings.begin());
  if (h.direction_norms.size() == 4) h.direction_norms.erase(h.direction_norms.begin());
  if (h.directions.size() == 4) h.directions.erase(h.directions.begin());
  h.dimension = 3;
}

// A 4-D header holds several 3D volumes along its one axis whose kind is not spatial (domain or
// space): first, interleaved (vector, RGB-color, list, ...: multi-channel microscopy), or last,
// one volume after the other (time, list: a series). That axis leaves the 3-D layout and becomes
// the volume count. Without `kinds` the axis cannot be told and the file is refused.
void split_volume_axis(NrrdHeader& h, NrrdLayout& layout, const std::string& file) {
  if (h.dimension != 4 || h.sizes.size() != 4) return;
  if (h.kinds.size() != 4)
    throw FormatError(file, "kinds",
                      "a 4-D volume needs the axis kinds, to tell its components or time points from its three space "
                      "axes (e.g. kinds: vector domain domain domain)");
  const auto spatial = [](const std::string& k) { return k == "domain" || k == "space"; };
  std::size_t axis = 4;
  for (std::size_t a = 0; a < 4; ++a)
    if (!spatial(h.kinds[a])) {
      if (axis != 4 || (a != 0 && a != 3))
        throw FormatError(file, "kinds",
                          fmt::format("\"{} {} {} {}\": expected three spatial axes (domain or space) and one other, "
                                      "first or last", h.kinds[0], h.kinds[1], h.kinds[2], h.kinds[3]));
      axis = a;
    }
  if (axis == 4) throw FormatError(file, "kinds", "all four axes are spatial; expected one axis of components or times");
  const auto drop = [&](auto& v) {
    if (v.size() == 4) v.erase(v.begin() + std::ptrdiff_t(axis));
  };
  if (h.sizes[axis] < 1) throw FormatError(file, "sizes", fmt::format("axis {} is {}; expected at least 1", axis, h.sizes[axis]));
  layout.info.volumes = h.sizes[axis];
  layout.interleaved = axis == 0;
  drop(h.sizes);
  drop(h.spacings);
  drop(h.direction_norms);
  drop(h.directions);
  h.dimension = 3;
}

// `spacings` and `space directions` are alternatives. The rule for odd values: nan in
// `spacings` and none in `space directions` are NRRD's spellings of "unknown" and give 1;
// a spacing of 0 or below (a zero-length direction) is an error, never silently replaced.
Spacing spacing_of(const NrrdHeader& h, const std::string& file) {
  const bool from_spacings = !h.spacings.empty();
  const std::vector<double>& s = from_spacings ? h.spacings : h.direction_norms;
  if (s.size() != 3) return {};
  const auto pick = [&](std::size_t axis) {
    const double v = s[axis];
    if (std::isnan(v)) return 1.0;
    if (!(v > 0) || !std::isfinite(v)) {
      if (from_spacings)
        throw FormatError(file, "spacings",
                          fmt::format("axis {} is {}; expected a positive number (or nan for unknown)", axis, v));
      throw FormatError(file, "space directions",
                        fmt::format("axis {} has a zero-length vector; expected a non-zero vector (or none)", axis));
    }
    return v;
  };
  return {pick(0), pick(1), pick(2)};
}

// Where the volume lies: `space directions` (unit vectors; their lengths are the spacing),
// `space origin` and `space units`, in the `space` they name. Without three direction vectors
// the axes are the space's own.
Geometry geometry_of(const NrrdHeader& h) {
  Geometry g;
  g.space = h.space.value_or(WorldSpace::unspecified);
  g.unit = h.space_unit;
  if (h.space_origin) g.origin = *h.space_origin;
  const bool all_directions = h.directions.size() == 3 &&
                              std::all_of(h.directions.begin(), h.directions.end(), [](const auto& d) { return d.has_value(); });
  if (all_directions)
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) g.direction[r][c] = (*h.directions[c])[r] / h.direction_norms[c];
  if (h.space_is_las) {
    g.origin[0] = -g.origin[0];
    for (double& v : g.direction[0]) v = -v;
  }
  return g;
}

void check_required(const NrrdHeader& h, const std::string& file) {
  if (!h.dtype) throw FormatError(file, "type", "missing");
  if (!h.dimension) throw FormatError(file, "dimension", "missing");
  if (h.sizes.empty()) throw FormatError(file, "sizes", "missing");
  if (!h.encoding) throw FormatError(file, "encoding", "missing");
  if (*h.dimension != 3)
    throw FormatError(file, "dimension", fmt::format("{} is not supported (a 3-D volume is expected)", *h.dimension));
  if (h.sizes.size() != 3)
    throw FormatError(file, "sizes", fmt::format("{} values given, expected 3 for dimension 3", h.sizes.size()));
  if (std::any_of(h.sizes.begin(), h.sizes.end(), [](std::int64_t s) { return s <= 0; }))
    throw FormatError(file, "sizes", fmt::format("{} {} {} must all be positive", h.sizes[0], h.sizes[1], h.sizes[2]));
  if (!h.spacings.empty() && h.spacings.size() != 3)
    throw FormatError(file, "spacings", fmt::format("{} values given, expected 3", h.spacings.size()));
  if (!h.direction_norms.empty() && h.direction_norms.size() != 3)
    throw FormatError(file, "space directions", fmt::format("{} vectors given, expected 3", h.direction_norms.size()));
  if (dtype_size(*h.dtype) > 1 && !h.big_endian)
    throw FormatError(file, "endian", "missing (required for samples wider than one byte)");
  if (h.byte_skip < -1) throw FormatError(file, "byte skip", fmt::format("{} is negative", h.byte_skip));
  if (h.byte_skip == -1 && *h.encoding != Encoding::raw)
    throw FormatError(file, "byte skip", "-1 (data at the end of the file) only works with raw encoding");
  if (h.line_skip < 0) throw FormatError(file, "line skip", fmt::format("{} is negative", h.line_skip));
}

std::filesystem::path resolve_data_file(const std::string& value, const std::filesystem::path& header_path) {
  std::filesystem::path p(value);
  return p.is_absolute() ? p : header_path.parent_path() / p;
}

NrrdLayout make_layout(NrrdHeader h, const std::filesystem::path& path) {
  const std::string file = path.string();
  drop_leading_unit_axis(h);
  NrrdLayout layout;
  split_volume_axis(h, layout, file);
  check_required(h, file);
  const std::int64_t volumes = layout.info.volumes;
  layout.info = VolumeInfo{{h.sizes[0], h.sizes[1], h.sizes[2]}, *h.dtype, spacing_of(h, file)};
  layout.info.volumes = volumes;
  layout.info.geometry = geometry_of(h);
  if (!checked_mul(checked_volume_bytes(layout.info, file, "sizes"), std::uint64_t(volumes)))
    throw FormatError(file, "sizes", "the volumes overflow a 64-bit byte count (corrupt or hostile header)");
  layout.encoding = *h.encoding;
  layout.big_endian = h.big_endian.value_or(false);
  layout.byte_skip = h.byte_skip;
  layout.line_skip = h.line_skip;
  if (h.data_file) {
    layout.data_path = resolve_data_file(*h.data_file, path);
  } else if (h.data_start) {
    layout.data_path = path;
    layout.data_start = *h.data_start;
  } else {
    throw FormatError(file, "data file",
                      "missing: a detached header (.nhdr) must name its data file, and an attached header must end "
                      "with a blank line before the data");
  }
  return layout;
}

NrrdLayout read_layout(const std::filesystem::path& path) {
  MappedFile header_file(path);
  HeaderParser parser{path.string(), {}};
  parser.parse(header_file.data(), header_file.size());
  return make_layout(std::move(parser.header), path);
}

// Maps the data file, naming the header too when it is missing: that is the file to fix.
std::shared_ptr<MappedFile> map_data_file(const std::filesystem::path& header_path, const NrrdLayout& layout) {
  if (layout.data_path == header_path) return std::make_shared<MappedFile>(header_path);
  try {
    return std::make_shared<MappedFile>(layout.data_path);
  } catch (const Error& e) {
    throw FormatError(header_path.string(), "data file", e.what());
  }
}

// Position after `lines` newline-terminated lines starting at `start`.
std::uint64_t skip_lines(const MappedFile& file, std::uint64_t start, std::int64_t lines, const std::string& name) {
  std::uint64_t pos = start;
  for (std::int64_t i = 0; i < lines; ++i) {
    const void* hit = pos < file.size() ? std::memchr(file.data() + pos, '\n', file.size() - pos) : nullptr;
    if (!hit) throw FormatError(name, "line skip", fmt::format("the data has fewer than {} lines to skip", lines));
    pos = std::uint64_t(static_cast<const std::byte*>(hit) - file.data()) + 1;
  }
  return pos;
}

// Exact sizes: extra or missing bytes mean `sizes` or `type` disagree with the data, and
// reading anyway would silently scramble the volume.
// The bytes of every volume of the file (checked against overflow by make_layout).
std::uint64_t data_bytes(const NrrdLayout& layout) { return layout.info.byte_size() * std::uint64_t(layout.info.volumes); }

std::string sizes_text(const NrrdLayout& layout) {
  const std::string dims = layout.info.dims.to_string();
  return layout.info.volumes == 1 ? dims : fmt::format("{} volumes of {}", layout.info.volumes, dims);
}

void check_data_bytes(const std::string& file, const NrrdLayout& layout, std::uint64_t available,
                      const char* where) {
  const std::uint64_t needed = data_bytes(layout);
  if (available == needed) return;
  throw FormatError(file, "data",
                    fmt::format("{} holds {} bytes of samples, but sizes {} of type {} need {}{}", where, available,
                                sizes_text(layout), dtype_name(layout.info.dtype), needed,
                                available < needed ? " (truncated file or wrong sizes)" : " (wrong sizes or type)"));
}

// The source of the chosen volume (ReadOptions::volume) of the samples at `offset` of `data`.
std::unique_ptr<VolumeSource> volume_source(std::shared_ptr<MappedFile> data, std::uint64_t offset,
                                            const NrrdLayout& layout, const std::filesystem::path& path,
                                            const ReadOptions& options) {
  const std::int64_t t = choose_volume(layout.info.volumes, layout.info.dims, options, path.string(), "kinds",
                                       layout.interleaved ? "components, interleaved" : "the last axis");
  if (layout.interleaved)
    return make_mapped_source(std::move(data), offset, layout.info, layout.big_endian, path, "data",
                              {layout.info.volumes, t});
  return make_mapped_source(std::move(data), offset + std::uint64_t(t) * layout.info.byte_size(), layout.info,
                            layout.big_endian, path, "data");
}

std::unique_ptr<VolumeSource> open_raw_encoded(const std::filesystem::path& path, const NrrdLayout& layout,
                                               const ReadOptions& options) {
  auto data = map_data_file(path, layout);
  const std::uint64_t start = skip_lines(*data, layout.data_start, layout.line_skip, path.string());
  std::uint64_t offset = start + std::uint64_t(std::max<std::int64_t>(layout.byte_skip, 0));
  // byte skip -1: the samples are the last bytes of the file, whatever precedes them.
  if (layout.byte_skip == -1 && data->size() - start >= data_bytes(layout)) offset = data->size() - data_bytes(layout);
  check_data_bytes(path.string(), layout, offset > data->size() ? 0 : data->size() - offset,
                   layout.data_path == path ? "the file after its header" : "the data file");
  return volume_source(std::move(data), offset, layout, path, options);
}

// Gzip data is decoded as reads need it (make_gzip_source): a pass in z order never writes it
// to disk, and a volume of a series decodes only the volumes before it.
std::unique_ptr<VolumeSource> open_gzip_encoded(const std::filesystem::path& path, const NrrdLayout& layout,
                                                const ReadOptions& options) {
  // For compressed encodings the byte skip counts decoded bytes (as teem does).
  const auto skip = std::uint64_t(layout.byte_skip);
  // Decoded sizes are file sizes: they must fit in a signed 64-bit offset.
  const auto declared = data_bytes(layout) > std::uint64_t(INT64_MAX) ? std::nullopt
                                                                      : checked_add(layout.byte_skip, std::int64_t(data_bytes(layout)));
  if (!declared)
    throw FormatError(path.string(), "byte skip",
                      fmt::format("{} plus the {} bytes of samples overflows a 64-bit file offset", skip,
                                  data_bytes(layout)));
  auto compressed = map_data_file(path, layout);
  const std::uint64_t start = skip_lines(*compressed, layout.data_start, layout.line_skip, path.string());
  if (start >= compressed->size())
    throw FormatError(path.string(), "data", "no gzip data follows the header (truncated file)");
  const std::int64_t t = choose_volume(layout.info.volumes, layout.info.dims, options, path.string(), "kinds",
                                       layout.interleaved ? "components, interleaved" : "the last axis");
  GzipVolume volume{
      .info = layout.info,
      .big_endian = layout.big_endian,
      .offset = skip + (layout.interleaved ? 0 : std::uint64_t(t) * layout.info.byte_size()),
      .interleave = layout.interleaved ? Interleave{layout.info.volumes, t} : Interleave{},
      .declared = {std::uint64_t(*declared),
                   fmt::format("the header (sizes {} of type {}{})", sizes_text(layout), dtype_name(layout.info.dtype),
                               skip ? fmt::format(" after a byte skip of {}", skip) : "")},
      .field = "data",
      .report_short = [file = path.string(), layout, skip](std::uint64_t decoded) {
        check_data_bytes(file, layout, decoded > skip ? decoded - skip : 0, "the decoded gzip stream");
      },
  };
  return make_gzip_source(std::move(compressed), start, std::move(volume), path, options);
}

// ---------------------------------------------------------------------------------------------

const char* nrrd_type_name(DType t) {
  switch (t) {
    case DType::u8: return "uint8";
    case DType::i8: return "int8";
    case DType::u16: return "uint16";
    case DType::i16: return "int16";
    case DType::u32: return "uint32";
    case DType::i32: return "int32";
    case DType::f32: return "float";
    case DType::f64: return "double";
    case DType::u64: return "uint64";
    case DType::i64: return "int64";
  }
  throw Error("nrrd: invalid dtype");
}

// The spacing alone (`spacings`) for a volume without placement; else `space`, `space
// directions` (unit direction times spacing), `space origin` and `space units`. "{}" prints the
// shortest text that parses back to the same double.
std::string placement_fields(const VolumeInfo& info) {
  const Geometry& g = info.geometry;
  if (g.origin == Vector3{0, 0, 0} && g.direction == kIdentity3 && g.space == WorldSpace::unspecified && g.unit.empty())
    return fmt::format("spacings: {} {} {}\n", info.spacing.x, info.spacing.y, info.spacing.z);
  std::string h;
  switch (g.space) {
    case WorldSpace::ras: h += "space: right-anterior-superior\n"; break;
    case WorldSpace::lps: h += "space: left-posterior-superior\n"; break;
    case WorldSpace::unspecified: h += "space dimension: 3\n"; break;
  }
  const std::array<double, 3> s{info.spacing.x, info.spacing.y, info.spacing.z};
  h += "space directions:";
  for (int c = 0; c < 3; ++c)
    h += fmt::format(" ({},{},{})", g.direction[0][c] * s[c], g.direction[1][c] * s[c], g.direction[2][c] * s[c]);
  h += fmt::format("\nspace origin: ({},{},{})\n", g.origin[0], g.origin[1], g.origin[2]);
  if (!g.unit.empty()) h += fmt::format("space units: \"{0}\" \"{0}\" \"{0}\"\n", g.unit);
  return h;
}

std::string header_text(const VolumeInfo& info, bool compress, const std::string& data_file) {
  std::string h = "NRRD0004\n# Complete NRRD file format specification at:\n"
                  "# http://teem.sourceforge.net/nrrd/format.html\n";
  h += fmt::format("type: {}\ndimension: 3\n", nrrd_type_name(info.dtype));
  h += fmt::format("sizes: {} {} {}\n", info.dims.x, info.dims.y, info.dims.z);
  h += placement_fields(info);
  h += fmt::format("endian: {}\n", std::endian::native == std::endian::big ? "big" : "little");
  h += fmt::format("encoding: {}\n", compress ? "gzip" : "raw");
  if (!data_file.empty()) return h + fmt::format("data file: {}\n", data_file);
  return h + "\n";  // the blank line that separates an attached header from its data
}

// The entry's extensions: an attached header (data in the same file) and a detached one.
constexpr std::string_view kAttachedExtension = ".nrrd";
constexpr std::string_view kDetachedExtension = ".nhdr";

bool is_detached_name(const std::filesystem::path& path) {
  return ascii_lower(path.extension().string()) == kDetachedExtension;
}

// A detached header's data file: `<stem>` plus the raw format's extension (the samples are a
// raw file), and the gzip suffix when compressed.
std::string detached_data_name(const std::filesystem::path& header, bool compress) {
  return header.stem().string() + raw_format().extensions.front() + (compress ? std::string(kGzipSuffix) : "");
}

// Attached: header then data in one file. For a .nhdr name the data goes to `<stem>.raw` or
// `<stem>.raw.gz` beside it, and the header is written last so it never names missing data.
class NrrdWriter final : public VolumeWriter {
 public:
  NrrdWriter(const std::filesystem::path& path, const VolumeInfo& info, bool compress)
      : path_(path), info_(info), compress_(compress),
        data_name_(is_detached_name(path) ? detached_data_name(path, compress) : ""),
        out_(data_name_.empty() ? path : path.parent_path() / data_name_, compress,
             data_name_.empty() ? header_text(info, compress, "") : "") {}

  void write_slab(const Volume& slab) override { out_.write(slab.bytes(), slab.byte_size()); }

  void finish() override {
    out_.commit();
    if (!data_name_.empty()) write_file_atomically(path_, header_text(info_, compress_, data_name_));
  }

 private:
  std::filesystem::path path_;
  VolumeInfo info_;
  bool compress_;
  std::string data_name_;  // empty for an attached header
  OutputStream out_;       // the attached header and data, or the detached data
};

// ---------------------------------------------------------------------------------------------
// The data files a header names, for files_read

// At most this many names of a `data file` pattern are listed (a hostile range is not expanded).
constexpr std::int64_t kMaxPatternFiles = 100000;

// `pattern` (printf style, one %d, %i or %u conversion with optional 0 flag and width) with
// `value` in place of the conversion; nullopt when there is no such conversion.
std::optional<std::string> expand_pattern(const std::string& pattern, std::int64_t value) {
  for (std::size_t at = pattern.find('%'); at != std::string::npos; at = pattern.find('%', at + 2)) {
    if (at + 1 < pattern.size() && pattern[at + 1] == '%') continue;  // "%%": a literal percent
    std::size_t end = at + 1;
    const bool zero = end < pattern.size() && pattern[end] == '0';
    std::size_t width = 0;
    while (end < pattern.size() && std::isdigit(static_cast<unsigned char>(pattern[end])))
      width = std::min<std::size_t>(width * 10 + std::size_t(pattern[end++] - '0'), 64);
    if (end >= pattern.size() || (pattern[end] != 'd' && pattern[end] != 'i' && pattern[end] != 'u')) return std::nullopt;
    std::string number = std::to_string(value);
    if (number.size() < width) number.insert(0, width - number.size(), zero ? '0' : ' ');
    return pattern.substr(0, at) + number + pattern.substr(end + 1);
  }
  return std::nullopt;
}

// The files of a `data file` value: one name; `LIST`, the names on the header's remaining lines;
// or a pattern "<format> <min> <max> <step> [<subdim>]".
std::vector<std::string> data_file_names(const std::string& value, std::istream& rest) {
  const std::vector<std::string> words = HeaderParser::words(value);
  if (words.empty()) return {};
  if (words[0] == "LIST") {
    std::vector<std::string> names;
    for (std::string line; std::getline(rest, line);) {
      line = HeaderParser::trim(line);
      if (line.empty()) break;
      names.push_back(line);
    }
    return names;
  }
  if (words.size() >= 4) {
    std::int64_t range[3]{};
    bool numbers = true;
    for (int i = 0; i < 3; ++i) {
      const std::string& w = words[std::size_t(i) + 1];
      numbers = numbers && std::from_chars(w.data(), w.data() + w.size(), range[i]).ec == std::errc{};
    }
    if (numbers && expand_pattern(words[0], range[0])) {
      std::vector<std::string> names;
      const auto [first, last, step] = range;
      std::int64_t i = first;
      for (std::int64_t n = 0; n < kMaxPatternFiles && (step > 0 ? i <= last : step < 0 ? i >= last : n == 0); ++n) {
        names.push_back(*expand_pattern(words[0], i));
        if (__builtin_add_overflow(i, step, &i)) break;
      }
      return names;
    }
  }
  return {value};
}

// The files a header's `data file` field names, read as leniently as a header can be: its
// reader refuses what it cannot read, and this only has to say which files it would open.
std::vector<TouchedPath> nrrd_files_read(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  if (!std::getline(in, line) || !is_magic_line(HeaderParser::trim(line))) return {};
  std::vector<TouchedPath> files;
  for (std::size_t lines = 0; lines < 100000 && std::getline(in, line); ++lines) {
    line = HeaderParser::trim(line);
    if (line.empty()) break;  // attached data follows
    const std::size_t colon = line.find(':');
    if (line[0] == '#' || colon == std::string::npos || (colon + 1 < line.size() && line[colon + 1] == '=')) continue;
    const std::string field = ascii_lower(HeaderParser::trim(std::string_view(line).substr(0, colon)));
    if (field != "data file" && field != "datafile") continue;
    for (const std::string& name : data_file_names(HeaderParser::trim(std::string_view(line).substr(colon + 1)), in))
      files.push_back({.path = resolve_data_file(name, path), .named = path, .role = "data file", .field = "data file"});
    break;
  }
  return files;
}

// A detached header's data file (NrrdWriter) beside the header, each with its temporary.
std::vector<TouchedPath> nrrd_files_written(const std::filesystem::path& path, const WriteOptions& options) {
  std::vector<TouchedPath> files;
  add_written_file(files, path, path);
  if (is_detached_name(path))
    add_written_file(files, path.parent_path() / detached_data_name(path, options.compress), path, "data file");
  return files;
}

std::unique_ptr<VolumeSource> open_nrrd(const std::filesystem::path& path, const ReadOptions& options) {
  const NrrdLayout layout = read_layout(path);
  if (layout.encoding == Encoding::gzip) return open_gzip_encoded(path, layout, options);
  return open_raw_encoded(path, layout, options);
}

std::unique_ptr<VolumeWriter> create_nrrd_writer(const std::filesystem::path& path, const VolumeInfo& info,
                                                 const WriteOptions& options) {
  return std::make_unique<NrrdWriter>(path, info, options.compress);
}

// The sniffer: the file starts with the magic line.
bool has_nrrd_magic(std::span<const std::byte> head) {
  const std::string_view text(reinterpret_cast<const char*>(head.data()), std::min<std::size_t>(head.size(), 8));
  return is_magic_line(text);
}

}  // namespace

VolumeFormat nrrd_format() {
  return {
      .name = "nrrd",
      .title = "NRRD",
      .description = "teem's nearly raw raster data: a text header, attached or detached, and raw or gzip samples",
      .extensions = {std::string(kAttachedExtension), std::string(kDetachedExtension)},
      .magic_bytes = 8,
      .sniff = has_nrrd_magic,
      .open = open_nrrd,
      .files_read = nrrd_files_read,
      .create_writer = create_nrrd_writer,
      .files_written = nrrd_files_written,
      .capabilities = {.streaming = true, .multi_volume = true, .spatial_metadata = true},
      .write_dtypes = DTypeSet::all(),
      .read_notes = "attached or detached header, raw/gzip, little/big endian, mmap for raw; 4-D files one volume at a "
                    "time with `--volume T` (alias `--component`, `--time`): the axis whose `kinds` entry is not "
                    "`domain`/`space`, first (interleaved components: vector, RGB-color, …) or last (a series: time, "
                    "list)",
      .write_notes = "attached, gzip (or raw with `--uncompressed`); a `.nhdr` name: a detached header beside its "
                     "`.raw` (`.raw.gz`) data",
  };
}

}  // namespace strata::io::detail

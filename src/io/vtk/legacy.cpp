// Legacy VTK files (.vtk) of STRUCTURED_POINTS, read. The header is lines of text; keywords are
// case-insensitive:
// | line / keyword            | meaning here                                                   |
// | ------------------------- | -------------------------------------------------------------- |
// | # vtk DataFile Version x.y | the signature                                                 |
// | (title)                   | one line, ignored                                              |
// | ASCII or BINARY           | samples as text, or big-endian binary                          |
// | DATASET STRUCTURED_POINTS | the only dataset read                                          |
// | DIMENSIONS nx ny nz       | dims                                                           |
// | SPACING or ASPECT_RATIO   | sx sy sz (default 1 1 1)                                       |
// | ORIGIN x y z              | centre of voxel 0 (default 0 0 0)                              |
// | POINT_DATA n              | n = nx ny nz                                                   |
// | SCALARS name type [ncomp] | an array; ReadOptions::dataset picks by name, else the first   |
// | LOOKUP_TABLE name         | after SCALARS; then the samples (BINARY: after the line break) |
// BINARY samples are memory-mapped in place; ASCII ones are parsed once into a temporary file.
#include <fmt/format.h>

#include "io/vtk/vtk_detail.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail::vtk {

namespace {

constexpr std::string_view kSignature = "# vtk DataFile Version";

// Words of the header, read from the mapped text one at a time.
class Cursor {
 public:
  Cursor(std::string_view text, const std::string& file) : text_(text), file_(file) {}

  std::string_view line(const std::string& field) {
    if (at_ >= text_.size()) throw FormatError(file_, field, "the file ends before it");
    const std::size_t end = std::min(text_.find('\n', at_), text_.size());
    std::string_view l = text_.substr(at_, end - at_);
    at_ = std::min(end + 1, text_.size());
    if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
    return l;
  }
  // The next word, "" at the end of the text.
  std::string_view word() {
    at_ = std::min(text_.find_first_not_of(" \t\r\n", at_), text_.size());
    const std::size_t end = std::min(text_.find_first_of(" \t\r\n", at_), text_.size());
    const std::string_view w = text_.substr(at_, end - at_);
    at_ = end;
    return w;
  }
  std::string keyword() { return ascii_lower(std::string(word())); }
  std::string_view peek_word() {
    const std::size_t saved = at_;
    const std::string_view w = word();
    at_ = saved;
    return w;
  }
  // The rest of the line, then the position after its line break: where binary data starts.
  void skip_line() { line("data"); }
  std::vector<double> doubles(std::size_t n, const std::string& field) {
    std::string joined;
    for (std::size_t i = 0; i < n; ++i) joined += std::string(word()) + " ";
    return parse_doubles(joined, n, file_, field);
  }
  std::int64_t integer(const std::string& field) { return parse_ints(word(), 1, file_, field)[0]; }
  std::size_t at() const { return at_; }
  void advance(std::uint64_t n) { at_ = std::size_t(std::min<std::uint64_t>(at_ + n, text_.size())); }
  std::string_view rest() const { return text_.substr(at_); }

 private:
  std::string_view text_;
  const std::string& file_;
  std::size_t at_ = 0;
};

struct Structure {
  Extent dims{};
  Vector3 spacing{1, 1, 1}, origin{0, 0, 0};
};

Structure read_structure(Cursor& in, const std::string& file) {
  const std::string dataset = in.keyword();
  const std::string kind = in.keyword();
  if (dataset != "dataset" || kind != "structured_points")
    throw FormatError(file, "DATASET", fmt::format("\"{} {}\" is not read (only DATASET STRUCTURED_POINTS)", dataset, kind));
  Structure s;
  bool have_dims = false;
  while (in.peek_word().size() > 0) {
    const std::string key = ascii_lower(std::string(in.peek_word()));
    if (key == "point_data") break;
    in.word();
    if (key == "dimensions") {
      std::int64_t n[3];
      for (std::int64_t& v : n) v = in.integer("DIMENSIONS");
      s.dims = {n[0], n[1], n[2]};
      have_dims = true;
    } else if (key == "spacing" || key == "aspect_ratio") {
      const auto v = in.doubles(3, "SPACING");
      s.spacing = {v[0], v[1], v[2]};
    } else if (key == "origin") {
      const auto v = in.doubles(3, "ORIGIN");
      s.origin = {v[0], v[1], v[2]};
    } else {
      throw FormatError(file, "DATASET", fmt::format("unexpected \"{}\" before POINT_DATA", key.substr(0, 40)));
    }
  }
  if (!have_dims) throw FormatError(file, "DIMENSIONS", "missing");
  return s;
}

struct Scalars {
  std::string name;
  DType dtype{};
  std::int64_t components = 1;
};

Scalars read_scalars_line(Cursor& in, const std::string& file) {
  const std::string key = in.keyword();
  if (key != "scalars")
    throw FormatError(file, "POINT_DATA",
                      fmt::format("\"{}\" is not read (only SCALARS arrays of point data)", key.substr(0, 40)));
  Scalars s;
  s.name = std::string(in.word());
  const std::string_view type = in.word();
  const std::optional<DType> dtype = dtype_of_legacy_type(type);
  if (!dtype) throw FormatError(file, "SCALARS type", fmt::format("\"{}\" is not read", type.substr(0, 40)));
  s.dtype = *dtype;
  const std::string_view next = in.peek_word();
  if (!next.empty() && next.find_first_not_of("0123456789") == std::string_view::npos) {
    s.components = in.integer("SCALARS numComp");
    if (s.components < 1 || s.components > kMaxComponents)
      throw FormatError(file, "SCALARS numComp", fmt::format("{} (expected 1..{})", s.components, kMaxComponents));
  }
  return s;
}

}  // namespace

std::unique_ptr<VolumeSource> open_legacy(const std::filesystem::path& path, const ReadOptions& options) {
  const std::string file = path.string();
  auto mapped = std::make_shared<MappedFile>(path);
  const std::string_view text(reinterpret_cast<const char*>(mapped->data()), mapped->size());
  Cursor in(text, file);
  if (!in.line("signature").starts_with(kSignature))
    throw FormatError(file, "signature", fmt::format("the first line is not \"{} x.y\"", kSignature));
  in.line("title");
  const std::string encoding = ascii_lower(std::string(in.word()));
  if (encoding != "ascii" && encoding != "binary")
    throw FormatError(file, "ASCII|BINARY", fmt::format("\"{}\" (expected ASCII or BINARY)", encoding.substr(0, 40)));
  const bool binary = encoding == "binary";
  const Structure structure = read_structure(in, file);
  in.word();  // POINT_DATA
  const std::int64_t points = in.integer("POINT_DATA");
  const auto count = structure.dims.checked_voxel_count();
  if (!count || points != *count)
    throw FormatError(file, "POINT_DATA", fmt::format("{} points, DIMENSIONS {} make {}", points, structure.dims.to_string(),
                                                      count ? fmt::format("{}", *count) : "too many"));
  while (true) {
    if (in.peek_word().empty())
      throw FormatError(file, "SCALARS",
                        options.dataset.empty() ? "no SCALARS array" : fmt::format("no array named \"{}\"", options.dataset));
    const Scalars scalars = read_scalars_line(in, file);
    const ArrayLayout layout =
        array_layout(structure.dims, {0, 0, 0}, scalars.dtype, scalars.components, structure.origin, structure.spacing,
                     kIdentity3, file, "SPACING", "DIMENSIONS");
    if (ascii_lower(std::string(in.peek_word())) == "lookup_table") {
      in.word();
      in.word();
    } else if (binary) {
      throw FormatError(file, "LOOKUP_TABLE", "missing after SCALARS (binary data starts after it)");
    }
    const std::string field = fmt::format("SCALARS {}", scalars.name);
    const bool wanted = options.dataset.empty() || options.dataset == scalars.name;
    if (binary) {
      in.skip_line();
      if (wanted) return component_source(std::move(mapped), in.at(), layout, true, path, options, field);
      in.advance(layout.bytes);
      continue;
    }
    const std::uint64_t samples = layout.bytes / dtype_size(scalars.dtype);
    if (!wanted) {
      in.advance(parse_ascii_samples(in.rest(), scalars.dtype, samples, nullptr, file, field));
      continue;
    }
    DecodedSamples out(options, file, field, layout.bytes);
    parse_ascii_samples(in.rest(), scalars.dtype, samples, &out, file, field);
    return component_source(out.map(), 0, layout, false, path, options, field);
  }
}

}  // namespace strata::io::detail::vtk

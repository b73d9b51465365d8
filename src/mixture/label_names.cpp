#include "strata/mixture/label_names.hpp"

#include <cctype>
#include <fstream>
#include <sstream>
#include <vector>

#include <fmt/format.h>

#include "strata/core/error.hpp"
#include "strata/io/file_names.hpp"

namespace strata::mixture {

namespace {

std::string lower_extension(const std::filesystem::path& p) {
  std::string e = p.extension().string();
  for (char& c : e) c = char(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

std::optional<std::int64_t> label_value(const std::string& text) {
  if (text.empty()) return std::nullopt;
  std::size_t used = 0;
  try {
    const long long v = std::stoll(text, &used, 10);
    if (used == text.size()) return std::int64_t(v);
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

std::string trimmed(const std::string& s) {
  std::size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
  return s.substr(a, b - a);
}

// The fields of one CSV line: commas separate, "quoted" fields may hold commas and "" quotes.
std::vector<std::string> csv_fields(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
      fields.back() += '"';
      ++i;
    } else if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  for (std::string& f : fields) f = trimmed(f);
  return fields;
}

class TableReader {
 public:
  explicit TableReader(const std::filesystem::path& file) : file_(file) {}

  void add(std::int64_t label, const std::string& name, const std::string& where) {
    if (name.empty()) fail(where, fmt::format("label {} has no name", label));
    if (name.size() > kMaxLabelNameBytes)
      fail(where, fmt::format("the name of label {} is {} bytes long, more than {}", label, name.size(), kMaxLabelNameBytes));
    if (!names_.emplace(label, name).second) fail(where, fmt::format("label {} is named twice", label));
  }
  [[noreturn]] void fail(const std::string& where, const std::string& what) const {
    throw Error(fmt::format("{}: {}: {}", file_.string(), where, what));
  }
  LabelNames take() { return std::move(names_); }

 private:
  std::filesystem::path file_;
  LabelNames names_;
};

LabelNames read_json_table(const std::filesystem::path& file, std::istream& in) {
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object())
    throw Error(file.string() + ": expected a JSON object {\"<label>\": \"name\", ...}");
  TableReader table(file);
  for (const auto& [key, value] : j.items()) {
    const auto label = label_value(key);
    if (!label) table.fail("key \"" + key + "\"", "expected a label value (an integer)");
    if (!value.is_string()) table.fail("key \"" + key + "\"", "expected a name (a string)");
    table.add(*label, value.get<std::string>(), "key \"" + key + "\"");
  }
  return table.take();
}

LabelNames read_line_table(const std::filesystem::path& file, std::istream& in, bool csv) {
  TableReader table(file);
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string content = trimmed(line);
    if (content.empty() || content[0] == '#') continue;
    std::vector<std::string> fields;
    if (csv) {
      fields = csv_fields(content);
    } else {
      std::istringstream words(content);
      for (std::string w; words >> w;) fields.push_back(w);
    }
    const std::string where = fmt::format("line {}", number);
    const auto label = label_value(fields[0]);
    if (!label) {
      if (csv && number == 1) continue;  // a header
      table.fail(where, "expected a label value (an integer) first, got \"" + fields[0] + "\"");
    }
    table.add(*label, fields.size() > 1 ? fields[1] : std::string(), where);
  }
  return table.take();
}

}  // namespace

LabelNames load_label_names(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(file.string() + ": cannot open the label names table");
  const std::string ext = lower_extension(file);
  if (ext == io::kJsonExtension) return read_json_table(file, in);
  return read_line_table(file, in, ext == io::kCsvExtension);
}

nlohmann::json label_names_json(const LabelNames& names) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [label, name] : names) j[std::to_string(label)] = name;
  return j;
}

LabelNames label_names_from_json(const nlohmann::json& j, const std::string& file) {
  const std::string field = "metadata.label_names";
  if (!j.is_object()) throw FormatError(file, field, "expected an object {\"<label>\": \"name\"}");
  LabelNames names;
  for (const auto& [key, value] : j.items()) {
    const auto label = label_value(key);
    if (!label || std::to_string(*label) != key) throw FormatError(file, field, "key \"" + key + "\" is not a label value");
    if (!value.is_string() || value.get_ref<const std::string&>().empty())
      throw FormatError(file, field + "." + key, "expected a non-empty name");
    names.emplace(*label, value.get<std::string>());
  }
  return names;
}

std::optional<std::filesystem::path> sidecar_label_names(const std::filesystem::path& input) {
  std::filesystem::path base = input;
  if (lower_extension(base) == io::kGzSuffix) base.replace_extension();
  base += io::kTextExtension;
  std::error_code ec;
  if (std::filesystem::is_regular_file(base, ec)) return base;
  return std::nullopt;
}

}  // namespace strata::mixture

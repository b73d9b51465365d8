// A scanner of the XML that VTK writes: start and end tags with their attributes, the character
// data after a start tag, and the stop at <AppendedData>. It is our own rather than expat because
// VTK's appended data is raw bytes inside an element, which no XML parser accepts (VTK's own
// reader stops its parser there too), and the schema needs no more than tags and attributes: no
// namespaces, DTDs or entities beyond the five predefined ones.
#include <fmt/format.h>

#include "io/vtk/vtk_detail.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail::vtk {

namespace {

// A VTK ImageData file nests five deep (VTKFile, ImageData, Piece, PointData, DataArray) and
// holds a few elements per array; these bounds only stop hostile input.
constexpr std::size_t kMaxDepth = 32;
constexpr std::size_t kMaxElements = 100000;

bool is_name_char(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == ':' ||
         c == '-' || c == '.';
}
bool is_space(char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t'; }

// &lt; &gt; &amp; &quot; &apos; replaced; any other entity is kept as written.
std::string unescape(std::string_view value) {
  static constexpr std::pair<std::string_view, char> kEntities[] = {
      {"&lt;", '<'}, {"&gt;", '>'}, {"&amp;", '&'}, {"&quot;", '"'}, {"&apos;", '\''}};
  std::string out;
  for (std::size_t i = 0; i < value.size();) {
    bool replaced = false;
    for (const auto& [entity, c] : kEntities)
      if (value.substr(i, entity.size()) == entity) {
        out += c;
        i += entity.size();
        replaced = true;
        break;
      }
    if (!replaced) out += value[i++];
  }
  return out;
}

class Scanner {
 public:
  Scanner(std::string_view doc, const std::string& file) : doc_(doc), file_(file) {}

  XmlDocument scan() {
    XmlDocument result;
    while (true) {
      const std::size_t open = doc_.find('<', at_);
      if (open == std::string_view::npos) break;
      at_ = open + 1;
      if (starts("?")) skip_past("?>");
      else if (starts("!--")) skip_past("-->");
      else if (starts("!")) skip_past(">");
      else if (starts("/")) end_tag();
      else if (start_tag(result)) return result;
    }
    if (!stack_.empty()) fail(fmt::format("<{}> is never closed", stack_.back()));
    return result;
  }

 private:
  [[noreturn]] void fail(const std::string& problem) const {
    throw FormatError(file_, "XML", fmt::format("{} (near byte {})", problem, at_));
  }
  bool starts(std::string_view s) const { return doc_.substr(at_, s.size()) == s; }
  void skip_past(std::string_view end) {
    const std::size_t found = doc_.find(end, at_);
    if (found == std::string_view::npos) fail(fmt::format("unterminated markup (no \"{}\")", end));
    at_ = found + end.size();
  }
  void skip_space() {
    while (at_ < doc_.size() && is_space(doc_[at_])) ++at_;
  }
  std::string name() {
    const std::size_t start = at_;
    while (at_ < doc_.size() && is_name_char(doc_[at_])) ++at_;
    if (start == at_) fail("expected a name");
    return std::string(doc_.substr(start, at_ - start));
  }

  void end_tag() {
    ++at_;
    const std::string closed = name();
    skip_space();
    if (!starts(">")) fail(fmt::format("unterminated </{}>", closed));
    ++at_;
    if (stack_.empty() || stack_.back() != closed)
      fail(fmt::format("</{}> closes {}", closed, stack_.empty() ? "nothing" : "<" + stack_.back() + ">"));
    stack_.pop_back();
  }

  // Reads a start tag into `result`; true when it is <AppendedData> (the scan stops there).
  bool start_tag(XmlDocument& result) {
    if (result.elements.size() == kMaxElements) fail(fmt::format("more than {} elements", kMaxElements));
    XmlElement element;
    element.name = name();
    element.parent = stack_.empty() ? "" : stack_.back();
    bool closed = false;
    while (true) {
      skip_space();
      if (at_ >= doc_.size()) fail(fmt::format("unterminated <{}>", element.name));
      if (starts("/>")) {
        at_ += 2;
        closed = true;
        break;
      }
      if (starts(">")) {
        ++at_;
        break;
      }
      element.attributes.push_back(attribute(element.name));
    }
    if (!closed) {
      if (stack_.size() == kMaxDepth) fail(fmt::format("elements nested more than {} deep", kMaxDepth));
      stack_.push_back(element.name);
      element.text = doc_.substr(at_, std::min(doc_.find('<', at_), doc_.size()) - at_);
    }
    const bool appended = element.name == "AppendedData" && !closed;
    result.elements.push_back(std::move(element));
    if (appended) {
      skip_space();
      if (!starts("_")) fail("<AppendedData> does not start with '_'");
      result.appended = at_ + 1;
    }
    return appended;
  }

  std::pair<std::string, std::string> attribute(const std::string& element) {
    std::string key = name();
    skip_space();
    if (!starts("=")) fail(fmt::format("attribute {} of <{}> has no value", key, element));
    ++at_;
    skip_space();
    if (at_ >= doc_.size() || (doc_[at_] != '"' && doc_[at_] != '\''))
      fail(fmt::format("attribute {} of <{}> is not quoted", key, element));
    const char quote = doc_[at_++];
    const std::size_t end = doc_.find(quote, at_);
    if (end == std::string_view::npos) fail(fmt::format("attribute {} of <{}> is never closed", key, element));
    std::string value = unescape(doc_.substr(at_, end - at_));
    at_ = end + 1;
    return {std::move(key), std::move(value)};
  }

  std::string_view doc_;
  const std::string& file_;
  std::size_t at_ = 0;
  std::vector<std::string> stack_;
};

}  // namespace

const std::string* XmlElement::attribute(std::string_view key) const {
  for (const auto& [k, v] : attributes)
    if (k == key) return &v;
  return nullptr;
}

XmlDocument scan_xml(std::string_view doc, const std::string& file) { return Scanner(doc, file).scan(); }

}  // namespace strata::io::detail::vtk

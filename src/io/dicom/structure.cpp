// The element headers walked (PS3.5 7.1, 7.5): a tag (group, element: 2 x u16), then
//   explicit VR: VR (2 chars); OB OD OF OL OV OW SQ SV UC UN UR UT UV: 2 reserved bytes and a
//                u32 length; every other VR: a u16 length
//   implicit VR: a u32 length
//   items and delimiters (FFFE,E000/E00D/E0DD): a u32 length, no VR
// A length of FFFFFFFF (undefined: sequences, encapsulated pixel data) has no value to skip: the
// walk goes on into the items, which are element headers too; so does a defined-length SQ.
#include "io/dicom/structure.hpp"

#include <array>
#include <cstdint>
#include <fstream>
#include <string>
#include <string_view>

#include <fmt/format.h>

#include "io/dicom/header.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail::dicom {

namespace {

constexpr std::uint32_t kUndefinedLength = 0xFFFFFFFF;
constexpr std::string_view kImplicitLittleEndian = "1.2.840.10008.1.2";

class ElementWalker {
 public:
  explicit ElementWalker(const std::filesystem::path& file)
      : name_(file.string()), in_(file, std::ios::binary), size_(std::filesystem::file_size(file)) {}

  void run() {
    std::array<char, kMagicBytes> head{};
    if (!in_.read(head.data(), head.size()) || std::string_view(head.data() + kMagicOffset, 4) != "DICM")
      throw FormatError(name_, "DICOM header", "no \"DICM\" signature at byte 128 (not a DICOM Part 10 file)");
    bool implicit = false, data_set = false;
    while (position() < size_) {
      Element e = read_tag();
      if (e.group != 0x0002 && !data_set) {  // the meta group is explicit VR; the data set as it says
        data_set = true;
        implicit = transfer_syntax_ == kImplicitLittleEndian;
      }
      read_length(e, implicit);
      if (e.group == 0x0002 && e.element == 0x0010) transfer_syntax_ = read_text(e.length);
      if (e.group == 0x7FE0 && e.element == 0x0010) return;  // what follows is GDCM's to decode
      if (!e.enters) in_.seekg(std::streamoff(e.length), std::ios::cur);
    }
    if (!data_set) throw FormatError(name_, "DICOM header", "the file ends after its meta group: no data set");
  }

 private:
  struct Element {
    std::uint16_t group = 0, element = 0;
    std::uint32_t length = 0;
    bool enters = false;  // the walk continues with its content (items, nested elements)
  };

  std::uint64_t position() { return std::uint64_t(in_.tellg()); }

  template <std::size_t N>
  std::array<unsigned char, N> bytes(const Element& e) {
    std::array<unsigned char, N> b{};
    if (!in_.read(reinterpret_cast<char*>(b.data()), N))
      throw FormatError(name_, tag_text(e), "the file ends inside the element's header");
    return b;
  }
  static std::uint32_t u32(const unsigned char* b) {
    return std::uint32_t(b[0]) | std::uint32_t(b[1]) << 8 | std::uint32_t(b[2]) << 16 | std::uint32_t(b[3]) << 24;
  }
  static std::string tag_text(const Element& e) { return fmt::format("({:04X},{:04X})", e.group, e.element); }

  Element read_tag() {
    Element e;
    const auto tag = bytes<4>(e);
    e.group = std::uint16_t(tag[0] | tag[1] << 8);
    e.element = std::uint16_t(tag[2] | tag[3] << 8);
    return e;
  }

  void read_length(Element& e, bool implicit) {
    std::string vr;
    if (e.group == 0xFFFE || implicit) {
      e.length = u32(bytes<4>(e).data());
    } else {
      const auto v = bytes<2>(e);
      vr = {char(v[0]), char(v[1])};
      if (!(vr[0] >= 'A' && vr[0] <= 'Z' && vr[1] >= 'A' && vr[1] <= 'Z'))
        throw FormatError(name_, tag_text(e), "no valid value representation (explicit VR expected)");
      constexpr std::string_view kLongVrs = "OB OD OF OL OV OW SQ SV UC UN UR UT UV";
      if (kLongVrs.find(vr) != std::string_view::npos) {
        e.length = u32(bytes<6>(e).data() + 2);
      } else {
        const auto l = bytes<2>(e);
        e.length = std::uint32_t(l[0] | l[1] << 8);
      }
    }
    e.enters = e.group == 0xFFFE || e.length == kUndefinedLength || vr == "SQ";
    if (!e.enters && e.length > size_ - position())
      throw FormatError(name_, tag_text(e), fmt::format("its value of {} bytes runs past the end of the file", e.length));
  }

  std::string read_text(std::uint32_t length) {
    std::string text(length, '\0');
    in_.read(text.data(), length);
    in_.seekg(-std::streamoff(length), std::ios::cur);
    while (!text.empty() && (text.back() == '\0' || text.back() == ' ')) text.pop_back();
    return text;
  }

  std::string name_;
  std::ifstream in_;
  std::uint64_t size_;
  std::string transfer_syntax_;
};

}  // namespace

void check_element_structure(const std::filesystem::path& file) { ElementWalker(file).run(); }

}  // namespace strata::io::detail::dicom

#pragma once
// DicomData: a DICOM data set of explicit-VR little-endian elements built element by element and
// written as a Part 10 file (preamble, "DICM", file meta group). The DICOM tests make their files
// with it, and fuzz/fuzz_dicom.cpp makes well-formed files around fuzzed tag values.
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

namespace strata::test::io {

// A data set of explicit-VR little-endian elements, written as a Part 10 file.
class DicomData {
 public:
  DicomData& text(std::uint16_t group, std::uint16_t element, const char* vr, std::string value) {
    if (value.size() % 2) value += std::string(vr) == "UI" ? '\0' : ' ';
    return set(group, element, vr, value);
  }
  DicomData& us(std::uint16_t group, std::uint16_t element, std::uint16_t value) {
    return set(group, element, "US", std::string{char(value & 0xFF), char(value >> 8)});
  }
  DicomData& pixels(const std::vector<std::int16_t>& samples) {
    std::string bytes(samples.size() * 2, '\0');
    if (!samples.empty()) std::memcpy(bytes.data(), samples.data(), bytes.size());
    return set(0x7FE0, 0x0010, "OW", bytes);
  }
  DicomData& sequence(std::uint16_t group, std::uint16_t element, const std::vector<DicomData>& items) {
    std::string bytes;
    for (const DicomData& item : items) {
      const std::string nested = item.encoded();
      bytes += tag(0xFFFE, 0xE000) + u32(std::uint32_t(nested.size())) + nested;
    }
    return set(group, element, "SQ", bytes);
  }
  DicomData& erase(std::uint16_t group, std::uint16_t element) {
    elements_.erase(key(group, element));
    return *this;
  }

  std::string encoded() const {
    std::string out;
    for (const auto& [k, e] : elements_) {
      out += tag(std::uint16_t(k >> 16), std::uint16_t(k & 0xFFFF)) + e.vr;
      const bool long_length = e.vr == "OB" || e.vr == "OW" || e.vr == "SQ" || e.vr == "UN" || e.vr == "UT";
      if (long_length)
        out += std::string(2, '\0') + u32(std::uint32_t(e.value.size()));
      else
        out += std::string{char(e.value.size() & 0xFF), char(e.value.size() >> 8)};
      out += e.value;
    }
    return out;
  }

  void write(const std::filesystem::path& path, const std::string& transfer_syntax = "1.2.840.10008.1.2.1") const {
    DicomData meta;
    meta.set(0x0002, 0x0001, "OB", std::string{'\0', '\1'})
        .text(0x0002, 0x0002, "UI", "1.2.840.10008.5.1.4.1.1.2")
        .text(0x0002, 0x0003, "UI", "1.2.3.4.5.6.7")
        .text(0x0002, 0x0010, "UI", transfer_syntax);
    const std::string meta_bytes = meta.encoded();
    std::ofstream out(path, std::ios::binary);
    out << std::string(128, '\0') << "DICM" << tag(0x0002, 0x0000) << "UL" << std::string{4, 0}
        << u32(std::uint32_t(meta_bytes.size())) << meta_bytes << encoded();
  }

 private:
  struct Element {
    std::string vr, value;
  };
  static std::uint32_t key(std::uint16_t group, std::uint16_t element) { return std::uint32_t(group) << 16 | element; }
  static std::string u32(std::uint32_t v) { return {char(v), char(v >> 8), char(v >> 16), char(v >> 24)}; }
  static std::string tag(std::uint16_t group, std::uint16_t element) {
    return {char(group), char(group >> 8), char(element), char(element >> 8)};
  }
  DicomData& set(std::uint16_t group, std::uint16_t element, const char* vr, std::string value) {
    elements_[key(group, element)] = {vr, std::move(value)};
    return *this;
  }
  std::map<std::uint32_t, Element> elements_;
};

}  // namespace strata::test::io

#include "strata/quant/scheme.hpp"

#include <charconv>
#include <cmath>
#include <optional>

#include "strata/core/error.hpp"

namespace strata::quant {
namespace {

constexpr const char* kGrammar =
    "expected \"f32\" or \"<factors>,<core>\" with factors u8|u16|f32 and core f32 or "
    "b<8|12|16><lin|log|mu[<mu>]>[+], e.g. \"u16,b8log+\", \"u8,b8lin\", \"u16,b12log+\", \"u16,b8mu+\"";

[[noreturn]] void fail(std::string_view text, const std::string& problem) {
  throw Error("quantization scheme \"" + std::string(text) + "\": " + problem + "; " + kGrammar);
}

bool consume(std::string_view& s, std::string_view prefix) {
  if (!s.starts_with(prefix)) return false;
  s.remove_prefix(prefix.size());
  return true;
}

void parse_factors(std::string_view part, std::string_view text, QuantScheme& q) {
  if (part == "u8" || part == "u16") {
    q.factor_coding = FactorCoding::linear;
    q.factor_bits = part == "u8" ? 8 : 16;
  } else if (part == "f32") {
    q.factor_coding = FactorCoding::f32;
    q.factor_bits = 32;
  } else {
    fail(text, "unknown factor coding \"" + std::string(part) + "\"");
  }
}

// Leading decimal bits count of "8log+" etc.
int parse_core_bits(std::string_view& s, std::string_view text) {
  int bits = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), bits);
  if (ec != std::errc() || (bits != 8 && bits != 12 && bits != 16)) fail(text, "core bits must be 8, 12 or 16");
  s.remove_prefix(std::size_t(end - s.data()));
  return bits;
}

// Optional mu after "mu": a positive finite number, e.g. "255" or "1e3".
float parse_mu(std::string_view& s, std::string_view text) {
  if (s.empty() || s == "+") return QuantScheme::kDefaultMu;
  float mu = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), mu);
  if (ec != std::errc() || !std::isfinite(mu) || mu <= 0) fail(text, "mu must be a positive number");
  s.remove_prefix(std::size_t(end - s.data()));
  return mu;
}

void parse_core(std::string_view part, std::string_view text, QuantScheme& q) {
  q.hot_corner_float = false;
  if (part == "f32") {
    q.core_coding = CoreCoding::f32;
    q.core_bits = 32;
    return;
  }
  std::string_view s = part;
  if (!consume(s, "b")) fail(text, "unknown core coding \"" + std::string(part) + "\"");
  q.core_bits = parse_core_bits(s, text);
  if (consume(s, "lin")) {
    q.core_coding = CoreCoding::linear;
  } else if (consume(s, "log")) {
    q.core_coding = CoreCoding::log;
  } else if (consume(s, "mu")) {
    q.core_coding = CoreCoding::mulaw;
    q.mu = parse_mu(s, text);
  } else {
    fail(text, "core kind must be lin, log or mu");
  }
  if (consume(s, "+")) q.hot_corner_float = true;
  if (!s.empty()) fail(text, "unexpected \"" + std::string(s) + "\" after the core coding");
}

std::string format_mu(float mu) {
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, mu);
  return std::string(buf, end);
}

}  // namespace

QuantScheme QuantScheme::parse(std::string_view text) {
  QuantScheme q;
  if (text == "f32") {
    parse_factors("f32", text, q);
    parse_core("f32", text, q);
    return q;
  }
  const std::size_t comma = text.find(',');
  if (comma == std::string_view::npos) fail(text, "missing ','");
  parse_factors(text.substr(0, comma), text, q);
  parse_core(text.substr(comma + 1), text, q);
  return q;
}

std::string QuantScheme::to_string() const {
  if (factor_coding == FactorCoding::f32 && core_coding == CoreCoding::f32) return "f32";
  std::string s;
  if (factor_coding == FactorCoding::f32) {
    s += "f32";
  } else {
    s += 'u';
    s += std::to_string(factor_bits);
  }
  s += ',';
  if (core_coding == CoreCoding::f32) {
    s += "f32";
    return s;
  }
  s += 'b';
  s += std::to_string(core_bits);
  switch (core_coding) {
    case CoreCoding::linear: s += "lin"; break;
    case CoreCoding::log: s += "log"; break;
    case CoreCoding::mulaw:
      s += "mu";
      if (mu != kDefaultMu) s += format_mu(mu);
      break;
    case CoreCoding::f32: break;
  }
  if (hot_corner_float) s += '+';
  return s;
}

}  // namespace strata::quant

#include "strata/core/isa.hpp"

#include <atomic>
#include <cstdlib>
#include <mutex>
#include <string>

#include "strata/core/error.hpp"

namespace strata {
namespace {

bool cpu_has(Isa isa) {
#if STRATA_X86_64
  switch (isa) {
    case Isa::generic: return true;
    case Isa::sse42: return __builtin_cpu_supports("sse4.2");
    case Isa::avx2: return cpu_has(Isa::sse42) && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case Isa::avx512:
      return cpu_has(Isa::avx2) && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
             __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq");
  }
  return false;
#else
  return isa == Isa::generic;
#endif
}

std::string level_list() {
  std::string out;
  for (Isa isa : kAllIsas) out += (out.empty() ? "" : ", ") + std::string(isa_name(isa));
  return out;
}

// Why `isa` cannot be the limit, or "" when this CPU supports it.
std::string unsupported_reason(Isa isa) {
  if (isa_supported(isa)) return {};
  return "this CPU does not support " + std::string(isa_name(isa)) + " (it supports up to " +
         std::string(isa_name(machine_isa())) + ")";
}

Isa limit_from_environment() {
  const char* value = std::getenv("STRATA_ISA");
  if (!value || !*value) return machine_isa();
  const std::optional<Isa> isa = parse_isa(value);
  if (!isa)
    throw Error("STRATA_ISA: unknown instruction set '" + std::string(value) + "' (expected one of " + level_list() +
                ")");
  if (const std::string reason = unsupported_reason(*isa); !reason.empty()) throw Error("STRATA_ISA: " + reason);
  return *isa;
}

// The limit, or kUnset until the first active_isa()/set_isa_limit().
constexpr int kUnset = -1;
std::atomic<int> g_limit{kUnset};
std::once_flag g_environment_read;

void read_environment_once() {
  std::call_once(g_environment_read, [] {
    const Isa isa = limit_from_environment();
    int expected = kUnset;  // an explicit set_isa_limit() made before wins
    g_limit.compare_exchange_strong(expected, int(isa), std::memory_order_relaxed);
  });
}

}  // namespace

std::string_view isa_name(Isa isa) {
  switch (isa) {
    case Isa::generic: return "generic";
    case Isa::sse42: return "sse4.2";
    case Isa::avx2: return "avx2";
    case Isa::avx512: return "avx512";
  }
  return "?";
}

std::optional<Isa> parse_isa(std::string_view name) {
  if (name == "sse42") return Isa::sse42;
  for (Isa isa : kAllIsas)
    if (name == isa_name(isa)) return isa;
  return std::nullopt;
}

bool isa_supported(Isa isa) {
  static const std::array<bool, kAllIsas.size()> supported = [] {
    std::array<bool, kAllIsas.size()> s{};
    for (Isa isa : kAllIsas) s[std::size_t(isa)] = cpu_has(isa);
    return s;
  }();
  return std::size_t(isa) < supported.size() && supported[std::size_t(isa)];
}

Isa machine_isa() {
  Isa best = Isa::generic;
  for (Isa isa : kAllIsas)
    if (isa_supported(isa)) best = isa;
  return best;
}

Isa active_isa() {
  int limit = g_limit.load(std::memory_order_relaxed);
  if (limit == kUnset) {
    read_environment_once();
    limit = g_limit.load(std::memory_order_relaxed);
  }
  return Isa(limit);
}

void set_isa_limit(Isa isa) {
  if (const std::string reason = unsupported_reason(isa); !reason.empty()) throw ParameterError("isa", reason);
  g_limit.store(int(isa), std::memory_order_relaxed);
}

ScopedIsaLimit::ScopedIsaLimit(Isa isa) : previous_(active_isa()) { set_isa_limit(isa); }

ScopedIsaLimit::~ScopedIsaLimit() { g_limit.store(int(previous_), std::memory_order_relaxed); }

}  // namespace strata

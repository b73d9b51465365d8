#pragma once
/// @brief Internal invariants that must hold however the input looks.
///
/// STRATA_DEBUG_CHECK(condition, message) throws strata::Error("internal error: " + message)
/// when `condition` is false in a debug build (NDEBUG not defined); in a release build it
/// compiles to nothing and `message` is not evaluated. Use it where a broken invariant would
/// otherwise surface far away (a corrupt structure read back later), so the state fails where
/// it is made. Input errors are not invariants: check those always and throw a FormatError.
#include <string>

#include "strata/core/error.hpp"

namespace strata::detail {
[[noreturn]] inline void invariant_failed(const std::string& message) { throw Error("internal error: " + message); }
}  // namespace strata::detail

#ifndef NDEBUG
#define STRATA_DEBUG_CHECK(condition, message)                        \
  do {                                                                \
    if (!(condition)) ::strata::detail::invariant_failed((message)); \
  } while (false)
#else
#define STRATA_DEBUG_CHECK(condition, message) \
  do {                                         \
  } while (false)
#endif

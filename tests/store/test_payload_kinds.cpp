// The payload-kind traits table: complete, in code order, and the properties the container
// and the decoders read from it.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "strata/core/error.hpp"
#include "strata/store/container.hpp"
#include "strata/store/payload_kinds.hpp"

namespace strata::store {
namespace {

TEST(PayloadKinds, EveryCodeHasOneRowAndNoOtherCodeHasAny) {
  std::set<std::string> names;
  for (const PayloadKindTraits& t : kPayloadKinds) {
    ASSERT_EQ(find_payload_kind(std::uint8_t(t.kind)), &t);
    EXPECT_EQ(&payload_kind_traits(t.kind), &t);
    EXPECT_TRUE(names.insert(std::string(t.name)).second) << t.name;
    EXPECT_STREQ(payload_kind_name(t.kind), std::string(t.name).c_str());
  }
  EXPECT_EQ(find_payload_kind(0), nullptr);
  EXPECT_EQ(find_payload_kind(std::uint8_t(kPayloadKinds.size() + 1)), nullptr);
  EXPECT_EQ(find_payload_kind(255), nullptr);
  EXPECT_STREQ(payload_kind_name(PayloadKind(0)), "unknown");
  EXPECT_THROW(payload_kind_traits(PayloadKind(200)), Error);
  EXPECT_FALSE(needs_alignment(PayloadKind(200)));
}

TEST(PayloadKinds, TraitsSayWhatEachPayloadHolds) {
  // Only the fixed-layout quantized Tucker bricks are addressed in place.
  for (const PayloadKindTraits& t : kPayloadKinds)
    EXPECT_EQ(t.aligned, t.kind == PayloadKind::tucker || t.kind == PayloadKind::tucker_zstd) << t.name;
  EXPECT_EQ(payload_kind_traits(PayloadKind::constant).decoder, PayloadDecoder::none);
  EXPECT_TRUE(payload_kind_traits(PayloadKind::masked).has_mask);
  // A masked brick wraps a brick of its own codec family, never another mask or a global core.
  EXPECT_FALSE(payload_kind_traits(PayloadKind::masked).maskable);
  EXPECT_FALSE(payload_kind_traits(PayloadKind::global_core).maskable);
  EXPECT_TRUE(payload_kind_traits(PayloadKind::raw_packed).maskable);
  // Global cores carry no factors of their own: the volume's bases are their factors.
  EXPECT_TRUE(payload_kind_traits(PayloadKind::global_core_zstd).has_core);
  EXPECT_FALSE(payload_kind_traits(PayloadKind::global_core_zstd).has_factors);
  EXPECT_TRUE(payload_kind_traits(PayloadKind::tucker).has_factors);
  // Each kind's format version is no later than the one this build writes.
  for (const PayloadKindTraits& t : kPayloadKinds) EXPECT_LE(t.since_minor, kFormatVersionMinor) << t.name;
}

}  // namespace
}  // namespace strata::store

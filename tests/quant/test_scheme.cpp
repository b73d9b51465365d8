#include <gtest/gtest.h>

#include "strata/core/error.hpp"
#include "strata/quant/scheme.hpp"

namespace strata::quant {
namespace {

TEST(QuantScheme, ParsesThePapersVariants) {
  const QuantScheme a = QuantScheme::parse("u16,b8log+");
  EXPECT_EQ(a.factor_coding, FactorCoding::linear);
  EXPECT_EQ(a.factor_bits, 16);
  EXPECT_EQ(a.core_coding, CoreCoding::log);
  EXPECT_EQ(a.core_bits, 8);
  EXPECT_TRUE(a.hot_corner_float);

  const QuantScheme b = QuantScheme::parse("u16,b8log");
  EXPECT_FALSE(b.hot_corner_float);

  const QuantScheme c = QuantScheme::parse("u8,b8lin");
  EXPECT_EQ(c.factor_bits, 8);
  EXPECT_EQ(c.core_coding, CoreCoding::linear);

  const QuantScheme d = QuantScheme::parse("u16,b16lin");
  EXPECT_EQ(d.core_bits, 16);

  const QuantScheme e = QuantScheme::parse("u16,b12log+");
  EXPECT_EQ(e.core_bits, 12);
  EXPECT_TRUE(e.hot_corner_float);

  const QuantScheme f = QuantScheme::parse("f32");
  EXPECT_EQ(f.factor_coding, FactorCoding::f32);
  EXPECT_EQ(f.core_coding, CoreCoding::f32);
  EXPECT_EQ(f.factor_bits, 32);
  EXPECT_EQ(f.core_bits, 32);
  EXPECT_FALSE(f.hot_corner_float);
}

TEST(QuantScheme, ParsesMuLawWithDefaultOrExplicitMu) {
  const QuantScheme a = QuantScheme::parse("u16,b8mu+");
  EXPECT_EQ(a.core_coding, CoreCoding::mulaw);
  EXPECT_EQ(a.mu, QuantScheme::kDefaultMu);
  EXPECT_TRUE(a.hot_corner_float);
  const QuantScheme b = QuantScheme::parse("u8,b12mu1000");
  EXPECT_EQ(b.mu, 1000.0f);
  EXPECT_FALSE(b.hot_corner_float);
  EXPECT_EQ(QuantScheme::parse("u16,b16mu2.5+").mu, 2.5f);
}

TEST(QuantScheme, DefaultIsThePapersRecommendation) {
  EXPECT_EQ(QuantScheme{}, QuantScheme::parse("u16,b8log+"));  // paper §6.2.2: U:16 B:8log+
}

TEST(QuantScheme, ToStringRoundTrips) {
  for (const char* text : {"f32", "u16,b8log+", "u16,b8log", "u8,b8lin", "u16,b16lin", "u16,b12log+", "u16,b8mu+",
                           "u8,b12mu1000", "f32,b8log+", "u16,f32", "u8,b16lin+"}) {
    const QuantScheme q = QuantScheme::parse(text);
    EXPECT_EQ(q.to_string(), text);
    EXPECT_EQ(QuantScheme::parse(q.to_string()), q);
  }
  EXPECT_EQ(QuantScheme::parse("f32,f32").to_string(), "f32");
  EXPECT_EQ(QuantScheme::parse("u16,b8mu255").to_string(), "u16,b8mu");
}

TEST(QuantScheme, RejectsUnknownStringsWithAClearMessage) {
  for (const char* text : {"", "u16", "u12,b8log", "u16,b9log", "u16,b8foo", "u16,b8log++", "u16,f32+", "u16,b8mu-3",
                           "u16,b8mu0", "U16,B8LOG", "u16,b8log+,x", "u16,log", "u16,bxlog", "f16"}) {
    try {
      QuantScheme::parse(text);
      ADD_FAILURE() << "accepted \"" << text << "\"";
    } catch (const Error& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find(std::string("\"") + text + "\""), std::string::npos) << message;
      EXPECT_NE(message.find("u16,b8log+"), std::string::npos) << "message should show a valid example: " << message;
    }
  }
}

}  // namespace
}  // namespace strata::quant

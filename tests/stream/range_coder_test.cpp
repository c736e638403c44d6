// The adaptive binary range coder (stream/range_coder.h): what the stream's mesh refinements
// are coded with, so every symbol kind must round-trip exactly and damage must be seen.
#include "stream/range_coder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace meshmux {
namespace {

// One recorded symbol of a mixed stream.
struct Symbol {
  int kind;  // 0 bit, 1 direct, 2 uint, 3 tree
  uint32_t value;
  int bits;  // direct: how many; uint: modelled bits
};

std::vector<Symbol> mixed_symbols(uint32_t seed, size_t n) {
  std::mt19937 rng(seed);
  std::vector<Symbol> out;
  for (size_t i = 0; i < n; ++i) {
    Symbol s{int(rng() % 4), 0, 0};
    switch (s.kind) {
      case 0:
        s.value = rng() % 10 < 8 ? 0 : 1;
        break;  // skewed: the contexts must adapt
      case 1:
        s.bits = 1 + int(rng() % 32), s.value = uint32_t(rng()) >> (32 - s.bits);
        break;
      case 2: {  // small values mostly, every bit length sometimes (0 and 2^32 - 1 included)
        int length = rng() % 8 == 0 ? int(rng() % 33) : int(rng() % 6);
        s.value = length == 0 ? 0 : (uint32_t(rng()) | 0x80000000u) >> (32 - length);
        s.bits = 1 + int(rng() % 3);
        break;
      }
      default:
        s.value = rng() % 32;
        break;
    }
    out.push_back(s);
  }
  out.push_back({2, 0xFFFFFFFFu, 3});
  out.push_back({2, 0, 3});
  return out;
}

struct Contexts {
  uint16_t bit[2] = {kProbabilityHalf, kProbabilityHalf};
  UIntContext uint;
  TreeContext<5> tree;
};

std::vector<uint8_t> encode(const std::vector<Symbol>& symbols) {
  RangeEncoder out;
  Contexts c;
  for (const Symbol& s : symbols) {
    if (s.kind == 0) out.put_bit(c.bit[0], s.value);
    if (s.kind == 1) out.put_direct(s.value, s.bits);
    if (s.kind == 2) out.put_uint(c.uint, s.value, s.bits);
    if (s.kind == 3) out.put_tree(c.tree, s.value);
  }
  return out.finish();
}

// Decodes one symbol of the kind `s` describes.
uint32_t decode(RangeDecoder& in, Contexts& c, const Symbol& s) {
  if (s.kind == 0) return in.get_bit(c.bit[0]);
  if (s.kind == 1) return in.get_direct(s.bits);
  if (s.kind == 2) return in.get_uint(c.uint, s.bits);
  return in.get_tree(c.tree);
}

// Every kind of symbol decodes to what was coded, and the decoder ends exactly at the last byte.
TEST(RangeCoder, MixedSymbolsRoundTrip) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    std::vector<Symbol> symbols = mixed_symbols(seed, 20000);
    std::vector<uint8_t> bytes = encode(symbols);
    RangeDecoder in(bytes.data(), bytes.size());
    Contexts c;
    for (size_t i = 0; i < symbols.size(); ++i)
      ASSERT_EQ(decode(in, c, symbols[i]), symbols[i].value)
          << "seed " << seed << " symbol " << i << " kind " << symbols[i].kind;
    EXPECT_FALSE(in.failed());
    EXPECT_EQ(in.consumed(), bytes.size());
  }
}

// A skewed source costs what its entropy says, not a byte per symbol: the contexts adapt.
TEST(RangeCoder, SkewedBitsCostNearTheirEntropy) {
  std::mt19937 rng(11);
  RangeEncoder out;
  uint16_t p = kProbabilityHalf;
  const int n = 100000;
  for (int i = 0; i < n; ++i) out.put_bit(p, rng() % 100 < 5 ? 1 : 0);
  double entropy = -(0.05 * std::log2(0.05) + 0.95 * std::log2(0.95));  // 0.286 bits
  double bits = 8.0 * double(out.finish().size()) / n;
  EXPECT_LT(bits, entropy * 1.1) << bits << " bits per symbol";
  EXPECT_GT(bits, entropy * 0.9);
}

// The bits counted per decision (count_bits, for reports of where a stream's bits go) add up to
// the coded bytes' bits, less the flush: the mixed stream's contexts, split between two tallies
// (one for modelled symbols, one for direct bits), and none counted while switched off.
TEST(RangeCoder, CountedBitsAddUpToTheCodedBytes) {
  std::vector<Symbol> symbols = mixed_symbols(5, 20000);
  RangeEncoder out;
  Contexts c;
  double modelled = 0, direct = 0, off = 0;
  for (size_t i = 0; i < symbols.size(); ++i) {
    const Symbol& s = symbols[i];
    out.count_bits(i < 100 ? nullptr : s.kind == 1 ? &direct : &modelled);
    if (i < 100) {  // not counted: these bits go to the stream, not to a tally
      const double before = modelled + direct;
      out.put_direct(s.value & 1, 1);
      off += 1;
      EXPECT_EQ(modelled + direct, before);
      continue;
    }
    if (s.kind == 0) out.put_bit(c.bit[0], s.value);
    if (s.kind == 1) out.put_direct(s.value, s.bits);
    if (s.kind == 2) out.put_uint(c.uint, s.value, s.bits);
    if (s.kind == 3) out.put_tree(c.tree, s.value);
  }
  const double coded = 8.0 * double(out.finish().size());
  const double counted = modelled + direct + off;
  EXPECT_GT(direct, 0);
  EXPECT_GT(modelled, 0);
  EXPECT_LE(counted, coded + 16);  // the coder may round a few bits under the information
  EXPECT_GE(counted, coded - 8.0 * (kRangeCoderFlushBytes + 2)) << counted << " of " << coded;
}

// A stream cut short is noticed (reads past the end fail rather than invent bytes), and so is
// one with bytes left over.
TEST(RangeCoder, TruncationIsNoticed) {
  std::vector<Symbol> symbols = mixed_symbols(5, 5000);
  std::vector<uint8_t> bytes = encode(symbols);
  for (size_t keep : {size_t(0), size_t(3), bytes.size() / 2, bytes.size() - 1}) {
    RangeDecoder in(bytes.data(), keep);
    Contexts c;
    for (const Symbol& s : symbols) decode(in, c, s);
    EXPECT_TRUE(in.failed()) << "kept " << keep << " of " << bytes.size();
  }
  std::vector<uint8_t> longer = bytes;
  longer.push_back(7);
  RangeDecoder in(longer.data(), longer.size());
  Contexts c;
  for (const Symbol& s : symbols) decode(in, c, s);
  EXPECT_NE(in.consumed(), longer.size());
}

// Random bytes decode to something (the decoder never reads out of bounds or loops), and a
// length past 32 bits is flagged.
TEST(RangeCoder, GarbageDecodesBoundedly) {
  std::mt19937 rng(3);
  int flagged = 0;
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<uint8_t> bytes(size_t(rng() % 64));
    for (auto& b : bytes) b = uint8_t(rng());
    RangeDecoder in(bytes.data(), bytes.size());
    UIntContext c;
    for (int i = 0; i < 100; ++i) in.get_uint(c, 3);
    flagged += in.failed();
    EXPECT_LE(in.consumed(), bytes.size());
  }
  EXPECT_GT(flagged, 100);
}

}  // namespace
}  // namespace meshmux

// Adaptive binary range coder (stream/range_coder.h): arithmetic coding as a range coder
// (G. N. N. Martin, "Range encoding", 1979) with carry propagation through a cached byte, and
// binary contexts whose probability moves by a fixed shift, as LZMA's coder does both.
#include "stream/range_coder.h"

#include <array>
#include <cmath>

namespace meshmux {

namespace {}  // namespace

UIntContext::UIntContext() {
  for (uint16_t& p : length) p = kProbabilityHalf;
  for (auto& m : mantissa)
    for (uint16_t& p : m) p = kProbabilityHalf;
}

void RangeEncoder::shift_low() {
  if (uint32_t(low_) < 0xFF000000u || (low_ >> 32) != 0) {
    const uint8_t carry = uint8_t(low_ >> 32);
    uint8_t byte = cache_;
    do {
      out_.push_back(uint8_t(byte + carry));
      byte = 0xFF;
    } while (--cache_size_ != 0);
    cache_ = uint8_t(uint32_t(low_) >> 24);
  }
  ++cache_size_;
  low_ = (low_ & 0x00FFFFFFu) << 8;
}

namespace {
// -log2(p / 2^kProbabilityBits) for every probability p a context can hold.
const std::array<double, (1u << kProbabilityBits) + 1>& bit_costs() {
  static const auto table = [] {
    std::array<double, (1u << kProbabilityBits) + 1> t{};
    for (size_t p = 1; p < t.size(); ++p)
      t[p] = -std::log2(double(p) / double(1u << kProbabilityBits));
    t[0] = double(kProbabilityBits);
    return t;
  }();
  return table;
}
}  // namespace

void RangeEncoder::put_bit(uint16_t& probability, uint32_t bit) {
  if (tally_)
    *tally_ += bit_costs()[bit == 0 ? probability : (1u << kProbabilityBits) - probability];
  const uint32_t bound = (range_ >> kProbabilityBits) * probability;
  if (bit == 0) {
    range_ = bound;
    probability = uint16_t(probability + ((kProbabilityOne - probability) >> kAdaptShift));
  } else {
    low_ += bound;
    range_ -= bound;
    probability = uint16_t(probability - (probability >> kAdaptShift));
  }
  while (range_ < kRangeTop) {
    range_ <<= 8;
    shift_low();
  }
}

void RangeEncoder::put_direct(uint32_t value, int bits) {
  if (tally_) *tally_ += bits;
  // In pieces of at most kDirectPiece bits, most significant first: the range is cut into
  // 2^k equal slices (its remainder left unused) and the value's slice taken.
  while (bits > 0) {
    const int k = bits < kDirectPiece ? bits : kDirectPiece;
    bits -= k;
    range_ >>= k;
    low_ += uint64_t((value >> bits) & ((1u << k) - 1)) * range_;
    while (range_ < kRangeTop) {
      range_ <<= 8;
      shift_low();
    }
  }
}

void RangeEncoder::put_uint(UIntContext& c, uint32_t value, int most) {
  const int n = bit_length(value);
  // The length: below kLengthEscape through a 4-level tree; from it, the escape symbol and
  // n - kLengthEscape in 5 direct bits (a few dozen times per mesh: vertex indices).
  const uint32_t symbol = uint32_t(n < kLengthEscape ? n : kLengthEscape);
  uint32_t node = 1;
  for (int i = 3; i >= 0; --i) {
    uint32_t bit = (symbol >> i) & 1;
    put_bit(c.length[node], bit);
    node = node << 1 | bit;
  }
  if (n >= kLengthEscape) put_direct(uint32_t(n - kLengthEscape), 5);
  if (n < 2) return;
  // The n - 1 bits below the leading one: the top three through contexts, the rest direct.
  const int below = n - 1, modelled = below < most ? below : most;
  node = 1;
  for (int i = 0; i < modelled; ++i) {
    uint32_t bit = (value >> (below - 1 - i)) & 1;
    put_bit(c.mantissa[n][node], bit);
    node = node << 1 | bit;
  }
  if (below > modelled) put_direct(value & ((1u << (below - modelled)) - 1), below - modelled);
}

std::vector<uint8_t> RangeEncoder::finish() {
  for (int i = 0; i < kRangeCoderFlushBytes; ++i) shift_low();
  return std::move(out_);
}

RangeDecoder::RangeDecoder(const uint8_t* data, size_t size)
    : begin_(data), at_(data), end_(data + size) {
  for (int i = 0; i < kRangeCoderFlushBytes; ++i) code_ = code_ << 8 | next_byte();
}

uint32_t RangeDecoder::get_direct(int bits) {
  uint32_t value = 0;
  while (bits > 0) {
    const int k = bits < kDirectPiece ? bits : kDirectPiece;
    bits -= k;
    range_ >>= k;
    uint32_t slice = code_ / range_;
    if (slice >> k) {  // past the last slice: only a damaged stream gets here
      slice = (1u << k) - 1;
      failed_ = true;
    }
    code_ -= slice * range_;
    value = value << k | slice;
    while (range_ < kRangeTop) {
      range_ <<= 8;
      code_ = code_ << 8 | next_byte();
    }
  }
  return value;
}

uint32_t RangeDecoder::get_uint(UIntContext& c, int most) {
  uint32_t node = 1;
  for (int i = 0; i < 4; ++i) node = node << 1 | get_bit(c.length[node]);
  int n = int(node - 16);
  if (n == kLengthEscape) n += int(get_direct(5));
  if (n > 32) {
    failed_ = true;  // no uint32 is that long
    return 0;
  }
  if (n < 2) return uint32_t(n);
  const int below = n - 1, modelled = below < most ? below : most;
  node = 1;
  for (int i = 0; i < modelled; ++i) node = node << 1 | get_bit(c.mantissa[n][node]);
  // node holds the leading one and the modelled bits; the direct ones follow.
  uint32_t value = node << (below - modelled);
  if (below > modelled) value |= get_direct(below - modelled);
  return value;
}

}  // namespace meshmux

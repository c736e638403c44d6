// An adaptive binary range coder: the entropy coder of the stream's mesh refinements
// (stream/vsplit.h). Each binary decision is coded with a probability that adapts to what
// its context has seen (11-bit probabilities, moved 1/16 of the way per decision: the
// carry-propagating "range coder" of Martin 1979 as LZMA uses it); integers are coded as their
// bit length through a binary tree of such contexts, up to three bits below the leading one
// through contexts of their own, and the rest as equiprobable bits.
//
// Why not deflate (package format ≤ 12): deflate codes bytes with one Huffman table per block,
// so a residual costs a whole number of bits and nothing it has seen about its neighbourhood
// helps; here each field has its own contexts (the position residual's by the size of the new
// vertex's ring). With format 13's prediction changes the shared models' mesh streams shrank
// 5–16% (bench/stream_bytes.sh).
//
// The web client runs this decoder compiled to WebAssembly (stream/decoder_api.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace meshmux {

constexpr int kProbabilityBits = 11;  // probabilities are p(0)·2^11
constexpr uint16_t kProbabilityHalf = 1 << (kProbabilityBits - 1);
constexpr uint32_t kProbabilityOne = 1u << kProbabilityBits;
constexpr uint32_t kRangeTop = 1u << 24;  // the range is renormalized to stay at or above this
constexpr int kAdaptShift = 4;            // moved 1/16 of the way per decision
constexpr int kRangeCoderFlushBytes = 5;  // the encoder's tail; the decoder's head
constexpr int kDirectPiece = 16;
constexpr int kLengthEscape = 15;  // bit lengths from here on are sent as 5 direct bits          //
                                   // equiprobable bits are coded this many at a time at most

// Contexts for integers (RangeEncoder::put_uint): a 4-level binary tree over the bit length
// (0..14, 15 escaping to 5 direct bits for 15..32) and, per bit length, a 3-level tree over the
// three bits below the leading one.
struct UIntContext {
  uint16_t length[16];
  uint16_t mantissa[33][8];
  UIntContext();
};
// Contexts for a value below 2^bits (RangeEncoder::put_tree), bits ≤ 8.
template <int Bits>
struct TreeContext {
  uint16_t node[1 << Bits];
  TreeContext() {
    for (uint16_t& p : node) p = kProbabilityHalf;
  }
};

class RangeEncoder {
 public:
  void put_bit(uint16_t& probability, uint32_t bit);
  // `bits` (≤ 32) equiprobable bits, most significant first, kDirectPiece at a time.
  void put_direct(uint32_t value, int bits);
  // `value` through `c`: its bit length, then up to `modelled` (≤ 3) bits below the leading
  // one through contexts, the rest direct.
  void put_uint(UIntContext& c, uint32_t value, int modelled = 3);
  template <int Bits>
  void put_tree(TreeContext<Bits>& c, uint32_t value) {
    uint32_t node = 1;
    for (int i = Bits - 1; i >= 0; --i) {
      uint32_t bit = (value >> i) & 1;
      put_bit(c.node[node], bit);
      node = node << 1 | bit;
    }
  }
  // Ends the stream (kRangeCoderFlushBytes more bytes) and returns it; the encoder is spent.
  std::vector<uint8_t> finish();
  // From now on, adds the information each coded decision carries (-log2 of its probability;
  // a direct bit: 1) to *bits (null: stop counting). For reports of where a stream's bits go;
  // the output does not change. O(1) per decision.
  void count_bits(double* bits) { tally_ = bits; }

 private:
  void shift_low();
  double* tally_ = nullptr;
  uint64_t low_ = 0;
  uint32_t range_ = 0xFFFFFFFFu;
  uint8_t cache_ = 0;
  uint64_t cache_size_ = 1;
  std::vector<uint8_t> out_;
};

// Decodes what RangeEncoder wrote. Reading past the end is an error (failed()), not undefined:
// missing bytes read as zero and set the flag. A whole stream is consumed exactly when
// consumed() == its size.
class RangeDecoder {
 public:
  RangeDecoder(const uint8_t* data, size_t size);
  // Inline: the decoder's hot path (every decision of every split goes through it).
  uint32_t get_bit(uint16_t& probability) {
    const uint32_t bound = (range_ >> kProbabilityBits) * probability;
    uint32_t bit;
    if (code_ < bound) {
      range_ = bound;
      probability = uint16_t(probability + ((kProbabilityOne - probability) >> kAdaptShift));
      bit = 0;
    } else {
      code_ -= bound;
      range_ -= bound;
      probability = uint16_t(probability - (probability >> kAdaptShift));
      bit = 1;
    }
    while (range_ < kRangeTop) {
      range_ <<= 8;
      code_ = code_ << 8 | next_byte();
    }
    return bit;
  }
  uint32_t get_direct(int bits);
  uint32_t get_uint(UIntContext& c, int modelled = 3);
  template <int Bits>
  uint32_t get_tree(TreeContext<Bits>& c) {
    uint32_t node = 1;
    for (int i = 0; i < Bits; ++i) node = node << 1 | get_bit(c.node[node]);
    return node - (1u << Bits);
  }
  bool failed() const { return failed_; }
  size_t consumed() const { return size_t(at_ - begin_); }

 private:
  uint8_t next_byte() {
    if (at_ == end_) {
      failed_ = true;
      return 0;
    }
    return *at_++;
  }
  const uint8_t *begin_, *at_, *end_;
  uint32_t range_ = 0xFFFFFFFFu, code_ = 0;
  bool failed_ = false;
};

// The number of bits of v (0 for 0): the bucket put_uint codes first.
inline int bit_length(uint32_t v) {
  int n = 0;
  while (v) ++n, v >>= 1;
  return n;
}

}  // namespace meshmux

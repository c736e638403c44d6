// Encoded images decoded in order, ahead of a consumer that takes them one at a time (the
// multiplexer uploading a package's texture levels to its renderer): a thread of its own decodes
// the next ones while the consumer works, and a consumer waiting for one decodes a later one
// itself meanwhile, so both cores decode while uploads wait for the slowest map. Consecutive KTX2
// images are claimed together (up to kKtx2Batch, within the window and the budget by their
// headers' sides) and transcoded by one child process (image/ktx2_transcode.h): the transcoder's
// start (node, its WebAssembly) cost ~0.2 s an image, 2 s of a helmet's 12 maps.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "core/parallel.h"
#include "core/status.h"
#include "scene/scene.h"

namespace meshmux {

// One image to decode: a name for errors, its encoded bytes (borrowed: they must outlive the
// DecodeAhead) and its MIME type.
struct EncodedItem {
  std::string name;
  const std::vector<uint8_t>* encoded = nullptr;
  std::string mime_type;
};

class DecodeAhead {
 public:
  // Starts decoding items[0] on a thread of its own. A further image is started only while
  // fewer than `window` (≥ 1) are decoded or being decoded and not yet taken, and the decoded
  // ones waiting hold under `budget` bytes of texels: the texels held are at most the budget
  // plus one image per thread (small maps run far ahead, large ones one or two).
  explicit DecodeAhead(std::vector<EncodedItem> items, size_t window = 64,
                       size_t budget = size_t(64) << 20);
  // Stops the decoding thread after the image it is on (untaken images are dropped).
  ~DecodeAhead();
  DecodeAhead(const DecodeAhead&) = delete;
  DecodeAhead& operator=(const DecodeAhead&) = delete;

  size_t size() const { return items_.size(); }
  // Image k decoded (decode_image's result: an error names the item), moved out. Takes images in
  // order (k = 0, 1, ...: one call each); while image k is still being decoded, the caller
  // decodes the first one not yet started, if the window allows. The same images whatever the
  // thread count and timing.
  Result<Image> take(size_t k);

 private:
  // The first image not yet started, claimed under the lock; nullopt when none or the window is
  // full.
  std::optional<size_t> claim_locked();
  // With item k just claimed: when it is KTX2, the KTX2 items right after it claimed too (see
  // above); returns the end of the claimed run (k + 1 for one).
  size_t claim_more_ktx2_locked(size_t k);
  void decode(size_t k);                       // decodes item k into its slot and marks it done
  void decode_ktx2(size_t begin, size_t end);  // items [begin, end), KTX2, in one transcoder run
  void decode_claimed(size_t k, size_t end);   // decode or decode_ktx2, as claimed
  static constexpr size_t kKtx2Batch = 16;
  void worker();

  std::vector<EncodedItem> items_;
  size_t window_;
  size_t budget_;
  size_t held_ = 0;  // bytes of texels decoded and not yet taken
  std::vector<Image> images_;
  std::vector<Status> status_;
  std::vector<uint8_t> done_;
  size_t started_ = 0;  // images claimed by a thread
  size_t taken_ = 0;    // images handed to the consumer
  bool stop_ = false;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::optional<Background> thread_;  // last: joined first on destruction
};

}  // namespace meshmux

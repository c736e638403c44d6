#include "multiplex/decode_ahead.h"

#include <algorithm>
#include <exception>
#include <utility>

#include "image/decode.h"
#include "image/ktx2_transcode.h"

namespace meshmux {

DecodeAhead::DecodeAhead(std::vector<EncodedItem> items, size_t window, size_t budget)
    : items_(std::move(items)),
      window_(std::max<size_t>(1, window)),
      budget_(budget),
      images_(items_.size()),
      status_(items_.size(), Status::ok()),
      done_(items_.size(), 0) {
  if (!items_.empty()) thread_.emplace([this] { worker(); });
}

DecodeAhead::~DecodeAhead() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  thread_.reset();
}

std::optional<size_t> DecodeAhead::claim_locked() {
  if (stop_ || started_ >= items_.size() || started_ >= taken_ + window_ || held_ >= budget_)
    return std::nullopt;
  return started_++;
}

namespace {

bool is_ktx2(const EncodedItem& item) { return item.mime_type == "image/ktx2" && item.encoded; }

// Texels' bytes a KTX2 item decodes to (its header's sides), or 0 where the header says nothing.
size_t ktx2_rgba_bytes(const EncodedItem& item) {
  auto h = read_ktx2_header(*item.encoded);
  return h.ok() ? size_t(h->width) * size_t(h->height) * 4 : 0;
}

}  // namespace

size_t DecodeAhead::claim_more_ktx2_locked(size_t k) {
  size_t end = k + 1;
  if (!is_ktx2(items_[k])) return end;
  size_t bytes = ktx2_rgba_bytes(items_[k]);
  while (end < items_.size() && end == started_ && end < taken_ + window_ && end - k < kKtx2Batch &&
         is_ktx2(items_[end])) {
    const size_t more = ktx2_rgba_bytes(items_[end]);
    if (held_ + bytes + more > budget_) break;
    bytes += more;
    ++started_, ++end;
  }
  return end;
}

void DecodeAhead::decode_ktx2(size_t begin, size_t end) {
  std::vector<Image> images(end - begin);
  std::vector<Image*> pointers;
  for (size_t k = begin; k < end; ++k) {
    Image& image = images[k - begin];
    image.name = items_[k].name;
    image.encoded = *items_[k].encoded;
    image.mime_type = items_[k].mime_type;
    pointers.push_back(&image);
  }
  // One child for the batch; a throw (out of memory) fails them all, each by name.
  std::vector<Status> status(images.size(), Status::ok());
  try {
    Ktx2Transcoded t = transcode_ktx2_images(pointers);
    for (size_t i = 0; i < images.size(); ++i) status[i] = t.images[i].status;
  } catch (const std::exception& e) {
    for (size_t i = 0; i < images.size(); ++i)
      status[i] =
          Status::error("multiplex: " + images[i].name + ": " + e.what(), ErrorKind::kInternal);
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (size_t k = begin; k < end; ++k) {
      Image& image = images[k - begin];
      if (!status[k - begin]) image.rgba.clear();
      image.encoded.clear();
      image.encoded.shrink_to_fit();
      held_ += image.rgba.size();
      images_[k] = std::move(image);
      status_[k] = std::move(status[k - begin]);
      done_[k] = 1;
    }
  }
  changed_.notify_all();
}

void DecodeAhead::decode_claimed(size_t k, size_t end) {
  if (end > k + 1)
    decode_ktx2(k, end);
  else
    decode(k);
}

void DecodeAhead::decode(size_t k) {
  Image image;
  image.name = items_[k].name;
  if (items_[k].encoded) image.encoded = *items_[k].encoded;
  image.mime_type = items_[k].mime_type;
  // A throw (out of memory) becomes this image's error: whoever waits for it must wake.
  Status s = Status::ok();
  try {
    s = decode_image(image);
  } catch (const std::exception& e) {
    image.rgba.clear();
    s = Status::error("multiplex: " + items_[k].name + ": " + e.what(), ErrorKind::kInternal);
  }
  image.encoded.clear();
  image.encoded.shrink_to_fit();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    held_ += image.rgba.size();
    images_[k] = std::move(image);
    status_[k] = std::move(s);
    done_[k] = 1;
  }
  changed_.notify_all();
}

void DecodeAhead::worker() {
  for (;;) {
    std::optional<size_t> k;
    size_t end = 0;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock,
                    [&] { return stop_ || started_ >= items_.size() || (k = claim_locked()); });
      if (!k) return;
      end = claim_more_ktx2_locked(*k);
    }
    decode_claimed(*k, end);
  }
}

Result<Image> DecodeAhead::take(size_t k) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (k != taken_ || k >= items_.size())
    return Status::error("multiplex: image " + std::to_string(k) + " taken out of order",
                         ErrorKind::kInternal);
  while (!done_[k]) {
    if (std::optional<size_t> j = claim_locked()) {  // decode a later one (or this one) here
      const size_t end = claim_more_ktx2_locked(*j);
      lock.unlock();
      decode_claimed(*j, end);
      lock.lock();
      continue;
    }
    changed_.wait(lock, [&] { return bool(done_[k]); });
  }
  ++taken_;
  Image image = std::move(images_[k]);
  held_ -= image.rgba.size();
  Status s = std::move(status_[k]);
  lock.unlock();
  changed_.notify_all();  // the window moved on
  if (!s) return s;
  return image;
}

}  // namespace meshmux

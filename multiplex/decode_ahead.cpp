#include "multiplex/decode_ahead.h"

#include <algorithm>
#include <exception>
#include <utility>

#include "image/decode.h"

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
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock,
                    [&] { return stop_ || started_ >= items_.size() || (k = claim_locked()); });
      if (!k) return;
    }
    decode(*k);
  }
}

Result<Image> DecodeAhead::take(size_t k) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (k != taken_ || k >= items_.size())
    return Status::error("multiplex: image " + std::to_string(k) + " taken out of order",
                         ErrorKind::kInternal);
  while (!done_[k]) {
    if (std::optional<size_t> j = claim_locked()) {  // decode a later one (or this one) here
      lock.unlock();
      decode(*j);
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

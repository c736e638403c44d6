// Errors as values. A Status is either ok or carries one human-readable message that names
// the stage, the file and the element, e.g. "gltf: scene.glb: mesh 3 primitive 1: accessor 7
// out of bounds". Result<T> is a T or a failed Status. Warnings (problems that do not stop the
// work) go to a Warnings sink instead.
#pragma once

#include <cassert>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace meshmux {

// What kind of failure, so the CLI can map it to an exit code.
enum class ErrorKind {
  kNone = 0,
  kInput,        // the input is missing, unreadable, malformed or unsupported
  kOutput,       // an output could not be written
  kInternal,     // a bug or an unexpected library failure
  kUnavailable,  // the machine lacks something optional (offscreen OpenGL/EGL): the only
                 // failure a conversion may degrade to a warning
};

class [[nodiscard]] Status {
 public:
  Status() = default;
  static Status ok() { return Status(); }
  // Every error names its kind: there is no default.
  static Status error(std::string message, ErrorKind kind) {
    Status s;
    s.kind_ = kind;
    s.message_ = std::move(message);
    return s;
  }
  bool is_ok() const { return kind_ == ErrorKind::kNone; }
  explicit operator bool() const { return is_ok(); }
  ErrorKind kind() const { return kind_; }
  const std::string& message() const { return message_; }
  // Returns a copy whose message is "prefix: <message>" (adds context on the way up).
  Status with_prefix(const std::string& prefix) const {
    if (is_ok()) return *this;
    return error(prefix + ": " + message_, kind_);
  }

 private:
  ErrorKind kind_ = ErrorKind::kNone;
  std::string message_;
};

template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : value_(std::move(value)) {}         // NOLINT: implicit by design
  Result(Status status) : status_(std::move(status)) {  // NOLINT: implicit by design
    assert(!status_.is_ok() && "Result built from an ok Status carries no value");
    if (status_.is_ok()) status_ = Status::error("internal: empty result", ErrorKind::kInternal);
  }
  bool ok() const { return value_.has_value(); }
  explicit operator bool() const { return ok(); }
  const Status& status() const { return status_; }
  T& value() { return *value_; }
  const T& value() const { return *value_; }
  T* operator->() { return &*value_; }
  const T* operator->() const { return &*value_; }
  T& operator*() { return *value_; }
  const T& operator*() const { return *value_; }
  T take() { return std::move(*value_); }

 private:
  std::optional<T> value_;
  Status status_;
};

// Collects warnings: problems the work survived (a missing texture, a skipped <lines> element).
// Each warning is one line naming the stage, file and element, like an error message.
class Warnings {
 public:
  void add(std::string message) { items_.push_back(std::move(message)); }
  const std::vector<std::string>& items() const { return items_; }
  bool empty() const { return items_.empty(); }

 private:
  std::vector<std::string> items_;
};

// Adds to a sink that may be null.
inline void warn(Warnings* sink, std::string message) {
  if (sink) sink->add(std::move(message));
}

}  // namespace meshmux

// Byte streams of saved accumulation state (checkpoints): values in the machine's byte order,
// grouped in blocks so that each owner (the film, its members, the render pass) reads back
// exactly what it wrote and refuses anything else with std::invalid_argument.
#pragma once

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace penumbra {

/// Appends values to a state. A block is a 4-character tag, a format version and the length of
/// what follows (beginBlock/endBlock), so a reader can check it and know where the next begins.
class StateWriter {
 public:
  explicit StateWriter(std::vector<uint8_t>& out) : out_(out) {}

  template <typename T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* bytes = reinterpret_cast<const uint8_t*>(&value);
    out_.insert(out_.end(), bytes, bytes + sizeof(T));
  }
  template <typename T>
  void putArray(const std::vector<T>& values) {
    static_assert(std::is_trivially_copyable_v<T>);
    put(uint64_t(values.size()));
    const auto* bytes = reinterpret_cast<const uint8_t*>(values.data());
    out_.insert(out_.end(), bytes, bytes + values.size() * sizeof(T));
  }
  void putString(const std::string& text) {
    put(uint64_t(text.size()));
    out_.insert(out_.end(), text.begin(), text.end());
  }
  /// Starts a block; returns what endBlock needs.
  size_t beginBlock(const char (&tag)[5], uint32_t version) {
    out_.insert(out_.end(), tag, tag + 4);
    put(version);
    put(uint64_t(0));  // the length, filled in by endBlock
    return out_.size();
  }
  void endBlock(size_t start) {
    const uint64_t length = out_.size() - start;
    std::memcpy(out_.data() + start - sizeof(length), &length, sizeof(length));
  }

 private:
  std::vector<uint8_t>& out_;
};

/// Reads what a StateWriter wrote from [cursor, end), advancing cursor; throws
/// std::invalid_argument (naming `what`) for a state that ends early or is of another kind.
class StateReader {
 public:
  StateReader(const uint8_t*& cursor, const uint8_t* end, std::string what)
      : cursor_(cursor), end_(end), what_(std::move(what)) {}

  template <typename T>
  T get() {
    static_assert(std::is_trivially_copyable_v<T>);
    T value;
    std::memcpy(&value, take(sizeof(T)), sizeof(T));
    return value;
  }
  template <typename T>
  std::vector<T> getArray(size_t expectedSize) {
    if (get<uint64_t>() != expectedSize) fail("holds arrays of another size");
    std::vector<T> values(expectedSize);
    if (expectedSize > 0)
      std::memcpy(values.data(), take(expectedSize * sizeof(T)), expectedSize * sizeof(T));
    return values;
  }
  std::string getString() {
    const uint64_t size = get<uint64_t>();
    if (size > uint64_t(end_ - cursor_)) fail("is truncated");
    const auto* bytes = reinterpret_cast<const char*>(take(size_t(size)));
    return std::string(bytes, size_t(size));
  }
  /// Reads a block's header; throws unless it is `tag` at `version` and wholly present. The
  /// block ends at blockEnd().
  void beginBlock(const char (&tag)[5], uint32_t version) {
    if (std::memcmp(take(4), tag, 4) != 0) fail("is not a " + std::string(tag) + " block");
    if (get<uint32_t>() != version)
      fail("has another format version than " + std::to_string(version));
    const uint64_t length = get<uint64_t>();
    if (length > uint64_t(end_ - cursor_)) fail("is truncated");
    blockEnd_ = cursor_ + length;
  }
  /// Throws unless the block was read to its end.
  void endBlock() const {
    if (cursor_ != blockEnd_) fail("has a block of another layout");
  }
  [[noreturn]] void fail(const std::string& problem) const {
    throw std::invalid_argument(what_ + " " + problem);
  }

 private:
  const uint8_t* take(size_t size) {
    if (size > size_t(end_ - cursor_)) fail("is truncated");
    const uint8_t* start = cursor_;
    cursor_ += size;
    return start;
  }

  const uint8_t*& cursor_;
  const uint8_t* end_;
  std::string what_;
  const uint8_t* blockEnd_ = nullptr;
};

}  // namespace penumbra

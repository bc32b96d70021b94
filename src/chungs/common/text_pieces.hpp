// Text built in pieces of a fixed size instead of one growing string. The heap is never trimmed
// (heap.hpp), so a file written from one string that grows with the run (a checkpoint's run state
// and keyframe list: ~10 MB after a 10 km drive) needed a larger free block at every checkpoint than
// any the last one left, and host memory rose by tens of MB at each checkpoint (bench/README.md).
// Pieces of one size fit the holes that earlier pieces left.
#pragma once
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace chungs {

class TextPieces {
 public:
  static constexpr size_t kPiece = size_t(256) << 10;

  void append(std::string_view text);
  TextPieces& operator+=(std::string_view text) {
    append(text);
    return *this;
  }
  TextPieces& operator+=(char c) {
    append(std::string_view(&c, 1));
    return *this;
  }
  // Appends another's text (its pieces move over, the last one's space is not reused).
  void splice(TextPieces&& other);
  size_t size() const;
  const std::vector<std::string>& pieces() const { return pieces_; }
  std::string str() const;  // the whole text (tests, small files)

 private:
  std::vector<std::string> pieces_;
};

}  // namespace chungs

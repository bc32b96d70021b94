#include "chungs/common/text_pieces.hpp"

#include <algorithm>

namespace chungs {

void TextPieces::append(std::string_view text) {
  while (!text.empty()) {
    if (pieces_.empty() || pieces_.back().size() == kPiece) {
      pieces_.emplace_back();
      pieces_.back().reserve(kPiece);
    }
    std::string& tail = pieces_.back();
    const size_t n = std::min(text.size(), kPiece - tail.size());
    tail.append(text.data(), n);
    text.remove_prefix(n);
  }
}

void TextPieces::splice(TextPieces&& other) {
  for (std::string& p : other.pieces_) pieces_.push_back(std::move(p));
  other.pieces_.clear();
}

size_t TextPieces::size() const {
  size_t n = 0;
  for (const std::string& p : pieces_) n += p.size();
  return n;
}

std::string TextPieces::str() const {
  std::string s;
  s.reserve(size());
  for (const std::string& p : pieces_) s += p;
  return s;
}

}  // namespace chungs

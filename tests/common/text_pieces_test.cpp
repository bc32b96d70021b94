#include "chungs/common/text_pieces.hpp"

#include <gtest/gtest.h>

#include <random>

namespace chungs {

TEST(TextPieces, KeepsTheBytesInOrderAcrossPiecesOfOneSize) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> len(0, 9000), ch('a', 'z');
  TextPieces t;
  std::string expect;
  // Enough appends of random lengths to cross many piece borders, some exactly at one.
  while (expect.size() < 3 * TextPieces::kPiece + 12345) {
    std::string s(size_t(len(rng)), 'x');
    for (char& c : s) c = char(ch(rng));
    t += s;
    expect += s;
  }
  t += '!';
  expect += '!';
  EXPECT_EQ(t.size(), expect.size());
  EXPECT_EQ(t.str(), expect);
  ASSERT_EQ(t.pieces().size(), expect.size() / TextPieces::kPiece + 1);
  for (size_t i = 0; i + 1 < t.pieces().size(); ++i) EXPECT_EQ(t.pieces()[i].size(), TextPieces::kPiece);

  TextPieces head;
  head += "head:";
  head.splice(std::move(t));
  EXPECT_EQ(head.str(), "head:" + expect);
  EXPECT_TRUE(t.pieces().empty());
  head += "tail";
  EXPECT_EQ(head.str(), "head:" + expect + "tail");
}

}  // namespace chungs

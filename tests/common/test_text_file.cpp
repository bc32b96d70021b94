#include <gtest/gtest.h>

#include <fstream>

#include "chungs/common/error.hpp"
#include "chungs/common/text_file.hpp"
#include "test_support.hpp"

using namespace chungs;

TEST(TextFile, SkipsCommentsAndHeadersAndNamesLines) {
  test::TempDir dir;
  std::ofstream(dir / "t.csv") << "#timestamp [ns],filename\n\n1,a.png\n2 , b.png\n";
  auto lines = read_text_table(dir / "t.csv", true, true);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[1].number, 4);
  EXPECT_EQ(lines[1].tokens[1], "b.png");
  EXPECT_EQ(lines[0].integer_at(0), 1);
  try {
    lines[1].number_at(1);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("t.csv:4"), std::string::npos) << e.what();
  }
}

TEST(TextFile, RejectsNonFiniteNumbersAndMissingFiles) {
  EXPECT_FALSE(is_number("nan"));
  EXPECT_FALSE(is_number("1.0x"));
  EXPECT_TRUE(is_number("-1e-3"));
  EXPECT_THROW(read_text_table("/nonexistent/file.txt"), Error);
}

// An editor's byte order mark made the first line a header: a trajectory lost its first pose unsaid.
TEST(TextFile, AByteOrderMarkIsNotAHeader) {
  test::TempDir dir;
  std::ofstream(dir / "t.txt") << "\xEF\xBB\xBF" << "0.5 1 2\n1.5 3 4\n";
  const auto lines = read_text_table(dir / "t.txt", false, true);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_DOUBLE_EQ(lines[0].number_at(0), 0.5);
  EXPECT_EQ(lines[0].number, 1);
}

TEST(TextFile, JsonNestedBeyondTheLimitIsRefusedNamingTheFile) {
  const std::string deep = std::string(300, '[') + std::string(300, ']');
  try {
    require_json_nesting(deep, "report.json");
    FAIL() << "300 levels passed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("report.json"), std::string::npos) << e.what();
  }
  // Brackets inside strings (escaped quotes too) are text, not nesting.
  const std::string in_text = "{\"a\": \"" + std::string(300, '[') + "\\\"" + std::string(300, '{') + "\", \"b\": [[1]]}";
  EXPECT_NO_THROW(require_json_nesting(in_text, "report.json"));
  EXPECT_NO_THROW(require_json_nesting(std::string(256, '[') + std::string(256, ']'), "report.json"));
}

// Writing a report: a failure names the file and the system's reason.
#include <gtest/gtest.h>

#include "chungs/common/error.hpp"
#include "chungs/eval/report.hpp"
#include "test_support.hpp"

using namespace chungs;

// report.json of a run on a full disk failed with "report.json.tmp: write failed", no reason.
TEST(Report, AFailedWriteNamesTheFileAndTheSystemsReason) {
  test::TempDir dir;
  std::filesystem::create_symlink("/dev/full", dir / "report.json.tmp");  // where it is written first
  nlohmann::json j;
  j["text"] = std::string(100000, 'x');
  try {
    write_json(dir / "report.json", j);
    FAIL() << "a write to a full disk went unnoticed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("report.json.tmp: write failed (No space left on device)"), std::string::npos)
        << e.what();
  }
}

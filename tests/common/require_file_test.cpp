// Inputs must be regular files: a FIFO named in an index file used to block a read forever.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/common/text_file.hpp"

namespace chungs {
namespace {

TEST(RequireFile, AFifoIsRefusedWithoutBlocking) {
  std::random_device rd;
  const auto dir = std::filesystem::temp_directory_path() / ("chungs_fifo_" + std::to_string(rd()));
  std::filesystem::create_directories(dir);
  const auto fifo = dir / "frame.png", plain = dir / "plain.txt";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::ofstream(plain) << "ok";
  try {
    read_file_text(fifo);
    ADD_FAILURE() << "read a FIFO";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("FIFO"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(fifo.string()), std::string::npos) << e.what();
  }
  EXPECT_THROW(require_file(dir), Error);  // a folder
  EXPECT_EQ(read_file_text(plain), "ok");
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace chungs

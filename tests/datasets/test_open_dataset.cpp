#include <gtest/gtest.h>

#include "chungs/datasets/dataset.hpp"
#include "dataset_test_util.hpp"
#include "test_support.hpp"

using namespace chungs;

TEST(OpenDataset, ListsTheKinds) {
  // rosbag is listed in every build; without ROS, opening one says the build lacks it.
  EXPECT_EQ(dataset_kinds(), (std::vector<std::string>{"kitti", "tum", "replica", "euroc", "3dmatch", "rosbag"}));
}

TEST(OpenDataset, UnknownKindNamesItAndTheKnownOnes) {
  test::expect_error([] { open_dataset("foo:bar"); }, {"'foo'", "kitti", "3dmatch"});
}

TEST(OpenDataset, SpecWithoutKindOrPathIsAnError) {
  test::expect_error([] { open_dataset("/some/folder"); }, {"KIND:PATH"});
  test::expect_error([] { open_dataset("kitti:"); }, {"empty"});
}

TEST(OpenDataset, MissingPathNamesIt) {
  test::TempDir tmp;
  for (const auto& kind : dataset_kinds()) {
    std::string path = (tmp / "nowhere").string();
    test::expect_error([&] { open_dataset(kind + ":" + path); }, {path, "does not exist"});
  }
}

TEST(OpenDataset, EmptyFolderIsNotMistakenForAnyKind) {
  test::TempDir tmp;
  for (const auto& kind : dataset_kinds())
    test::expect_error([&] { open_dataset(kind + ":" + tmp.path().string()); }, {tmp.path().string()});
}

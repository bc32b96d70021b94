// A PLY may give list counts, vertex indices and colours as floats; a NaN or fractional one is
// refused naming the file, line and value, where it used to become an int or a colour byte through
// an undefined conversion (found by fuzz/mesh_ply_fuzz.cpp; its inputs are in fuzz/corpus/mesh_ply).
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/synth/ply.hpp"
#include "test_support.hpp"

namespace chungs::synth {
namespace {

const char* const kHeader =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
    "property float red\nproperty float green\nproperty float blue\nelement face 1\n";

std::string error_reading(const test::TempDir& tmp, const std::string& faces, const std::string& body) {
  const auto file = tmp / "mesh.ply";
  std::ofstream(file) << kHeader << faces << "end_header\n" << body;
  try {
    read_ply(file);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

const char* const kVertices = "0 0 0 1 0 0\n1 0 0 0 1 0\n0 1 0 0 0 1\n";

TEST(PlyNumbers, NanOrFractionalListLengthIsRefused) {
  test::TempDir tmp;
  const std::string faces = "property list float int vertex_indices\n";
  for (const char* count : {"nan", "2.5"}) {
    const std::string msg = error_reading(tmp, faces, std::string(kVertices) + count + " 0 1 2\n");
    EXPECT_NE(msg.find("mesh.ply:16: bad list length " + std::string(count)), std::string::npos) << msg;
  }
}

TEST(PlyNumbers, NanOrFractionalVertexIndexIsRefused) {
  test::TempDir tmp;
  const std::string faces = "property list uchar float vertex_indices\n";
  for (const char* index : {"nan", "1.5"}) {
    const std::string msg = error_reading(tmp, faces, std::string(kVertices) + "3 0 " + index + " 2\n");
    EXPECT_NE(msg.find("mesh.ply:16: face 0 refers to vertex " + std::string(index)), std::string::npos)
        << msg;
  }
  EXPECT_EQ(error_reading(tmp, faces, std::string(kVertices) + "3 0 1 2\n"), "(no error)");
}

TEST(PlyNumbers, NonFiniteColourIsRefused) {
  test::TempDir tmp;
  const std::string faces = "property list uchar int vertex_indices\n";
  const std::string msg = error_reading(tmp, faces, "0 0 0 1 0 0\n1 0 0 nan 1 0\n0 1 0 0 0 1\n3 0 1 2\n");
  EXPECT_NE(msg.find("mesh.ply:14: vertex 1 has red = nan"), std::string::npos) << msg;
}

}  // namespace
}  // namespace chungs::synth

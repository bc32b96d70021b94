// Hostile inputs to the generator (issue 21): every one is refused with the file or value named,
// before it can hang the reader, wrap an integer or size buffers for a typo.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <thread>

#include "chungs/common/error.hpp"
#include "chungs/synth/mesh_render.hpp"
#include "chungs/synth/ply.hpp"
#include "chungs/synth/room.hpp"
#include "chungs/synth/sequence.hpp"
#include "chungs/synth/street.hpp"
#include "test_support.hpp"

namespace chungs::synth {
namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

void write_file(const std::filesystem::path& p, const std::string& text) { std::ofstream(p) << text; }

const char* const kTriangle =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
    "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
    "%s -1 0\n1 -1 0\n0 1 0\n3 0 1 2\n";

std::string triangle_with_first_x(const std::string& x) {
  std::string s = kTriangle;
  return s.replace(s.find("%s"), 2, x);
}

TEST(SynthHostile, PlyRefusesNonFiniteVertexNamingFileAndLine) {
  test::TempDir dir;
  for (const std::string x : {"nan", "inf", "-inf", "1e300"}) {
    write_file(dir / "m.ply", triangle_with_first_x(x));
    const std::string e = error_of([&] { read_ply(dir / "m.ply"); });
    EXPECT_NE(e.find("m.ply:10: vertex 0 has x = "), std::string::npos) << x << ": " << e;
  }
  write_file(dir / "m.ply", triangle_with_first_x("-1"));
  EXPECT_EQ(read_ply(dir / "m.ply").vertices.size(), 3u);
}

// Fuzzing found it (fuzz/corpus/mesh_ply/binary_header_ends_without_newline): a binary header whose
// end_header is the file's last bytes, without a newline, had the body start one byte past the end
// and read the vertices from beyond the buffer.
TEST(SynthHostile, PlyHeaderEndingTheFileWithoutNewlineIsAnEarlyEndNotAnOverread) {
  test::TempDir dir;
  write_file(dir / "m.ply",
             "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
             "property float z\nend_header");
  const std::string e = error_of([&] { read_ply(dir / "m.ply"); });
  EXPECT_NE(e.find("m.ply\": file ends early inside the vertex data"), std::string::npos) << e;
}

TEST(SynthHostile, PlyRefusesAFifoInsteadOfBlocking) {
  test::TempDir dir;
  const auto fifo = dir / "m.ply";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  // Without the check the reader blocks in open() until a writer comes. This writer knocks (a
  // non-blocking open succeeds only while a reader waits) and closes at once, so an unfixed reader
  // fails the test instead of hanging it; a fixed one never opens the FIFO, so nobody answers.
  std::atomic<bool> done{false};
  std::thread unblock([&] {
    while (!done) {
      const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
      if (fd >= 0) ::close(fd);
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  });
  const std::string e = error_of([&] { read_ply(fifo); });
  done = true;
  unblock.join();
  EXPECT_NE(e.find("m.ply: expected a PLY mesh, found a FIFO"), std::string::npos) << e;
}

TEST(SynthHostile, IntrinsicsRefuseSidesThatWrapOrCannotBeAllocated) {
  for (const std::string spec :
       {"50,50,32,24,1e12,48", "50,50,32,24,100000,100000", "50,50,32,24,64.5,48", "50,50,32,24,0,48"}) {
    const std::string e = error_of([&] { parse_intrinsics(spec); });
    EXPECT_NE(e.find("intrinsics '" + spec + "': "), std::string::npos) << e;
    EXPECT_NE(e.find("must be a whole number of pixels from 1 to 16384"), std::string::npos) << e;
  }
  EXPECT_EQ(parse_intrinsics("50,50,32,24,16384,48").width, 16384);
  EXPECT_NE(error_of([] { parse_intrinsics(""); }).find("intrinsics are empty"), std::string::npos);
}

TEST(SynthHostile, CamParamsJsonSidesAreChecked) {
  test::TempDir dir;
  write_file(dir / "cam.json", R"({"camera": {"w": 1e12, "h": 48, "fx": 50, "fy": 50, "cx": 32, "cy": 24}})");
  const std::string e = error_of([&] { read_cam_params_json(dir / "cam.json"); });
  EXPECT_NE(e.find("cam.json: camera.w must be a whole number of pixels"), std::string::npos) << e;
}

TEST(SynthHostile, StreetRouteRefusesLengthsWithoutEnd) {
  StreetOptions o;
  for (double length : {double(INFINITY), 1e308, -5.0, double(NAN)}) {
    o.length_m = length;
    const std::string e = error_of([&] { street_trajectory(o, 2); });
    EXPECT_NE(e.find("street route: length must be in (0, 1e+06] m"), std::string::npos)
        << length << ": " << e;
  }
  o.length_m = 20;
  EXPECT_EQ(street_trajectory(o, 2).size(), 2u);
}

TEST(SynthHostile, SequenceRefusesImagesBeyondTheSideLimit) {
  test::TempDir dir;
  RoomOptions ro;
  MeshScene scene(build_room(ro), Environment::indoor());
  const std::string e = error_of([&] {
    render_sequence(scene, room_trajectory(ro, 1), tum_camera(20000, 8), SequenceOptions{}, dir / "out");
  });
  EXPECT_NE(e.find("image size 20000x8 exceeds 16384 pixels a side"), std::string::npos) << e;
}

}  // namespace
}  // namespace chungs::synth

// The viewer's server over a map folder made here: what /api/map and /api/chunk/<id> answer, the
// errors a client gets for unknown ids, bad queries and paths outside the page, a taken port, and
// a folder left exactly as it was. Requests go over a plain socket, byte for byte as written.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "chungs/common/error.hpp"
#include "chungs/mapping/map_state.hpp"
#include "chungs/mapping/sky_file.hpp"
#include "chungs/pipeline/timeline.hpp"
#include "chungs/serve/splat_pack.hpp"
#include "chungs/serve/view_server.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;
using namespace chungs::serve;
namespace fs = std::filesystem;

namespace {

struct Reply {
  int status = 0;
  std::string headers, body;
};

// Runs a server on a thread of its own; stop() asks until the loop has ended (a stop() that comes
// before the loop has started is lost).
class Running {
 public:
  explicit Running(ViewServer& s) : s_(s), t_([this] {
    s_.run();
    done_ = true;
  }) {}
  ~Running() { stop(); }
  void stop() {
    while (!done_) {
      s_.stop();
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    if (t_.joinable()) t_.join();
  }

 private:
  ViewServer& s_;
  std::atomic<bool> done_{false};
  std::thread t_;
};

Reply get(int port, const std::string& target, const std::string& headers = "", const std::string& method = "GET") {
  Reply r;
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(uint16_t(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    close(fd);
    return r;
  }
  const timeval limit{10, 0};  // a server that never answers fails the test instead of hanging it
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &limit, sizeof limit);
  const std::string req = method + " " + target + " HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n" + headers + "\r\n";
  (void)!write(fd, req.data(), req.size());
  std::string all;
  char buf[65536];
  ssize_t n;
  while ((n = read(fd, buf, sizeof buf)) > 0) all.append(buf, size_t(n));
  close(fd);
  const size_t head_end = all.find("\r\n\r\n");
  if (all.rfind("HTTP/1.1 ", 0) != 0 || head_end == std::string::npos) return r;
  r.status = std::stoi(all.substr(9, 3));
  r.headers = all.substr(0, head_end);
  r.body = all.substr(head_end + 4);
  return r;
}

std::map<std::string, std::string> folder_bytes(const fs::path& dir) {
  std::map<std::string, std::string> m;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) {
      std::ifstream f(e.path(), std::ios::binary);
      std::stringstream s;
      s << f.rdbuf();
      m[fs::relative(e.path(), dir).string()] = s.str();
    }
  return m;
}

ChunkId cid(int x) { return chunk_id({x, 0, -2}); }

// A map of three chunks at checkpoint 4 with two keyframes, a trajectory and a report.
void make_map(const fs::path& map) {
  ChunkStoreConfig c;
  c.durable = false;
  c.chunk_size = 10;
  {
    ChunkStore w(map, c);
    for (int x = 0; x < 3; ++x) w.save(cid(x), test::random_block(20 + 5 * x, 100 + x, 10.f * x, 0, -20));
    w.set_config("checkpoint", "4");
    w.commit();
  }
  std::vector<KeyframeRecord> kfs(2);
  for (int i = 0; i < 2; ++i) {
    kfs[i].id = uint32_t(i);
    kfs[i].frame = uint64_t(8 * i);
    kfs[i].camera = Camera(64, 48, 50, 50, 31.5, 23.5);
    kfs[i].pose.t = Eigen::Vector3d(1.5 * i, 0.25, -21);
  }
  write_keyframe_records(map / "keyframes.txt", kfs, false);
  std::ofstream(map / "trajectory.txt") << "0 0 0.25 -21 0 0 0 1\n1 1.5 0.25 -21 0 0 0 1\n";
  std::ofstream(map / "report.json") << R"({"fps": 3.5, "settings": {"budget_gaussians": 1000}})";
}

class ViewServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    make_map(map_);
    fs::create_directories(web_ / "page");
    std::ofstream(web_ / "page" / "index.html") << "<html>viewer</html>";
    std::ofstream js(web_ / "page" / "viewer.js");
    for (int i = 0; i < 2000; ++i) js << "export const a" << i << " = " << i << ";\n";
    std::ofstream(web_ / "secret.txt") << "not for clients";
    before_ = folder_bytes(map_);
    snapshot_ = std::make_shared<MapSnapshot>(map_);
    server_ = std::make_unique<ViewServer>(snapshot_, ViewServerOptions{"127.0.0.1", 0, web_ / "page"});
    server_->bind();
    running_ = std::make_unique<Running>(*server_);
  }
  void TearDown() override {
    running_.reset();
    EXPECT_EQ(folder_bytes(map_), before_) << "the server changed the map folder";
  }
  int port() const { return server_->port(); }

  test::TempDir dir_;
  fs::path map_ = dir_ / "map", web_ = dir_ / "web";
  std::map<std::string, std::string> before_;
  std::shared_ptr<MapSnapshot> snapshot_;
  std::unique_ptr<ViewServer> server_;
  std::unique_ptr<Running> running_;
};

}  // namespace

TEST_F(ViewServerTest, MapDescriptionListsChunksKeyframesCameraAndReport) {
  const Reply r = get(port(), "/api/map");
  ASSERT_EQ(r.status, 200) << r.body;
  const auto j = nlohmann::json::parse(r.body);
  EXPECT_EQ(j["checkpoint"], 4);
  EXPECT_EQ(j["chunk_size"], 10.0);
  EXPECT_EQ(j["total_gaussians"], 20 + 25 + 30);
  ASSERT_EQ(j["chunks"].size(), 3u);
  const Manifest m = Manifest::read(map_ / "manifest.txt");
  for (const auto& c : j["chunks"]) {
    const ChunkId id = std::stoull(c["id"].get<std::string>());
    ASSERT_TRUE(m.chunks.count(id));
    EXPECT_EQ(c["count"], m.chunks.at(id).count);
    EXPECT_EQ(c["generation"], m.chunks.at(id).generation);
    const ChunkCoord cc = chunk_coord(id);
    EXPECT_EQ(c["coord"], nlohmann::json({cc.x, cc.y, cc.z}));
    EXPECT_EQ(c["min"][0], 10.0 * cc.x - 5);
    EXPECT_EQ(c["max"][2], 10.0 * cc.z + 5);
  }
  ASSERT_EQ(j["keyframes"].size(), 2u);
  EXPECT_EQ(j["keyframes"][1]["frame"], 8);
  EXPECT_EQ(j["keyframes"][1]["pose"][0][3], 1.5);
  EXPECT_EQ(j["origin"], nlohmann::json({0.0, 0.25, -21.0}));  // the first keyframe's position
  EXPECT_EQ(j["camera"]["cx"], 31.5);
  EXPECT_EQ(j["camera"]["width"], 64);
  EXPECT_EQ(j["trajectory"].size(), 2u);
  EXPECT_EQ(j["report"]["fps"], 3.5);
  EXPECT_NE(r.headers.find("application/json"), std::string::npos);
}

TEST_F(ViewServerTest, ChunkBytesAreThePackOfTheCommittedChunkAtTheAskedDegree) {
  ChunkStore reader(map_, reader_config());
  for (int x = 0; x < 3; ++x) {
    const GaussianBlock b = reader.load(cid(x));
    const Eigen::Vector3d c = chunk_centre(chunk_coord(cid(x)), 10);
    const double origin[3] = {c.x(), c.y(), c.z()};
    const uint64_t gen = reader.manifest().chunks.at(cid(x)).generation;
    const Reply full = get(port(), "/api/chunk/" + std::to_string(cid(x)));
    ASSERT_EQ(full.status, 200) << full.body;
    EXPECT_EQ(full.body, pack_splats(b.params, 3, origin, cid(x), gen));
    const Reply dc = get(port(), "/api/chunk/" + std::to_string(cid(x)) + "?sh=0");
    ASSERT_EQ(dc.status, 200);
    EXPECT_EQ(dc.body, pack_splats(b.params, 0, origin, cid(x), gen));
    EXPECT_EQ(dc.body.size(), splat_pack_bytes(b.size(), 0));
  }
}

TEST_F(ViewServerTest, UnknownChunksAndBadValuesGetJsonErrorsNamingThem) {
  const Reply missing = get(port(), "/api/chunk/" + std::to_string(cid(7)));
  EXPECT_EQ(missing.status, 404);
  EXPECT_NE(nlohmann::json::parse(missing.body)["error"].get<std::string>().find(std::to_string(cid(7))),
            std::string::npos);
  for (const std::string bad : {"abc", "-1", "12x", "99999999999999999999999", "1e5", ""}) {
    const Reply r = get(port(), "/api/chunk/" + bad);
    EXPECT_EQ(r.status, 400) << bad;
    EXPECT_NE(nlohmann::json::parse(r.body)["error"].get<std::string>().find("'" + bad + "'"), std::string::npos)
        << r.body;
  }
  for (const std::string sh : {"4", "-1", "x", "1.5", "3%20", "%00"}) {
    const Reply r = get(port(), "/api/chunk/" + std::to_string(cid(0)) + "?sh=" + sh);
    EXPECT_EQ(r.status, 400) << sh;
    EXPECT_NE(r.body.find("sh '"), std::string::npos) << r.body;
  }
  const Reply twice = get(port(), "/api/chunk/" + std::to_string(cid(0)) + "?sh=0&sh=3");
  EXPECT_EQ(twice.status, 400);
  EXPECT_NE(twice.body.find("sh is given more than once"), std::string::npos) << twice.body;
  const Reply api = get(port(), "/api/nothing");
  EXPECT_EQ(api.status, 404);
  EXPECT_TRUE(nlohmann::json::parse(api.body).contains("error"));
}

TEST_F(ViewServerTest, PageFilesAreServedAndPathsOutOfTheRootAreRefused) {
  const Reply index = get(port(), "/");
  EXPECT_EQ(index.status, 200);
  EXPECT_EQ(index.body, "<html>viewer</html>");
  for (const std::string t : {"/../secret.txt", "/%2e%2e/secret.txt", "/a/../../secret.txt", "/..%2fsecret.txt",
                              "/%2E%2E%2Fsecret.txt", "//../secret.txt", "/./../secret.txt"}) {
    const Reply r = get(port(), t);
    EXPECT_NE(r.status, 200) << t;
    EXPECT_EQ(r.body.find("not for clients"), std::string::npos) << t;
  }
  // Still up and serving after the hostile requests.
  EXPECT_EQ(get(port(), "/api/map").status, 200);
}

// What the HTTP library did on its own: a multipart body of every range asked for (1,000 ranges of the
// bundle took 3 GB), a body read to its announced end before a refusal, a path cut at a NUL byte.
TEST_F(ViewServerTest, RangesAreIgnoredAndRequestsNothingServesAreRefusedUnread) {
  const Reply plain = get(port(), "/viewer.js");
  ASSERT_EQ(plain.status, 200);
  std::string ranges = "Range: bytes=0-";
  for (int i = 0; i < 200; ++i) ranges += ",0-";
  for (const std::string path : {"/viewer.js", "/index.html", "/api/map"}) {
    const Reply r = get(port(), path, ranges + "\r\n");
    EXPECT_EQ(r.status, 200) << path;
    if (path == "/viewer.js") EXPECT_EQ(r.body, plain.body);
  }
  const auto t0 = std::chrono::steady_clock::now();
  const Reply post = get(port(), "/api/map", "Content-Length: 10737418240\r\n", "POST");
  EXPECT_EQ(post.status, 405);
  EXPECT_NE(post.headers.find("Allow: GET, HEAD"), std::string::npos) << post.headers;
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5)) << "the refusal waited for the body";
  EXPECT_EQ(get(port(), "/index.html", "", "DELETE").status, 405);
  EXPECT_EQ(get(port(), "/index.html%00.js").status, 400);
  std::string many;
  for (int i = 0; i < 300; ++i) many += "X-" + std::to_string(i) + ": a\r\n";
  EXPECT_EQ(get(port(), "/api/map", many).status, 431);
  EXPECT_EQ(get(port(), "/api/map").status, 200);
}

TEST_F(ViewServerTest, ASecondServerOnATakenPortFailsNamingHostAndPort) {
  ViewServer second(snapshot_, ViewServerOptions{"127.0.0.1", port(), {}});
  try {
    second.bind();
    FAIL() << "bound a port in use";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("127.0.0.1:" + std::to_string(port())), std::string::npos) << m;
    EXPECT_NE(m.find("in use"), std::string::npos) << m;
  }
}

TEST(ViewServer, WithoutAPageTheApiIsServedAndTheRootSaysWhy) {
  test::TempDir dir;
  make_map(dir / "map");
  auto snap = std::make_shared<MapSnapshot>(dir / "map");
  ViewServer s(snap, ViewServerOptions{"127.0.0.1", 0, dir / "no-such-page"});
  EXPECT_FALSE(s.has_page());
  s.bind();
  Running running(s);
  const Reply root = get(s.port(), "/");
  const Reply map = get(s.port(), "/api/map");
  running.stop();
  EXPECT_EQ(root.status, 503);
  EXPECT_NE(root.body.find("not built"), std::string::npos);
  EXPECT_EQ(map.status, 200);
}

TEST(MapSnapshot, AFolderWithoutAManifestIsRefusedByName) {
  test::TempDir dir;
  fs::create_directories(dir / "empty");
  try {
    MapSnapshot s(dir / "empty");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("empty: not a map folder"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::is_empty(dir / "empty"));
}

TEST(ViewServer, TimelineIsTheRunStateCommittedWithTheCheckpointColumnByColumn) {
  test::TempDir dir;
  make_map(dir / "map");
  std::vector<TimelineSample> samples(3);
  for (int i = 0; i < 3; ++i) {
    samples[size_t(i)].seconds = 1.5 * i;
    samples[size_t(i)].iterations = uint64_t(10 * i);
    samples[size_t(i)].total = uint64_t(100 + i);
    samples[size_t(i)].resident = uint64_t(60 + i);
    samples[size_t(i)].rss_mb = 30.25 + i;
    samples[size_t(i)].loads = uint64_t(i);
  }
  // Checkpoint 4 names its numbered run state until the writer renames it: that one is read.
  write_json_atomically(checkpoint_file(dir / "map", 4, "run_state.json"), {{"timeline", to_json(samples)}}, false);
  samples.resize(1);
  write_json_atomically(dir / "map" / "run_state.json", {{"timeline", to_json(samples)}}, false);
  ViewServer s(std::make_shared<MapSnapshot>(dir / "map"), ViewServerOptions{"127.0.0.1", 0, {}});
  s.bind();
  Running running(s);
  const Reply r = get(s.port(), "/api/timeline");
  running.stop();
  ASSERT_EQ(r.status, 200) << r.body;
  const auto j = nlohmann::json::parse(r.body);
  EXPECT_EQ(j["seconds"], nlohmann::json({0.0, 1.5, 3.0}));
  EXPECT_EQ(j["iterations"], nlohmann::json({0, 10, 20}));
  EXPECT_EQ(j["on_disk"], nlohmann::json({40, 40, 40}));
  EXPECT_EQ(j["rss_mb"][2], 32.25);
  EXPECT_EQ(j["loads"], nlohmann::json({0, 1, 2}));
}

TEST_F(ViewServerTest, WithoutARunStateTheTimelineIsEmpty) {
  const Reply r = get(port(), "/api/timeline");
  ASSERT_EQ(r.status, 200);
  EXPECT_TRUE(nlohmann::json::parse(r.body)["seconds"].empty());
}

TEST_F(ViewServerTest, WithoutASkyTheMapSaysSoAndTheSkyIsNotFound) {
  EXPECT_TRUE(nlohmann::json::parse(get(port(), "/api/map").body)["sky"].is_null());
  const Reply r = get(port(), "/api/sky");
  EXPECT_EQ(r.status, 404);
  EXPECT_NE(nlohmann::json::parse(r.body)["error"].get<std::string>().find("sky"), std::string::npos);
}

TEST(ViewServer, SkyIsTheTextureCommittedWithTheCheckpointTexelsMarkedTrainedOrNot) {
  test::TempDir dir;
  make_map(dir / "map");
  const double R[9] = {0, 0, 1, 1, 0, 0, 0, 1, 0};  // a camera whose up (-y) is not world z
  SkyConfig config;
  config.width = 8;
  config.height = 4;
  SkyTexture sky = make_sky(config, R);
  for (size_t i = 0; i < sky.rgb.size(); ++i) sky.rgb[i] = float((i * 37) % 101) / 100.f;
  sky.rgb[5] = 0.5f / 255;  // rounds up to 1
  for (size_t i = 0; i < sky.texels(); i += 3) sky.updates[i] = uint32_t(i + 1);  // the others never trained
  // Checkpoint 4 names its numbered sky until the writer renames it: that one is served, not an
  // older checkpoint's under the final name.
  write_sky_file(checkpoint_file(dir / "map", 4, "sky.bin"), sky, false);
  SkyTexture older = sky;
  std::fill(older.rgb.begin(), older.rgb.end(), 0.f);
  write_sky_file(dir / "map" / "sky.bin", older, false);
  ViewServer s(std::make_shared<MapSnapshot>(dir / "map"), ViewServerOptions{"127.0.0.1", 0, {}});
  s.bind();
  Running running(s);
  const Reply map = get(s.port(), "/api/map");
  const Reply r = get(s.port(), "/api/sky");
  running.stop();
  EXPECT_EQ(nlohmann::json::parse(map.body)["sky"], nlohmann::json({{"width", 8}, {"height", 4}}));
  ASSERT_EQ(r.status, 200) << r.body;
  ASSERT_EQ(r.body.size(), 64u + 4 * 8 * 4);
  EXPECT_EQ(r.body.substr(0, 8), "DCSKYTX1");
  uint32_t size[2];
  float axes[9];
  std::memcpy(size, r.body.data() + 8, sizeof size);
  std::memcpy(axes, r.body.data() + 16, sizeof axes);
  EXPECT_EQ(size[0], 8u);
  EXPECT_EQ(size[1], 4u);
  for (int i = 0; i < 9; ++i) EXPECT_EQ(axes[i], sky.axes[i]) << i;
  const auto* t = reinterpret_cast<const uint8_t*>(r.body.data() + 64);
  for (size_t i = 0; i < sky.texels(); ++i) {
    for (int c = 0; c < 3; ++c) EXPECT_EQ(t[4 * i + c], std::lround(sky.rgb[3 * i + c] * 255)) << i << " " << c;
    EXPECT_EQ(t[4 * i + 3], i % 3 == 0 ? 255 : 0) << i;
  }
  EXPECT_EQ(t[4 * 1 + 2], 1);
}

// Compression by the library costs the machine the mapper runs on (Brotli at its slowest quality:
// seconds for the page's bundle, tens of ms per /api/map), so the bundle and the API do not come
// compressed even when the browser asks for it. (index.html and the stylesheet, 1-2 KB, still do:
// the library compresses every text/ type, and they cost it a millisecond.)
TEST_F(ViewServerTest, BundleAndApiAreNotCompressedEvenWhenTheClientAcceptsIt) {
  const std::string accept = "Accept-Encoding: gzip, deflate, br, zstd\r\n";
  const std::string chunk = "/api/chunk/" + std::to_string(cid(1));
  for (const std::string t : {"/viewer.js", "/api/map", "/api/timeline", chunk.c_str(), "/api/nothing"}) {
    const Reply plain = get(port(), t), asked = get(port(), t, accept);
    EXPECT_EQ(asked.headers.find("Content-Encoding"), std::string::npos) << t << "\n" << asked.headers;
    EXPECT_EQ(asked.body, plain.body) << t;
    EXPECT_EQ(asked.status, plain.status) << t;
  }
  const Reply js = get(port(), "/viewer.js", accept);
  EXPECT_NE(js.headers.find("Content-Type: application/javascript"), std::string::npos) << js.headers;
}

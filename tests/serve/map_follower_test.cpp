// Following a map that a writer goes on committing: a new checkpoint becomes the current snapshot
// with one event naming what changed, an older snapshot keeps reading its own checkpoint, and the
// server streams the event to a client of /api/events.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include "chungs/serve/map_follower.hpp"
#include "chungs/serve/view_server.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;
using namespace chungs::serve;
namespace fs = std::filesystem;

namespace {

ChunkId cid(int x) { return chunk_id({x, 1, 0}); }

ChunkStoreConfig writer() {
  ChunkStoreConfig c;
  c.durable = false;
  return c;
}

void commit(const fs::path& map, int checkpoint, const std::vector<std::pair<int, int>>& saves,
            const std::vector<int>& removes = {}, int keyframes = 1) {
  ChunkStore w(map, writer());
  for (auto [x, n] : saves) w.save(cid(x), test::random_block(size_t(n), uint64_t(checkpoint * 100 + x), 10.f * x, 10, 0));
  for (int x : removes) w.remove(cid(x));
  w.set_config("checkpoint", std::to_string(checkpoint));
  w.commit();
  std::vector<KeyframeRecord> kfs(static_cast<size_t>(keyframes));
  for (int i = 0; i < keyframes; ++i) {
    kfs[size_t(i)].id = uint32_t(i);
    kfs[size_t(i)].camera = Camera(32, 24, 20, 20, 16, 12);
    kfs[size_t(i)].pose.t = Eigen::Vector3d(2.0 * i, 10, 0);
  }
  write_keyframe_records(map / "keyframes.txt", kfs, false);
}

std::vector<std::string> ids(const nlohmann::json& a) {
  std::vector<std::string> v;
  for (const auto& x : a) v.push_back(x.get<std::string>());
  return v;
}

}  // namespace

TEST(MapFollower, ANewCheckpointBecomesCurrentWithOneEventNamingItsChanges) {
  test::TempDir dir;
  const fs::path map = dir / "map";
  commit(map, 1, {{0, 10}, {1, 12}, {2, 14}});
  MapFollower f(std::make_shared<MapSnapshot>(map));
  EXPECT_FALSE(f.poll());
  const auto first = f.current();
  const GaussianBlock chunk1_before = first->store().load(cid(1));

  commit(map, 2, {{1, 20}, {3, 5}}, {2}, 3);  // chunk 1 changed, 3 added, 2 removed
  ASSERT_TRUE(f.poll());
  EXPECT_FALSE(f.poll());
  EXPECT_EQ(f.version(), 1u);
  EXPECT_EQ(f.current()->checkpoint(), 2u);
  const auto ev = f.events_after(0, std::chrono::milliseconds(0));
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0]["version"], 1);
  EXPECT_EQ(ev[0]["checkpoint"], 2);
  EXPECT_EQ(ids(ev[0]["added"]), std::vector<std::string>{std::to_string(cid(3))});
  EXPECT_EQ(ids(ev[0]["changed"]), std::vector<std::string>{std::to_string(cid(1))});
  EXPECT_EQ(ids(ev[0]["removed"]), std::vector<std::string>{std::to_string(cid(2))});
  EXPECT_EQ(ev[0]["keyframes"], 3);
  EXPECT_EQ(ev[0]["pose"][0][3], 4.0);  // the newest keyframe's position
  EXPECT_EQ(ev[0]["total_gaussians"], 10 + 20 + 5);
  EXPECT_TRUE(f.events_after(1, std::chrono::milliseconds(0)).empty());

  // Two more commits delete the files of checkpoint 1: the first snapshot still reads them whole.
  commit(map, 3, {{1, 7}});
  commit(map, 4, {{1, 8}});
  const GaussianBlock again = first->store().load(cid(1));
  EXPECT_EQ(again.params.mean, chunk1_before.params.mean);
  EXPECT_EQ(again.size(), 12u);
}

TEST(MapFollower, AClientFarBehindIsToldToReload) {
  test::TempDir dir;
  const fs::path map = dir / "map";
  commit(map, 1, {{0, 4}});
  MapFollower f(std::make_shared<MapSnapshot>(map));
  for (int k = 2; k < 2 + 260; ++k) {
    commit(map, k, {{0, 4 + k % 3}});
    ASSERT_TRUE(f.poll()) << k;
  }
  const auto ev = f.events_after(0, std::chrono::milliseconds(0));
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0]["reload"], true);
  EXPECT_EQ(f.events_after(250, std::chrono::milliseconds(0)).size(), 10u);
  // A page that knew a later version (the viewer restarted under it) is told at once, not left waiting.
  const auto ahead = f.events_after(f.version() + 5, std::chrono::seconds(30));
  ASSERT_EQ(ahead.size(), 1u);
  EXPECT_EQ(ahead[0]["reload"], true);
  EXPECT_EQ(ahead[0]["version"], f.version());
}

namespace {

// A server of the follower's map on a free port, run on a thread of its own while in scope.
class ServedMap {
 public:
  explicit ServedMap(std::shared_ptr<MapFollower> f) : follower_(std::move(f)), server_(follower_, {"127.0.0.1", 0, {}}) {
    server_.bind();
    thread_ = std::thread([this] {
      server_.run();
      done_ = true;
    });
    follower_->start(std::chrono::milliseconds(20));
  }
  ~ServedMap() {
    follower_->stop();  // ends the event streams' loops, then the server
    while (!done_) {
      server_.stop();
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    thread_.join();
  }
  // A connection that has sent GET `path`, read with a timeout of 100 ms a call.
  int ask(const std::string& path) const {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(uint16_t(server_.port()));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    const std::string req = "GET " + path + " HTTP/1.1\r\nHost: x\r\n\r\n";
    EXPECT_EQ(write(fd, req.data(), req.size()), ssize_t(req.size()));
    timeval tv{0, 100000};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    return fd;
  }

 private:
  std::shared_ptr<MapFollower> follower_;
  ViewServer server_;
  std::atomic<bool> done_{false};
  std::thread thread_;
};

// What `fd` gives until `enough` says so or `wait` has passed.
template <class Enough>
std::string read_until(int fd, Enough enough, std::chrono::milliseconds wait) {
  std::string got;
  const auto t0 = std::chrono::steady_clock::now();
  while (!enough(got) && std::chrono::steady_clock::now() - t0 < wait) {
    char buf[4096];
    const ssize_t n = read(fd, buf, sizeof buf);
    if (n > 0) got.append(buf, size_t(n));
  }
  return got;
}

}  // namespace

TEST(MapFollower, TheServerStreamsEachCheckpointToAnEventClient) {
  test::TempDir dir;
  const fs::path map = dir / "map";
  commit(map, 1, {{0, 6}});
  ServedMap served(std::make_shared<MapFollower>(std::make_shared<MapSnapshot>(map)));
  const int fd = served.ask("/api/events?since=0");
  commit(map, 2, {{5, 9}});
  const auto t0 = std::chrono::steady_clock::now();
  const std::string got = read_until(fd, [](const std::string& g) {
    const size_t at = g.find("event: checkpoint");
    return at != std::string::npos && g.find("\n\n", at) != std::string::npos;
  }, std::chrono::seconds(10));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  close(fd);
  EXPECT_NE(got.find("text/event-stream"), std::string::npos) << got;
  EXPECT_NE(got.find("id: 1"), std::string::npos) << got;
  EXPECT_NE(got.find("\"added\":[\"" + std::to_string(cid(5)) + "\"]"), std::string::npos) << got;
  EXPECT_LT(seconds, 2.0);  // the bound for a committed chunk to reach the page
}

// Each open event stream holds a server thread: 34 streams left none of the 32 for /api/map, which
// timed out until they closed. Past 16 a stream is refused, and the map is still served.
TEST(MapFollower, EventStreamsBeyondSixteenAreRefusedAndTheMapIsStillServed) {
  test::TempDir dir;
  const fs::path map = dir / "map";
  commit(map, 1, {{0, 6}});
  ServedMap served(std::make_shared<MapFollower>(std::make_shared<MapSnapshot>(map)));
  auto headers = [](const std::string& g) { return g.find("\r\n\r\n") != std::string::npos; };
  std::vector<int> streams;
  for (int i = 0; i < 16; ++i) {
    streams.push_back(served.ask("/api/events"));
    const std::string got = read_until(streams.back(), headers, std::chrono::seconds(5));
    EXPECT_NE(got.find("text/event-stream"), std::string::npos) << i << ": " << got;
  }
  const int extra = served.ask("/api/events");
  const std::string refused = read_until(extra, headers, std::chrono::seconds(5));
  close(extra);
  EXPECT_NE(refused.find("503"), std::string::npos) << refused;
  const int fd = served.ask("/api/map");
  const std::string answer = read_until(fd, headers, std::chrono::seconds(5));  // no thread left: nothing in 5 s
  close(fd);
  EXPECT_NE(answer.find("200 OK"), std::string::npos) << answer;
  for (int s : streams) close(s);
}

#include "chungs/serve/view_server.hpp"

#include <httplib.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <charconv>
#include <cstdlib>
#include <cstring>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/serve/sky_pack.hpp"
#include "chungs/serve/splat_pack.hpp"

#ifndef CHUNGS_WEB_BUILD_DIR
#define CHUNGS_WEB_BUILD_DIR ""
#endif

namespace chungs::serve {

namespace fs = std::filesystem;

namespace {

// The library (built with Brotli) compresses a response whose type is exactly one it lists
// (application/json, application/javascript, text/...) when the client accepts it, at Brotli's
// slowest quality: about 1 MB/s here, so each page load spent 3-4 s of a core on the 3 MB bundle
// and every checkpoint's /api/map 50-100 ms, on the mapper's core beside `run --view` (measured:
// 11 s of CPU in a 67 s run, 15 % of the mapper's FPS). Chunks (octet-stream) never were. The same
// types with their charset named are served as they are; on localhost compression buys nothing.
// view_server_test checks that no response is compressed.
constexpr const char* kJson = "application/json; charset=utf-8";
constexpr const char* kJavaScript = "application/javascript; charset=utf-8";

void json_error(httplib::Response& res, int status, const std::string& message) {
  res.status = status;
  res.set_content(nlohmann::json{{"error", message}}.dump(), kJson);
}

// A decimal number in [lo, hi] and nothing else (no sign, blanks or trailing characters).
bool parse_whole(const std::string& s, uint64_t lo, uint64_t hi, uint64_t& out) {
  if (s.empty() || s.size() > 20) return false;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && end == s.data() + s.size() && out >= lo && out <= hi;
}

// Printable and short, for echoing a client's value in a message.
std::string quoted(const std::string& s) {
  std::string q;
  for (char c : s.substr(0, 64)) q += (c >= 0x20 && c < 0x7f && c != '\'') ? c : '?';
  return "'" + q + (s.size() > 64 ? "...'" : "'");
}

bool holds_page(const fs::path& dir) {
  std::error_code ec;
  return !dir.empty() && fs::is_regular_file(dir / "index.html", ec);
}

}  // namespace

fs::path find_web_root(const fs::path& explicit_root) {
  if (!explicit_root.empty()) return holds_page(explicit_root) ? explicit_root : fs::path();
  if (const char* env = std::getenv("CHUNGS_WEB_DIR"); env && *env) return holds_page(env) ? fs::path(env) : fs::path();
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / "share" / "diskchungs" / "web";
    if (holds_page(installed)) return installed;
  }
  const fs::path built = CHUNGS_WEB_BUILD_DIR;
  return holds_page(built) ? built : fs::path();
}

ViewServer::ViewServer(std::shared_ptr<const MapSnapshot> map, ViewServerOptions options)
    : ViewServer(std::make_shared<MapFollower>(std::move(map)), std::move(options)) {}

ViewServer::ViewServer(std::shared_ptr<MapFollower> follower, ViewServerOptions options)
    : follower_(std::move(follower)), options_(std::move(options)), server_(std::make_unique<httplib::Server>()) {
  if (options_.port < 0 || options_.port > 65535) fail("port ", options_.port, " is outside 0..65535");
  // The library's default adds SO_REUSEPORT, which lets a second server share a port that is in
  // use; only SO_REUSEADDR (a restart while old connections linger), so a taken port is refused.
  // Each open event stream (/api/events) holds a thread for as long as its page is open; the
  // library's default of 8 would leave a few pages waiting for chunks. Idle threads cost nothing.
  server_->new_task_queue = [] { return new httplib::ThreadPool(32); };
  server_->set_socket_options([](int sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  routes();
}

ViewServer::~ViewServer() = default;

std::string ViewServer::url() const {
  const bool v6 = options_.host.find(':') != std::string::npos;
  return "http://" + (v6 ? "[" + options_.host + "]" : options_.host) + ":" + std::to_string(port_) + "/";
}

void ViewServer::bind() {
  errno = 0;
  bool ok;
  if (options_.port == 0) {
    port_ = server_->bind_to_any_port(options_.host);
    ok = port_ > 0;
  } else {
    ok = server_->bind_to_port(options_.host, options_.port);
    port_ = options_.port;
  }
  if (!ok) {
    const int e = errno;
    fail("cannot listen on ", options_.host, ":", options_.port, ": ",
         e == EADDRINUSE ? "the port is in use (another server, or give --port)"
         : e         ? std::strerror(e)
                     : "the address is not one of this machine's");
  }
}

void ViewServer::run() { server_->listen_after_bind(); }

void ViewServer::stop() { server_->stop(); }

void ViewServer::routes() {
  httplib::Server& s = *server_;
  s.set_read_timeout(10);
  s.set_write_timeout(30);
  s.set_payload_max_length(64 * 1024);  // nothing here takes a body
  s.set_keep_alive_max_count(1000);

  // Before any route (the library serves static files even earlier: see the file handler below), what it
  // would otherwise do on its own.
  constexpr size_t kMaxHeaders = 200;
  s.set_pre_routing_handler([](const httplib::Request& req, httplib::Response& res) {
    // Nothing here needs byte ranges, and the library built a multipart body of each one asked for:
    // 1,000 "0-" ranges of viewer.js took 3 GB. Ranges are ignored (a full 200 is always a valid answer).
    const_cast<httplib::Request&>(req).ranges.clear();
    if (req.method != "GET" && req.method != "HEAD") {
      // Answered before a body is read (a POST announcing 10 GB was read to its end first).
      res.set_header("Allow", "GET, HEAD");
      res.set_header("Connection", "close");
      json_error(res, 405, req.method + " is not served here; only GET and HEAD");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (req.path.find('\0') != std::string::npos) {  // %00 cut a static path short: index.html%00.js
      json_error(res, 400, "the path holds a NUL byte");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (req.headers.size() > kMaxHeaders) {
      res.set_header("Connection", "close");
      json_error(res, 431, "more than " + std::to_string(kMaxHeaders) + " request headers");
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  // Static files are served before that handler runs: their ranges are dropped here.
  s.set_file_request_handler([](const httplib::Request& req, httplib::Response& res) {
    const_cast<httplib::Request&>(req).ranges.clear();
    res.status = 200;
  });

  const fs::path root = find_web_root(options_.web_root);
  has_page_ = !root.empty();
  if (has_page_) {
    s.set_mount_point("/", root.string());
    s.set_file_extension_and_mimetype_mapping("js", kJavaScript);
    s.set_file_extension_and_mimetype_mapping("mjs", kJavaScript);
    s.set_file_extension_and_mimetype_mapping("map", kJson);
  } else {
    s.Get("/", [](const httplib::Request&, httplib::Response& res) {
      res.status = 503;
      res.set_content(
          "The viewer page is not built: configure with node and npm installed (CHUNGS_WEB=AUTO|ON) and build the "
          "target web, or pass --web DIR. The API is served: /api/map, /api/chunk/<id>.\n",
          "text/plain");
    });
  }

  auto follower = follower_;
  s.Get("/api/map", [follower](const httplib::Request&, httplib::Response& res) {
    uint64_t version = 0;
    const auto map = follower->current(version);
    if (!map) return json_error(res, 503, "the run has not committed its first checkpoint yet");
    nlohmann::json j = map->describe();
    j["version"] = version;
    res.set_header("Cache-Control", "no-store");
    res.set_content(j.dump(), kJson);
  });

  s.Get("/api/timeline", [follower](const httplib::Request&, httplib::Response& res) {
    const auto map = follower->current();
    if (!map) return json_error(res, 503, "the run has not committed its first checkpoint yet");
    res.set_header("Cache-Control", "no-store");
    res.set_content(map->timeline_json().dump(), kJson);
  });

  // Each open stream holds one of the 32 threads: past half of them, more streams (34 curls) left no
  // thread for /api/map and the chunks until they closed.
  constexpr int kMaxEventStreams = 16;
  auto streams = std::make_shared<std::atomic<int>>(0);
  s.Get("/api/events", [follower, streams](const httplib::Request& req, httplib::Response& res) {
    uint64_t since = follower->version();
    if (req.get_param_value_count("since") > 1) return json_error(res, 400, "since is given more than once");
    if (req.has_param("since")) {
      const std::string v = req.get_param_value("since");
      if (!parse_whole(v, 0, UINT64_MAX, since))
        return json_error(res, 400, "since " + quoted(v) + " is not a version (a whole number)");
    }
    if (streams->fetch_add(1) >= kMaxEventStreams) {
      streams->fetch_sub(1);
      return json_error(res, 503, "too many open event streams (" + std::to_string(kMaxEventStreams) +
                                      "); close a viewer page and try again");
    }
    res.set_header("Cache-Control", "no-store");
    res.set_chunked_content_provider("text/event-stream", [follower, since](size_t, httplib::DataSink& sink) mutable {
      if (follower->stopped()) {
        sink.done();
        return true;
      }
      std::string text;
      for (const auto& e : follower->events_after(since, std::chrono::seconds(1))) {
        since = e["version"].get<uint64_t>();
        text += "id: " + std::to_string(since) + "\nevent: checkpoint\ndata: " + e.dump() + "\n\n";
      }
      if (text.empty()) text = ": waiting\n\n";  // also finds a client that has gone
      return sink.write(text.data(), text.size());
    }, [streams](bool) { streams->fetch_sub(1); });
  });

  s.Get(R"(/api/chunk/([^/]*))", [follower](const httplib::Request& req, httplib::Response& res) {
    const auto map = follower->current();
    if (!map) return json_error(res, 503, "the run has not committed its first checkpoint yet");
    const std::string text = req.matches[1];
    uint64_t id = 0;
    if (!parse_whole(text, 0, UINT64_MAX, id))
      return json_error(res, 400, "chunk id " + quoted(text) + " is not a decimal chunk id");
    const ChunkStore& store = map->store();
    if (!store.contains(id)) return json_error(res, 404, "chunk " + text + " is not in this map");
    int degree = store.sh_degree();
    // ?sh=0&sh=3 took the first: one value, or a clear refusal.
    if (req.get_param_value_count("sh") > 1) return json_error(res, 400, "sh is given more than once");
    if (req.has_param("sh")) {
      const std::string v = req.get_param_value("sh");
      uint64_t d = 0;
      if (!parse_whole(v, 0, 3, d)) return json_error(res, 400, "sh " + quoted(v) + " must be 0, 1, 2 or 3");
      degree = std::min(degree, int(d));
    }
    const GaussianBlock block = store.load(id);
    degree = std::min(degree, block.sh_degree);
    const Eigen::Vector3d c = chunk_centre(chunk_coord(id), store.chunk_size());
    const double origin[3] = {c.x(), c.y(), c.z()};
    const uint64_t generation = store.manifest().chunks.at(id).generation;
    res.set_header("Cache-Control", "no-store");
    res.set_content(pack_splats(block.params, degree, origin, id, generation), "application/octet-stream");
  });

  s.Get("/api/sky", [follower](const httplib::Request&, httplib::Response& res) {
    const auto map = follower->current();
    if (!map) return json_error(res, 503, "the run has not committed its first checkpoint yet");
    if (!map->sky()) return json_error(res, 404, "this map has no learned sky (sky.bin)");
    res.set_header("Cache-Control", "no-store");
    res.set_content(pack_sky(*map->sky()), "application/octet-stream");
  });

  s.Get(R"(/api/.*)", [](const httplib::Request& req, httplib::Response& res) {
    json_error(res, 404, "no such API path " + quoted(req.path) + " (there are /api/map, /api/chunk/<id>, /api/sky, /api/timeline, /api/events)");
  });

  // The library answers 400 itself for paths it refuses (.. out of the root); keep its status.
  s.set_exception_handler([](const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
    std::string what = "unknown error";
    try {
      std::rethrow_exception(ep);
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
    log::warn("viewer: ", req.path, ": ", what);
    json_error(res, 500, what);
  });
}

}  // namespace chungs::serve

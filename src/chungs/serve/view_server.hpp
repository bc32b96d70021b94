// The viewer's HTTP server (cpp-httplib) over one committed checkpoint of a map folder.
//   GET /api/map            JSON: checkpoint, chunk size, SH degree, origin, chunks (id as a decimal
//                           string, coord, min/max corners, count, generation), keyframes (id,
//                           frame, stamp, 4x4 camera-to-world pose as rows), trajectory (positions),
//                           camera (the first keyframe's intrinsics and size), sky ({width, height}
//                           of the learned sky's texture, or null) and report (report.json as the run
//                           wrote it, or null)
//   GET /api/chunk/<id>     the chunk's Gaussians packed as splat_pack.hpp lays out; ?sh=0..3 picks the
//                           SH degree (default the map's; above it, the map's)
//   GET /api/sky            the learned sky committed with the checkpoint, packed as sky_pack.hpp
//                           lays out; 404 for a map without one
//   GET /api/timeline       JSON: the run's timeline committed with the checkpoint, one array per
//                           quantity (seconds, frame, keyframes, iterations, resident, total, on_disk,
//                           rss_mb, vram_mb, loads, saves, disk_mb, wait_ms); empty arrays without one
//   GET /api/events         server-sent events, one `checkpoint` event per checkpoint the follower
//                           took (map_follower.hpp), `id` its version; ?since=V (the `version` of
//                           /api/map) replays the ones after V; a comment line every second otherwise
//   GET /...                the page's files from the web root (index.html for /)
// /api/map also carries "version": the follower's version of the snapshot it describes.
// Requests are answered on a pool of 32 threads; an open event stream keeps one of them.
// Errors are JSON {"error": "..."}: 404 for an unknown chunk or API path, 400 for a malformed id or
// query value (named in the message), 500 for a chunk that cannot be read. Paths that climb out of
// the web root find no file (404). Only GET and HEAD are served (405 otherwise, before any body is
// read); Range headers are ignored (the whole resource, 200); a NUL in the path is a 400 and more than
// 200 headers a 431. An event stream whose ?since= is ahead of this viewer's versions (it was restarted
// under an open page) gets a reload event at once.
// Not defended: slow clients. Each connection holds one of the threads while it trickles its request
// in (the library's read timeout restarts with every byte), so 32 of them leave none for others;
// the viewer listens on 127.0.0.1 unless --host says otherwise.
#pragma once
#include <atomic>
#include <filesystem>
#include <memory>
#include <string>

#include "chungs/serve/map_follower.hpp"
#include "chungs/serve/map_snapshot.hpp"

namespace httplib {
class Server;
}

namespace chungs::serve {

struct ViewServerOptions {
  std::string host = "127.0.0.1";
  int port = 8080;                  // 0: any free port (tests)
  std::filesystem::path web_root;   // the built page; empty or missing: the API alone, / explains
};

class ViewServer {
 public:
  // A map that stays as it was opened (no events).
  ViewServer(std::shared_ptr<const MapSnapshot> map, ViewServerOptions options);
  // A map followed as a run commits checkpoints (the follower's thread is the caller's to start).
  ViewServer(std::shared_ptr<MapFollower> follower, ViewServerOptions options);
  ~ViewServer();
  ViewServer(const ViewServer&) = delete;
  ViewServer& operator=(const ViewServer&) = delete;

  // Takes the port. Throws Error "cannot listen on HOST:PORT: REASON" when it is taken or the
  // address is not this machine's.
  void bind();
  int port() const { return port_; }  // the bound port (after bind)
  std::string url() const;
  // Serves until stop() (from any thread). bind() first.
  void run();
  // Ends open event streams too: stop the follower first (they end when it has stopped).
  void stop();
  bool has_page() const { return has_page_; }

 private:
  void routes();
  std::shared_ptr<MapFollower> follower_;
  ViewServerOptions options_;
  std::unique_ptr<httplib::Server> server_;
  int port_ = 0;
  bool has_page_ = false;
};

// The folder holding the built page: `explicit_root` when given (must hold index.html), else
// CHUNGS_WEB_DIR from the environment, else beside the installed binary
// (<exe>/../share/diskchungs/web), else the build tree's web/dist (compiled in). Empty when none
// holds index.html.
std::filesystem::path find_web_root(const std::filesystem::path& explicit_root = {});

}  // namespace chungs::serve

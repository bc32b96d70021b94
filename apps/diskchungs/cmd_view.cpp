// `diskchungs view MAP`: serves the browser viewer for a map folder (src/chungs/serve) until Ctrl-C,
// following the checkpoints a run beside it commits (the page hears of each through /api/events).
#include <cmath>
#include <cstdio>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <thread>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/serve/map_follower.hpp"
#include "chungs/serve/view_server.hpp"
#include "command.hpp"
#include "flag_checks.hpp"
#include "stop_signal.hpp"

namespace chungs::app {
namespace {

struct ViewArgs {
  std::string map, host = "127.0.0.1", web;
  long long port = 8080;  // signed, so that a typed -1 is refused instead of wrapped
  double follow_s = 0.5;  // 0: the checkpoint of the start only
  bool wait = false;
};

int run_view(const ViewArgs& a) {
  const StopSignal signal("");
  const std::atomic<bool>& g_stop = signal.stop();
  // A file is no map folder that a run could make: waiting for it would never end.
  if (a.wait && std::filesystem::exists(a.map) && !std::filesystem::is_directory(a.map))
    fail(a.map, ": is a file, not a map folder (--wait waits for a run's folder)");
  if (a.wait && !std::filesystem::exists(std::filesystem::path(a.map) / "manifest.txt")) {
    log::info("waiting for ", a.map, "'s first checkpoint (Ctrl-C stops)");
    while (!g_stop && !std::filesystem::exists(std::filesystem::path(a.map) / "manifest.txt"))
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (g_stop) return 0;
  }
  auto snapshot = std::make_shared<serve::MapSnapshot>(a.map);
  auto follower = std::make_shared<serve::MapFollower>(snapshot);
  serve::ViewServerOptions o;
  o.host = a.host;
  o.port = int(a.port);
  if (!a.web.empty()) {
    o.web_root = serve::find_web_root(a.web);
    if (o.web_root.empty()) fail("--web ", a.web, ": no index.html there (build the target web, or point at its dist folder)");
  }
  serve::ViewServer server(follower, o);
  server.bind();
  if (!server.has_page())
    log::warn("the viewer page is not built (node and npm at configure time, target web); serving the API only");
  std::printf("serving %s (checkpoint %llu: %zu chunks, %llu Gaussians) at %s  (Ctrl-C stops)\n", a.map.c_str(),
              (unsigned long long)snapshot->checkpoint(), snapshot->store().size(),
              (unsigned long long)snapshot->store().total_gaussians(), server.url().c_str());
  std::fflush(stdout);
  if (a.follow_s > 0) follower->start(std::chrono::milliseconds(long(a.follow_s * 1000)));
  // The handler only sets a flag; this thread turns it into a stop, asked again until the loop has
  // ended (a stop that comes before the loop has started is lost).
  std::atomic<bool> done{false};
  std::thread watcher([&] {
    while (!g_stop && !done) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    follower->stop();  // ends the event streams, which would hold the server's threads
    while (!done) {
      server.stop();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  server.run();
  done = true;
  watcher.join();
  std::printf("stopped\n");
  return 0;
}

const Command cmd{"view", "serve a map folder to the browser viewer (http://127.0.0.1:8080/ by default)",
                  [](CLI::App& app) {
  auto a = std::make_shared<ViewArgs>();
  app.add_option("map", a->map, "map folder")->required();
  app.add_option("--port", a->port, "TCP port, 1..65535 (0: any free port, printed)")->capture_default_str();
  app.add_option("--host", a->host, "address to listen on (0.0.0.0: every interface, reachable from other machines)")
      ->capture_default_str();
  app.add_option("--follow", a->follow_s,
                 "seconds between looks for a new checkpoint of a run writing the map (0: serve the one at start)")
      ->capture_default_str();
  app.add_flag("--wait", a->wait, "wait for the map's first checkpoint when the folder has none yet");
  app.add_option("--web", a->web, "folder of the built page (default: installed, else the build tree's web/dist)");
  return [a, &app]() {
    if (given(app, "--port")) require_flag(a->port >= 0 && a->port <= 65535, "--port", "in 0..65535", a->port);
    require_flag(!a->host.empty(), "--host", "an address", "''");
    // 0 is off; below 0.01 s the follower would poll the folder without a pause (30 % of a core at 1e-300).
    if (given(app, "--follow"))
      require_flag(std::isfinite(a->follow_s) && (a->follow_s == 0 || (a->follow_s >= 0.01 && a->follow_s <= 3600)),
                   "--follow", "0 (off) or in [0.01, 3600] seconds", a->follow_s);
    return run_view(*a);
  };
}};

}  // namespace
}  // namespace chungs::app

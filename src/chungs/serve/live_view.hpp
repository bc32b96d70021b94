// The viewer beside a run in the same process (`run --view`): the port is taken at once (a taken
// port fails before any mapping), the folder is followed from its first checkpoint on, and the
// server answers on threads of its own. It reads only what the run has committed, like any reader,
// so the mapper is never waited on.
#pragma once
#include <atomic>
#include <filesystem>
#include <memory>
#include <thread>

#include "chungs/serve/map_follower.hpp"
#include "chungs/serve/view_server.hpp"

namespace chungs::serve {

class LiveView {
 public:
  // Throws Error naming host:port when the port cannot be taken.
  LiveView(const std::filesystem::path& folder, ViewServerOptions options, double follow_seconds = 0.5);
  ~LiveView();  // stops following and serving
  LiveView(const LiveView&) = delete;
  LiveView& operator=(const LiveView&) = delete;
  std::string url() const { return server_->url(); }

 private:
  std::shared_ptr<MapFollower> follower_;
  std::unique_ptr<ViewServer> server_;
  std::atomic<bool> done_{false};
  std::thread thread_;
};

}  // namespace chungs::serve

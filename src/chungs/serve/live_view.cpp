#include "chungs/serve/live_view.hpp"

#include <chrono>

namespace chungs::serve {

LiveView::LiveView(const std::filesystem::path& folder, ViewServerOptions options, double follow_seconds)
    : follower_(std::make_shared<MapFollower>(folder)),
      server_(std::make_unique<ViewServer>(follower_, std::move(options))) {
  server_->bind();
  follower_->start(std::chrono::milliseconds(long(follow_seconds * 1000)));
  thread_ = std::thread([this] {
    server_->run();
    done_ = true;
  });
}

LiveView::~LiveView() {
  follower_->stop();  // ends the event streams first: they hold the server's threads
  // A stop before the server's loop has started is lost: ask until it has ended.
  while (!done_) {
    server_->stop();
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  thread_.join();
}

}  // namespace chungs::serve

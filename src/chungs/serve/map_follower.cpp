#include "chungs/serve/map_follower.hpp"

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"

namespace chungs::serve {

namespace {

constexpr size_t kKeptEvents = 256;

uint64_t checkpoint_on_disk(const std::filesystem::path& folder) {
  const Manifest m = Manifest::read(folder / "manifest.txt");
  const auto it = m.config.find("checkpoint");
  return it == m.config.end() ? 0 : std::strtoull(it->second.c_str(), nullptr, 10);
}

}  // namespace

MapFollower::MapFollower(std::shared_ptr<const MapSnapshot> first)
    : folder_(first->folder()), current_(std::move(first)) {}

MapFollower::MapFollower(std::filesystem::path folder) : folder_(std::move(folder)) {}

MapFollower::~MapFollower() { stop(); }

std::shared_ptr<const MapSnapshot> MapFollower::current() const {
  std::lock_guard lock(mutex_);
  return current_;
}

std::shared_ptr<const MapSnapshot> MapFollower::current(uint64_t& version) const {
  std::lock_guard lock(mutex_);
  version = version_;
  return current_;
}

uint64_t MapFollower::version() const {
  std::lock_guard lock(mutex_);
  return version_;
}

nlohmann::json MapFollower::difference(const MapSnapshot& before, const MapSnapshot& after) {
  const Manifest a = before.store().manifest(), b = after.store().manifest();
  nlohmann::json added = nlohmann::json::array(), changed = nlohmann::json::array(),
                 removed = nlohmann::json::array();
  for (const auto& [id, e] : b.chunks) {
    const auto it = a.chunks.find(id);
    if (it == a.chunks.end())
      added.push_back(std::to_string(id));
    else if (it->second.generation != e.generation || it->second.count != e.count)
      changed.push_back(std::to_string(id));
  }
  for (const auto& [id, e] : a.chunks)
    if (!b.chunks.count(id)) removed.push_back(std::to_string(id));
  nlohmann::json pose = nullptr;
  if (!after.keyframes().empty()) {
    const Eigen::Matrix4d m = after.keyframes().back().pose.matrix();
    pose = nlohmann::json::array();
    for (int r = 0; r < 4; ++r) pose.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  }
  return {{"checkpoint", after.checkpoint()}, {"added", added},     {"changed", changed},
          {"removed", removed},             {"pose", pose},        {"keyframes", after.keyframes().size()},
          {"total_gaussians", b.total_gaussians()}};
}

bool MapFollower::poll() {
  const auto now = current();
  try {
    if (!now) {
      if (!std::filesystem::exists(folder_ / "manifest.txt")) return false;
      auto first = std::make_shared<const MapSnapshot>(folder_);
      nlohmann::json e = {{"reload", true}, {"checkpoint", first->checkpoint()}};
      {
        std::lock_guard lock(mutex_);
        current_ = std::move(first);
        e["version"] = ++version_;
        events_.push_back(std::move(e));
      }
      changed_.notify_all();
      return true;
    }
    // The manifest is replaced (renamed over) at each commit: its time and size say when to read it.
    std::error_code ec;
    const auto file = folder_ / "manifest.txt";
    const auto stamp = std::filesystem::last_write_time(file, ec);
    const auto size = std::filesystem::file_size(file, ec);
    // Read anyway every 10th look: a file system with coarse times could hide a commit.
    if (!ec && stamp == seen_time_ && size == seen_size_ && ++unread_looks_ < 10) return false;
    unread_looks_ = 0;
    seen_time_ = stamp;
    seen_size_ = size;
    if (checkpoint_on_disk(folder_) == now->checkpoint()) return false;
    auto next = std::make_shared<const MapSnapshot>(folder_);
    if (next->checkpoint() == now->checkpoint()) return false;
    nlohmann::json e = difference(*now, *next);
    {
      std::lock_guard lock(mutex_);
      current_ = std::move(next);
      e["version"] = ++version_;
      events_.push_back(std::move(e));
      if (events_.size() > kKeptEvents) events_.pop_front();
      last_error_.clear();
    }
    changed_.notify_all();
    return true;
  } catch (const Error& e) {
    seen_size_ = ~uintmax_t(0);  // look again next time
    // A checkpoint being written, or a manifest replaced between looking and reading: next time.
    std::lock_guard lock(mutex_);
    if (last_error_ != e.what()) log::debug("viewer: the map's next checkpoint is not readable yet: ", e.what());
    last_error_ = e.what();
    return false;
  }
}

void MapFollower::start(std::chrono::milliseconds interval) {
  thread_ = std::thread([this, interval] {
    std::unique_lock lock(mutex_);
    while (!stop_) {
      lock.unlock();
      poll();
      lock.lock();
      changed_.wait_for(lock, interval, [this] { return stop_; });
    }
  });
}

void MapFollower::stop() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  if (thread_.joinable()) thread_.join();
}

bool MapFollower::stopped() const {
  std::lock_guard lock(mutex_);
  return stop_;
}

std::vector<nlohmann::json> MapFollower::events_after(uint64_t version, std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  std::vector<nlohmann::json> out;
  // A page that knew a later version than this viewer has (the viewer was restarted under it, its
  // versions from 0 again) would wait for versions that mean other checkpoints: it reloads the map.
  if (version > version_) {
    out.push_back({{"version", version_}, {"reload", true}});
    return out;
  }
  changed_.wait_for(lock, timeout, [&] { return stop_ || version_ > version; });
  if (version_ <= version) return out;
  if (events_.empty() || events_.front()["version"].get<uint64_t>() > version + 1) {
    out.push_back({{"version", version_}, {"reload", true}});
    return out;
  }
  for (const auto& e : events_)
    if (e["version"].get<uint64_t>() > version) out.push_back(e);
  return out;
}

}  // namespace chungs::serve

#include "chungs/datasets/mono_view.hpp"

#include "chungs/common/error.hpp"

namespace chungs {
namespace {

class MonoView : public Dataset {
 public:
  explicit MonoView(std::unique_ptr<Dataset> inner) : inner_(std::move(inner)), info_(inner_->info()) {
    info_.has_right = false;
    info_.has_depth = false;
    info_.baseline = 0;
  }
  const DatasetInfo& info() const override { return info_; }
  Frame frame(size_t i) const override {
    Frame f = inner_->frame(i);
    f.right.reset();
    f.depth.reset();
    f.baseline = 0;
    return f;
  }
  double timestamp(size_t i) const override { return inner_->timestamp(i); }
  std::optional<SE3> gt_pose(size_t i) const override { return inner_->gt_pose(i); }

 private:
  std::unique_ptr<Dataset> inner_;
  DatasetInfo info_;
};

}  // namespace

InputMode parse_input_mode(const std::string& s) {
  if (s == "auto") return InputMode::Auto;
  if (s == "mono") return InputMode::Mono;
  fail("input mode '", s, "': expected auto (everything the dataset has) or mono (its left camera only)");
}

std::unique_ptr<Dataset> with_input_mode(std::unique_ptr<Dataset> dataset, InputMode mode) {
  if (mode == InputMode::Auto) return dataset;
  return std::make_unique<MonoView>(std::move(dataset));
}

}  // namespace chungs

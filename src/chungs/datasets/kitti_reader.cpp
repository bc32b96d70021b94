// KITTI odometry: a sequence folder with a rectified stereo pair of image folders, calib.txt
// (projection matrices) and optional times.txt; poses in the folder or in the standard
// poses/NN.txt beside sequences/NN.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>

#include "chungs/common/log.hpp"
#include "chungs/common/text_file.hpp"
#include "chungs/datasets/reader_common.hpp"
#include "chungs/datasets/readers.hpp"

namespace chungs::ds {

namespace {

using Projection = Eigen::Matrix<double, 3, 4>;

// Which image folders hold the pair, and which projection matrices (P0..P3) describe them.
struct Layout {
  const char* left;
  const char* right;
  int p_left, p_right;
};

Layout find_layout(const fs::path& dir) {
  static const Layout layouts[] = {
      {"image_0", "image_1", 0, 1}, {"image_2", "image_3", 2, 3}, {"image_l", "image_r", 0, 1}};
  std::error_code ec;
  for (const auto& l : layouts)
    if (fs::is_directory(dir / l.left, ec)) return l;
  fail(dir.string(), ": not a KITTI sequence (no image_0/image_1, image_2/image_3 or image_l/image_r folders)");
}

// calib.txt lines are "P0: 12 numbers" (other labels such as Tr: are ignored) or, in some exports,
// unlabelled rows of 12 numbers taken as P0, P1, ... in order.
Projection read_projection(const fs::path& file, int index, int* line_number) {
  auto lines = read_text_table(file);
  int unlabelled = 0;
  const std::string want = cat("P", index);
  for (const auto& l : lines) {
    std::string label;
    size_t first = 0;
    if (l.tokens[0].back() == ':') {
      label = l.tokens[0].substr(0, l.tokens[0].size() - 1);
      first = 1;
    } else {
      label = cat("P", unlabelled++);
    }
    if (label != want) continue;
    if (l.tokens.size() != first + 12) l.fail_here(cat("projection ", want, " needs 12 numbers, found ", l.tokens.size() - first));
    Projection p;
    for (int k = 0; k < 12; ++k) p(k / 4, k % 4) = l.number_at(first + size_t(k));
    if (!(p(0, 0) > 0 && p(1, 1) > 0)) l.fail_here(cat("focal lengths of ", want, " must be positive"));
    if (p(2, 0) != 0 || p(2, 1) != 0 || p(2, 2) != 1)
      l.fail_here(cat(want, " is not a rectified projection (third row must start 0 0 1)"));
    *line_number = l.number;
    return p;
  }
  fail(file.string(), ": no projection matrix ", want, " (expected a line '", want, ": ...' or ", index + 1,
       " unlabelled lines of 12 numbers)");
}

// The reader gives both images the left camera and turns disparity into depth with its fx: a pair
// whose projections differ in K is not rectified as one (the baseline would be wrong, silently).
// calib.txt prints about 10 digits, so a relative difference beyond 1e-6 is another camera.
void require_shared_camera(const fs::path& calib, const Layout& layout, const Projection& pl,
                           const Projection& pr, int line_r) {
  static const struct {
    const char* name;
    int row, col;
  } entries[] = {{"fx", 0, 0}, {"fy", 1, 1}, {"cx", 0, 2}, {"cy", 1, 2}};
  for (const auto& e : entries) {
    const double l = pl(e.row, e.col), r = pr(e.row, e.col);
    if (std::abs(l - r) > 1e-6 * std::max(std::abs(l), std::abs(r)))
      fail(calib.string(), ":", line_r, ": P", layout.p_right, "'s ", e.name, " ", std::setprecision(10), r,
           " differs from P", layout.p_left, "'s ", l, "; a rectified stereo pair shares one camera matrix");
  }
}

// times.txt: one stamp in seconds per line, increasing.
std::vector<double> read_times(const fs::path& file, size_t frames) {
  auto lines = read_text_table(file);
  if (lines.size() < frames) fail(file.string(), ": ", lines.size(), " timestamps for ", frames, " images");
  std::vector<double> t(frames);
  for (size_t i = 0; i < frames; ++i) {
    lines[i].expect_fields(1);
    t[i] = lines[i].number_at(0);
    if (t[i] < 0) lines[i].fail_here(cat("timestamp ", t[i], " is negative"));
    if (i > 0 && !(t[i] > t[i - 1])) lines[i].fail_here(cat("timestamp ", t[i], " does not increase"));
  }
  return t;
}

// The sequence folder, also when given one of its image folders (SEQ/image_0).
fs::path kitti_sequence(const fs::path& given) {
  const fs::path named = named_folder(given);
  for (const char* images : {"image_0", "image_1", "image_2", "image_3", "image_l", "image_r"})
    if (named.filename() == images && named.has_parent_path() && fs::exists(named.parent_path() / "calib.txt"))
      return named.parent_path();
  return given;
}

class KittiDataset : public SequenceDataset {
 public:
  explicit KittiDataset(const fs::path& given) {
    const fs::path dir = kitti_sequence(given);
    info_.kind = "kitti";
    info_.path = dir;
    Layout layout = find_layout(dir);
    left_ = list(dir / layout.left);
    right_ = list(dir / layout.right);
    check_pairs(dir / layout.left, dir / layout.right);

    fs::path calib = dir / "calib.txt";
    require_file(calib, "KITTI calibration");
    int line_l = 0, line_r = 0;
    Projection pl = read_projection(calib, layout.p_left, &line_l);
    Projection pr = read_projection(calib, layout.p_right, &line_r);
    require_shared_camera(calib, layout, pl, pr, line_r);
    // Rectified projections are K [I | t]: camera centres sit at -t in camera 0's frame, all
    // cameras share one orientation, and the baseline is the x distance between the centres.
    info_.baseline = offset(pl).x() - offset(pr).x();
    if (!(info_.baseline > 0))
      fail(calib.string(), ":", line_r, ": right camera gives a baseline of ", info_.baseline,
           " m; it must be positive (right camera to the right of the left one)");
    info_.has_right = true;

    Image8 first = load_image(left_[0]);  // sets the size every other image must have
    info_.camera = Camera(first.width(), first.height(), pl(0, 0), pl(1, 1), pl(0, 2), pl(1, 2));
    info_.color = first.channels() == 3;
    channels_ = first.channels();
    info_.rate_hz = 10;

    std::vector<double> stamps(left_.size());
    if (auto times = first_existing({dir / "times.txt"})) {
      stamps = read_times(*times, left_.size());
      if (stamps.size() > 1) info_.rate_hz = double(stamps.size() - 1) / (stamps.back() - stamps.front());
    } else {
      for (size_t i = 0; i < stamps.size(); ++i) stamps[i] = double(i) / info_.rate_hz;
    }
    finish(stamps, read_gt(dir, pl));
  }

  Frame frame(size_t i) const override {
    check_index(i);
    Frame f = frame_header(i, left_[i]);
    const Camera& c = info_.camera;
    f.left = load_image(left_[i], c.width, c.height, channels_);
    f.right = load_image(right_[i], c.width, c.height, channels_);
    return f;
  }

 private:
  static std::vector<fs::path> list(const fs::path& folder) {
    std::vector<fs::path> out;
    for (auto& [n, p] : numbered_files(folder, "", ".png")) out.push_back(p);
    if (out.empty()) fail(folder.string(), ": no numbered .png images");
    return out;
  }

  void check_pairs(const fs::path& lf, const fs::path& rf) const {
    if (left_.size() != right_.size())
      fail(info_.path.string(), ": ", lf.filename().string(), " has ", left_.size(), " images but ",
           rf.filename().string(), " has ", right_.size(), "; stereo pairs must match");
    for (size_t i = 0; i < left_.size(); ++i)
      if (left_[i].filename() != right_[i].filename())
        fail(right_[i].string(), ": right image does not match left image ", left_[i].filename().string());
  }

  // t in P = K [I | t].
  static Eigen::Vector3d offset(const Projection& p) {
    Eigen::Matrix3d K = p.leftCols<3>();
    return K.inverse() * p.col(3);
  }

  // Ground truth describes camera 0; a colour pair (cameras 2/3) sits beside it, shifted by the
  // offset in its projection matrix.
  std::vector<std::optional<SE3>> read_gt(const fs::path& dir, const Projection& pl) const {
    auto file = first_existing({dir / "poses.txt", dir.parent_path().parent_path() / "poses" /
                                                       (dir.filename().string() + ".txt")});
    if (!file) {
      log::info(dir.string(), ": no poses.txt or ../../poses/", dir.filename().string(), ".txt; no ground truth");
      return {};
    }
    Trajectory tr = read_kitti_trajectory(*file);
    if (tr.size() < left_.size())
      fail(file->string(), ": ", tr.size(), " poses for ", left_.size(), " images");
    // An excerpt of a sequence beside its whole pose file is a fair use; a folder that lost images is not,
    // and only the counts tell them apart: say so.
    if (tr.size() > left_.size())
      log::warn(file->string(), ": ", tr.size(), " poses for ", left_.size(), " images; the first ", left_.size(),
                " are taken as theirs (an excerpt from the start of a longer sequence)");
    SE3 cam0_to_left(Eigen::Matrix3d::Identity(), -offset(pl));
    std::vector<std::optional<SE3>> gt(left_.size());
    for (size_t i = 0; i < gt.size(); ++i) gt[i] = tr.poses[i] * cam0_to_left;
    return gt;
  }

  std::vector<fs::path> left_, right_;
  int channels_ = 1;
};

}  // namespace

std::unique_ptr<Dataset> open_kitti(const fs::path& path) { return std::make_unique<KittiDataset>(path); }

}  // namespace chungs::ds

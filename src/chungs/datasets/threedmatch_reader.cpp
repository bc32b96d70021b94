// 3DMatch RGB-D: SEQ/frame-NNNNNN.color.png, .depth.png (uint16 millimetres), .pose.txt (4x4
// camera-to-world), and camera-intrinsics.txt (3x3) in SEQ or its parent. The path may be SEQ or
// the scene folder holding exactly one sequence. Frame numbers need not be contiguous.
#include <algorithm>

#include "chungs/common/log.hpp"
#include "chungs/datasets/reader_common.hpp"
#include "chungs/datasets/readers.hpp"

namespace chungs::ds {

namespace {

constexpr double kRateHz = 30;  // the Kinect/Structure sensors 3DMatch was captured with
constexpr double kDepthUnitsPerMetre = 1000;
const char* const kPrefix = "frame-";
const char* const kColour = ".color.png";

bool has_frames(const fs::path& dir) { return !numbered_files(dir, kPrefix, kColour).empty(); }

fs::path find_sequence(const fs::path& path) {
  if (has_frames(path)) return path;
  std::vector<fs::path> seqs;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(path, ec))
    if (e.is_directory() && has_frames(e.path())) seqs.push_back(e.path());
  std::sort(seqs.begin(), seqs.end());
  if (seqs.empty()) fail(path.string(), ": no frame-NNNNNN.color.png here or in a subfolder; not a 3DMatch sequence");
  if (seqs.size() > 1)
    fail(path.string(), ": ", seqs.size(), " sequences inside (", seqs[0].filename().string(), ", ",
         seqs[1].filename().string(), ", ...); name one of them");
  return seqs[0];
}

Camera read_intrinsics(const fs::path& file) {
  Eigen::MatrixXd K = read_matrix(file, 3, 3);
  if (K(1, 0) != 0 || K(2, 0) != 0 || K(2, 1) != 0 || K(2, 2) != 1)
    fail(file.string(), ": not a pinhole camera matrix (expected rows 'fx 0 cx', '0 fy cy', '0 0 1')");
  Camera c;
  c.fx = require_positive(K(0, 0), file, "fx");
  c.fy = require_positive(K(1, 1), file, "fy");
  c.cx = K(0, 2);
  c.cy = K(1, 2);
  return c;
}

class ThreeDMatchDataset : public SequenceDataset {
 public:
  explicit ThreeDMatchDataset(const fs::path& path) {
    require_dir(path, "3DMatch folder");
    fs::path dir = find_sequence(path);
    info_.kind = "3dmatch";
    info_.path = dir;
    auto intr = first_existing({dir / "camera-intrinsics.txt", dir.parent_path() / "camera-intrinsics.txt"});
    if (!intr) fail(dir.string(), ": camera-intrinsics.txt is missing (looked here and in the parent folder)");
    Camera cam = read_intrinsics(*intr);

    auto frames = numbered_files(dir, kPrefix, kColour);
    // Ground truth is all or nothing: a pose file missing in the middle of a posed sequence is damage.
    bool posed = false;
    for (const auto& [n, file] : frames) posed = posed || fs::exists(sibling(file, ".pose.txt"));
    std::vector<double> stamps;
    std::vector<std::optional<SE3>> gt;
    for (const auto& [n, file] : frames) {
      fs::path depth = sibling(file, ".depth.png");
      require_file(depth, "3DMatch depth image");
      colour_.push_back(file);
      depth_.push_back(depth);
      stamps.push_back(double(n) / kRateHz);
      if (posed) {
        fs::path pose = sibling(file, ".pose.txt");
        require_file(pose, "3DMatch pose file");
        gt.push_back(SE3::from_matrix(Eigen::Matrix4d(read_matrix(pose, 4, 4)), pose.string().c_str()));
      }
    }
    if (!posed) log::info(dir.string(), ": no frame-*.pose.txt files; no ground truth");

    Image8 first = load_image(colour_[0]);
    cam.width = first.width();
    cam.height = first.height();
    cam.validate(intr->string());
    channels_ = first.channels();
    info_.camera = cam;
    info_.has_depth = true;
    info_.color = channels_ == 3;
    info_.rate_hz = kRateHz;
    finish(stamps, gt);
  }

  Frame frame(size_t i) const override {
    check_index(i);
    Frame f = frame_header(i, colour_[i]);
    const Camera& c = info_.camera;
    f.left = load_image(colour_[i], c.width, c.height, channels_);
    f.depth = load_depth(depth_[i], kDepthUnitsPerMetre, c.width, c.height);
    return f;
  }

 private:
  // frame-000001.color.png -> frame-000001<ext>
  static fs::path sibling(const fs::path& colour, const std::string& ext) {
    std::string name = colour.filename().string();
    return colour.parent_path() / (name.substr(0, name.size() - std::string(kColour).size()) + ext);
  }

  std::vector<fs::path> colour_, depth_;
  int channels_ = 3;
};

}  // namespace

std::unique_ptr<Dataset> open_3dmatch(const fs::path& path) { return std::make_unique<ThreeDMatchDataset>(path); }

}  // namespace chungs::ds

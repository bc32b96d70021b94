#include "chungs/synth/writers.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/image/image_io.hpp"

namespace chungs::synth {
namespace fs = std::filesystem;

Layout parse_layout(const std::string& name) {
  if (name == "tum") return Layout::Tum;
  if (name == "kitti") return Layout::Kitti;
  fail("unknown layout '", name, "' (expected tum or kitti)");
}

const char* layout_name(Layout l) { return l == Layout::Tum ? "tum" : "kitti"; }

Image16 encode_depth(const ImageF& depth, double scale) {
  Image16 out(depth.width(), depth.height(), 1);
  const float* d = depth.data();
  uint16_t* o = out.data();
  for (size_t i = 0; i < out.size(); ++i) {
    const double v = std::round(double(d[i]) * scale);
    o[i] = (d[i] > 0 && v >= 1 && v <= 65535) ? uint16_t(v) : 0;
  }
  return out;
}

namespace {

std::ofstream open_text(const fs::path& file) {
  std::ofstream out(file);
  if (!out) fail(file, ": cannot open for writing");
  return out;
}

void close_text(std::ofstream& out, const fs::path& file) {
  out.close();
  if (!out) fail(file, ": write failed");
}

// The first line of every sequence's camera.txt (write_camera_txt): what marks a folder as one of ours.
constexpr const char* kCameraHeader = "# synthetic pinhole camera";

// A sequence goes into a new or empty folder, or over an earlier sequence. Written into a real dataset
// (--out kitti_seq1), it replaced calib.txt and poses.txt and left the dataset's own images beside its
// frames: a mixed dataset, the real one hidden.
void claim_folder(const fs::path& out) {
  std::error_code ec;
  if (!fs::exists(out, ec)) return;
  if (!fs::is_directory(out, ec)) fail(out.string(), ": is not a folder; a synthetic sequence is written into one");
  if (fs::is_empty(out, ec)) return;
  std::ifstream camera(out / "camera.txt");
  std::string first;
  if (camera && std::getline(camera, first) && first.rfind(kCameraHeader, 0) == 0) return;
  fail(out.string(), " holds files of something other than a synthetic sequence (no camera.txt of one); give a new "
       "or empty folder");
}

// Creates `dir` and removes the PNG frames an earlier run left there: a shorter new sequence must
// not be read back with the old one's tail.
void prepare_frame_dir(const fs::path& dir) {
  fs::create_directories(dir);
  size_t removed = 0;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && e.path().extension() == ".png") removed += fs::remove(e.path()) ? 1 : 0;
  if (removed) log::warn(dir.string(), ": replaced ", removed, " frames of an earlier sequence");
}

// A frame's file name in the TUM layout: its stamp to the microsecond. Beyond 1e15 s the name would no
// longer tell microseconds apart (and 1e300 overflowed the name).
std::string stamp_name(size_t index, double t) {
  if (!(std::abs(t) < 1e15)) fail("frame ", index, ": stamp ", t, " s cannot name its file (|stamp| < 1e15 s)");
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6f", t);
  return buf;
}

class TumWriter : public SequenceWriter {
 public:
  TumWriter(fs::path out, const Camera& cam) : out_(std::move(out)), cam_(cam) {
    claim_folder(out_);
    prepare_frame_dir(out_ / "rgb");
    // First, so that a run stopped midway leaves a folder the next run recognises (claim_folder).
    write_camera_txt(out_ / "camera.txt", cam_, 0, kTumDepthScale);
    prepare_frame_dir(out_ / "depth");
  }
  void add(const FrameOut& f) override {
    if (!f.left) fail("TUM writer: frame ", f.index, " has no colour image");
    const std::string name = stamp_name(f.index, f.stamp) + ".png";
    // Stamps closer than a microsecond name the same file: the later frame would replace the earlier.
    if (!rgb_.empty() && rgb_.back() == name)
      fail("frames ", f.index - 1, " and ", f.index, " have stamps ", traj_.stamps.back(), " and ", f.stamp,
           " s, which name the same file ", name, " (stamps must differ by a microsecond or more)");
    write_png(out_ / "rgb" / name, *f.left);
    rgb_.push_back(name);
    if (f.depth) {
      write_png(out_ / "depth" / name, encode_depth(*f.depth, kTumDepthScale));
      depth_.push_back(name);
    }
    traj_.push_back(f.stamp, f.pose);
  }
  void finish() override {
    auto list = [&](const char* file, const char* what, const char* dir, const std::vector<std::string>& names) {
      const fs::path p = out_ / file;
      auto o = open_text(p);
      o << "# " << what << " images\n# file: 'synthetic (diskchungs synth)'\n# timestamp filename\n";
      for (const auto& n : names) o << n.substr(0, n.size() - 4) << ' ' << dir << '/' << n << '\n';
      close_text(o, p);
    };
    list("rgb.txt", "color", "rgb", rgb_);
    list("depth.txt", "depth", "depth", depth_);
    write_tum_trajectory(out_ / "groundtruth.txt", traj_);
    // The TUM reader's intrinsics override, so that any synthetic camera reads back as written.
    const fs::path calib = out_ / "calib.txt";
    auto c = open_text(calib);
    c << std::setprecision(17) << cam_.fx << ' ' << cam_.fy << ' ' << cam_.cx << ' ' << cam_.cy << '\n';
    close_text(c, calib);
  }

 private:
  fs::path out_;
  Camera cam_;
  std::vector<std::string> rgb_, depth_;
  Trajectory traj_;
};

class KittiWriter : public SequenceWriter {
 public:
  KittiWriter(fs::path out, const Camera& cam, double baseline, bool depth)
      : out_(std::move(out)), cam_(cam), baseline_(baseline), depth_(depth) {
    claim_folder(out_);
    prepare_frame_dir(out_ / "image_2");
    prepare_frame_dir(out_ / "image_3");
    if (depth_) prepare_frame_dir(out_ / "depth");
    else if (fs::is_directory(out_ / "depth")) prepare_frame_dir(out_ / "depth");
    write_camera_txt(out_ / "camera.txt", cam_, baseline_, depth_ ? kKittiDepthScale : 0);  // first: see TumWriter
  }
  void add(const FrameOut& f) override {
    if (!f.left || !f.right) fail("KITTI writer: frame ", f.index, " needs a left and a right image");
    char name[32];
    std::snprintf(name, sizeof name, "%06zu.png", f.index);
    write_png(out_ / "image_2" / name, *f.left);
    write_png(out_ / "image_3" / name, *f.right);
    if (depth_ && f.depth) write_png(out_ / "depth" / name, encode_depth(*f.depth, kKittiDepthScale));
    traj_.push_back(f.stamp, f.pose);
  }
  void finish() override {
    const fs::path calib = out_ / "calib.txt";
    auto c = open_text(calib);
    char buf[512];
    for (int i = 0; i < 4; ++i) {
      const double tx = (i == 1 || i == 3) ? -cam_.fx * baseline_ : 0.0;
      std::snprintf(buf, sizeof buf, "P%d: %.12e %.12e %.12e %.12e %.12e %.12e %.12e %.12e %.12e %.12e %.12e %.12e\n", i,
                    cam_.fx, 0.0, cam_.cx, tx, 0.0, cam_.fy, cam_.cy, 0.0, 0.0, 0.0, 1.0, 0.0);
      c << buf;
    }
    close_text(c, calib);
    const fs::path times = out_ / "times.txt";
    auto t = open_text(times);
    for (double s : traj_.stamps) {
      std::snprintf(buf, sizeof buf, "%.6e\n", s);
      t << buf;
    }
    close_text(t, times);
    write_kitti_trajectory(out_ / "poses.txt", traj_);
  }

 private:
  fs::path out_;
  Camera cam_;
  double baseline_;
  bool depth_;
  Trajectory traj_;
};

}  // namespace

std::unique_ptr<SequenceWriter> make_tum_writer(const fs::path& out, const Camera& cam) {
  return std::make_unique<TumWriter>(out, cam);
}

std::unique_ptr<SequenceWriter> make_kitti_writer(const fs::path& out, const Camera& cam, double baseline,
                                                  bool write_depth) {
  return std::make_unique<KittiWriter>(out, cam, baseline, write_depth);
}

void write_camera_txt(const fs::path& file, const Camera& cam, double baseline, double depth_scale) {
  auto o = open_text(file);
  o << kCameraHeader << ", no distortion; pixel centres at integer coordinates\n"
    << "# fx fy cx cy width height baseline_m depth_scale\n";
  char buf[256];
  std::snprintf(buf, sizeof buf, "%.9g %.9g %.9g %.9g %d %d %.9g %.9g\n", cam.fx, cam.fy, cam.cx, cam.cy, cam.width,
                cam.height, baseline, depth_scale);
  o << buf;
  close_text(o, file);
}

}  // namespace chungs::synth

// Writers of rendered sequences in the on-disk layouts the dataset readers load.
//
// TUM RGB-D: rgb/<t>.png, depth/<t>.png (uint16, metres * 5000), rgb.txt, depth.txt,
//   groundtruth.txt (t tx ty tz qx qy qz qw), calib.txt ("fx fy cx cy", the reader's intrinsics
//   override) and camera.txt (intrinsics, size and depth scale, for people).
// KITTI odometry: image_2/NNNNNN.png and image_3/NNNNNN.png (colour, left/right), calib.txt (P0..P3,
//   row-major 3x4; P1 and P3 hold -fx * baseline), times.txt, poses.txt (3x4 camera-to-world of the
//   left camera), optionally depth/NNNNNN.png (uint16, metres * 256, the KITTI depth convention).
#pragma once
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/trajectory.hpp"
#include "chungs/image/image.hpp"

namespace chungs::synth {

enum class Layout { Tum, Kitti };
Layout parse_layout(const std::string& name);  // "tum" | "kitti"; throws Error otherwise
const char* layout_name(Layout l);

constexpr double kTumDepthScale = 5000.0;
constexpr double kKittiDepthScale = 256.0;

// Metres -> uint16 depth image; 0 (and values that do not fit) become 0 = invalid.
Image16 encode_depth(const ImageF& depth, double scale);

struct FrameOut {
  size_t index = 0;
  double stamp = 0;
  SE3 pose;                      // left camera-to-world
  const Image8* left = nullptr;  // RGB
  const Image8* right = nullptr; // RGB, KITTI layout
  const ImageF* depth = nullptr; // metres
};

class SequenceWriter {
 public:
  virtual ~SequenceWriter() = default;
  virtual void add(const FrameOut& f) = 0;
  // Writes the index and trajectory files. Frames written so far stay valid without it.
  virtual void finish() = 0;
};

std::unique_ptr<SequenceWriter> make_tum_writer(const std::filesystem::path& out, const Camera& cam);
std::unique_ptr<SequenceWriter> make_kitti_writer(const std::filesystem::path& out, const Camera& cam,
                                                  double baseline, bool write_depth);

// Writes camera.txt: a commented "fx fy cx cy width height [baseline]" line.
void write_camera_txt(const std::filesystem::path& file, const Camera& cam, double baseline, double depth_scale);

}  // namespace chungs::synth

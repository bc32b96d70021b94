// Scoring a set of rendered images against references: files paired by name across two folders
// (or one file against one file), PSNR / SSIM (and LPIPS, given its weights) per pair and their means.
#pragma once
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "chungs/eval/image_metrics.hpp"
#include "chungs/eval/lpips.hpp"

namespace chungs {

struct ImagePair {
  std::string name;  // file stem shared by both
  std::filesystem::path ref, test;
};

// Which images of a folder a pairing wants: where a folder holds both, depth images are told by
// "depth" in their names (3DMatch, Replica); Any takes every image.
enum class ImageRole { Any, Colour, Depth };

// Two files: one pair. Two folders: the PNG / JPEG files of each (not recursive) of the role, paired
// by stem, so frame000.jpg matches a render frame000.png. A stem present on one side only, two files
// with one stem in a folder, an empty folder, or a file against a folder is an Error naming the path.
std::vector<ImagePair> match_image_pairs(const std::filesystem::path& ref, const std::filesystem::path& test,
                                         ImageRole role = ImageRole::Any);

// A mask file (PNG / JPEG): a pixel is kept when any of its channels is non-zero.
Image8 read_mask(const std::filesystem::path& file);

struct ImagePairResult {
  ImagePair pair;
  ImageMetrics metrics;
  std::optional<double> lpips;  // only where LPIPS weights were given
};

struct ImageSetResult {
  std::vector<ImagePairResult> images;
  // Means over pairs of the per-image values (as 3DGS papers average PSNR per image). The PSNR
  // mean is +inf when any pair is identical; infinite_psnr counts those pairs.
  double mean_psnr = 0.0, mean_ssim = 0.0, mean_mse = 0.0;
  size_t infinite_psnr = 0;
  std::optional<double> mean_lpips;
  std::string lpips_unavailable;  // why mean_lpips is absent
};

// Reads each pair (8-bit, alpha dropped) and scores it; a size or channel mismatch is an Error
// naming both files. The mask, when given, must match every image's size. LPIPS is scored where
// `lpips` holds a metric; it has no masked form, so a mask with LPIPS is an Error.
ImageSetResult evaluate_image_pairs(const std::vector<ImagePair>& pairs, const Image8* mask = nullptr,
                                    const SsimOptions& ssim_opt = {}, const LpipsSetting* lpips = nullptr);

}  // namespace chungs

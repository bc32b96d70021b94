#include "chungs/eval/image_set.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/common/progress.hpp"
#include "chungs/image/image_io.hpp"

namespace chungs {

namespace fs = std::filesystem;

namespace {

bool is_image_file(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg";
}

std::map<std::string, fs::path> images_by_stem(const fs::path& dir) {
  std::map<std::string, fs::path> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!is_image_file(e.path())) continue;
    // Named like an image but a FIFO, a device or a folder: refused by its name (it used to be
    // skipped, and its partner then reported the image as missing).
    require_file(e.path(), "PNG or JPEG image");
    auto [it, fresh] = out.emplace(e.path().stem().string(), e.path());
    if (!fresh) fail(e.path().string(), ": same name as ", it->second.string(), " (pairs are matched by name)");
  }
  if (out.empty()) fail(dir.string(), ": no PNG or JPEG images in this folder");
  return out;
}

bool named_depth(const std::string& stem) {
  std::string s = stem;
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s.find("depth") != std::string::npos;
}

// A sequence folder holding colour and depth side by side (3DMatch's frame-N.color.png and
// frame-N.depth.png, Replica's frameN.jpg and depthN.png): the role's files only, by their names.
std::map<std::string, fs::path> images_for(const fs::path& dir, ImageRole role) {
  std::map<std::string, fs::path> all = images_by_stem(dir);
  if (role == ImageRole::Any) return all;
  size_t depth = 0;
  for (const auto& [stem, path] : all) depth += named_depth(stem);
  if (depth == 0 || depth == all.size()) return all;
  std::map<std::string, fs::path> kept;
  for (const auto& [stem, path] : all)
    if (named_depth(stem) == (role == ImageRole::Depth)) kept.emplace(stem, path);
  log::info(dir.string(), ": ", kept.size(), role == ImageRole::Depth ? " depth images" : " colour images",
            " (named", role == ImageRole::Depth ? "" : " without", " 'depth'); ", all.size() - kept.size(),
            " others left out");
  return kept;
}

// Keeps colour channels only: an alpha channel is not part of the photometric comparison.
Image8 drop_alpha(Image8 img) {
  if (img.channels() == 4 || img.channels() == 2) {
    const int keep = img.channels() - 1;
    Image8 out(img.width(), img.height(), keep);
    for (size_t i = 0; i < img.pixels(); ++i)
      for (int c = 0; c < keep; ++c) out.data()[i * keep + c] = img.data()[i * img.channels() + c];
    return out;
  }
  return img;
}

}  // namespace

std::vector<ImagePair> match_image_pairs(const fs::path& ref, const fs::path& test, ImageRole role) {
  if (!fs::exists(ref)) fail(ref.string(), ": does not exist");
  if (!fs::exists(test)) fail(test.string(), ": does not exist");
  const bool ref_dir = fs::is_directory(ref), test_dir = fs::is_directory(test);
  if (ref_dir != test_dir)
    fail(ref_dir ? test.string() : ref.string(), ": is a file but ", ref_dir ? ref.string() : test.string(),
         " is a folder (give two files or two folders)");
  if (!ref_dir) return {ImagePair{test.stem().string(), ref, test}};

  const auto refs = images_for(ref, role), tests = images_for(test, role);
  std::vector<ImagePair> pairs;
  for (const auto& [stem, path] : refs) {
    auto it = tests.find(stem);
    if (it == tests.end()) fail((test / stem).string(), ".*: missing (reference ", path.string(), ")");
    pairs.push_back({stem, path, it->second});
  }
  for (const auto& [stem, path] : tests)
    if (!refs.count(stem)) fail((ref / stem).string(), ".*: missing (test image ", path.string(), ")");
  return pairs;
}

Image8 read_mask(const fs::path& file) {
  const Image8 img = read_image8(file);
  Image8 mask(img.width(), img.height(), 1);
  for (size_t i = 0; i < img.pixels(); ++i) {
    bool any = false;
    for (int c = 0; c < img.channels(); ++c) any |= img.data()[i * img.channels() + c] != 0;
    mask.data()[i] = any ? 255 : 0;
  }
  return mask;
}

ImageSetResult evaluate_image_pairs(const std::vector<ImagePair>& pairs, const Image8* mask,
                                    const SsimOptions& ssim_opt, const LpipsSetting* lpips) {
  if (pairs.empty()) fail("image evaluation: no image pairs");
  const Lpips* metric = lpips && lpips->metric ? &*lpips->metric : nullptr;
  if (metric && mask)
    fail(metric->source(), ": LPIPS has no masked form; score it without a mask (PSNR and SSIM are the same "
                           "either way outside the mask)");
  ImageSetResult res;
  res.lpips_unavailable = metric ? "" : lpips ? lpips->unavailable : "LPIPS not requested";
  Progress progress("eval images", (long long)pairs.size());
  double sum_psnr = 0, sum_ssim = 0, sum_mse = 0, sum_lpips = 0;
  for (const auto& p : pairs) {
    const Image8 ref = drop_alpha(read_image8(p.ref));
    const Image8 test = drop_alpha(read_image8(p.test));
    if (!ref.same_shape(test))
      fail(p.test.string(), ": ", test.width(), "x", test.height(), "x", test.channels(), " differs from reference ",
           p.ref.string(), " (", ref.width(), "x", ref.height(), "x", ref.channels(), ")");
    if (mask && !mask->same_size(ref))
      fail(p.ref.string(), ": ", ref.width(), "x", ref.height(), " differs from the mask's ", mask->width(), "x",
           mask->height());
    ImageMetrics m;
    std::optional<double> d;
    try {
      m = compare_images(ref, test, mask, ssim_opt);
      if (metric) d = metric->distance(to_float(ref), to_float(test));
    } catch (const Error& e) {
      fail(p.test.string(), ": ", e.what());
    }
    if (d) sum_lpips += *d;
    if (std::isinf(m.psnr)) ++res.infinite_psnr;
    log::debug(p.name, ": PSNR ", m.psnr, " SSIM ", m.ssim);
    sum_psnr += m.psnr, sum_ssim += m.ssim, sum_mse += m.mse;
    res.images.push_back({p, m, d});
    progress.step();
  }
  progress.finish();
  const double n = double(pairs.size());
  res.mean_psnr = sum_psnr / n, res.mean_ssim = sum_ssim / n, res.mean_mse = sum_mse / n;
  if (metric) res.mean_lpips = sum_lpips / n;
  return res;
}

}  // namespace chungs

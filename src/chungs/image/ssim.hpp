// Structural similarity (SSIM, Wang et al. 2004) of two float images, the way 3DGS / SLAM papers
// report it: Gaussian window 11 x 11, sigma 1.5, C1 = (0.01 L)^2, C2 = (0.03 L)^2, computed per
// channel and averaged over channels and pixels.
//
// Border: the default `Valid` counts only windows that lie wholly inside the image, so the map is
// (W - 10) x (H - 10). That is what torchmetrics' StructuralSimilarityIndexMeasure (used by the
// reference code, see PAPER.md) and pytorch-msssim report: torchmetrics pads and then crops the
// padded border away, which leaves exactly the valid windows. `ZeroPad` gives a same-size map with
// the image zero-padded outside, as the original 3DGS training loss (and its metrics script) does;
// that variant scores slightly lower near borders and is what a loss wants (one value per pixel).
//
// Mask: pixels whose mask value is 0 are left out of the mean. A window is counted by its centre
// pixel, so in `Valid` mode map pixel (i, j) is kept when mask(i + r, j + r) != 0 (r = 5).
#pragma once
#include "chungs/image/image.hpp"

namespace chungs {

enum class SsimBorder { Valid, ZeroPad };

struct SsimOptions {
  double data_range = 1.0;  // L: 1 for float colour in [0, 1]
  SsimBorder border = SsimBorder::Valid;
  int window = 11;  // odd
  double sigma = 1.5;
  bool want_map = false;  // fill SsimResult::map
};

struct SsimResult {
  double mean = 0.0;  // over counted map pixels and all channels; NaN when nothing was counted
  size_t counted = 0;  // map pixels counted (per channel)
  // Per-pixel, per-channel SSIM (same channel count as the inputs) when want_map was set. Map
  // pixel (x, y) is the window centred on image pixel (x + offset, y + offset).
  ImageF map;
  int offset = 0;  // window radius in Valid mode, 0 in ZeroPad mode
};

// a and b: same width, height and channels (any of 1..4). mask: optional, 1 channel, same size.
// Throws Error on shape mismatches, an even or non-positive window, or (Valid) an image smaller
// than the window.
SsimResult ssim(const ImageF& a, const ImageF& b, const SsimOptions& opt = {}, const Image8* mask = nullptr);

// The normalised 1-D Gaussian (sum 1) of the given odd size; the 2-D window is its outer product.
std::vector<double> gaussian_kernel_1d(int size, double sigma);

}  // namespace chungs

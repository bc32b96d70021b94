// Photometric quality of a rendered image against its reference: MSE, PSNR and SSIM, optionally
// restricted to a mask. Conventions match the reference code's torchmetrics evaluation: float
// colour in [0, 1] (data range 1), all channels averaged, SSIM with the valid-window border (see
// chungs/image/ssim.hpp). Values are not clamped: a render outside [0, 1] is scored as it is.
#pragma once
#include <cstddef>

#include "chungs/image/image.hpp"
#include "chungs/image/ssim.hpp"

namespace chungs {

struct ImageMetrics {
  double mse = 0.0;
  double psnr = 0.0;  // +inf when the images are identical on the kept pixels
  double ssim = 0.0;
  size_t pixels = 0;  // pixels counted for MSE / PSNR
};

// Mean squared difference over all channels of the pixels whose mask value is non-zero (all
// pixels without a mask); NaN when the mask keeps none. Shapes must match (mask: 1 channel, same
// width and height), else Error.
double mse(const ImageF& a, const ImageF& b, const Image8* mask = nullptr);
// 10 log10(range^2 / mse); exactly +inf for mse == 0 (identical images), never a division error.
double psnr_from_mse(double mse, double data_range = 1.0);
double psnr(const ImageF& a, const ImageF& b, const Image8* mask = nullptr);
// 8-bit images are scored as float images divided by 255 (the same number as 10 log10(255^2/MSE)).
double psnr(const Image8& a, const Image8& b, const Image8* mask = nullptr);

ImageMetrics compare_images(const ImageF& ref, const ImageF& test, const Image8* mask = nullptr,
                            const SsimOptions& ssim_opt = {});
ImageMetrics compare_images(const Image8& ref, const Image8& test, const Image8* mask = nullptr,
                            const SsimOptions& ssim_opt = {});

}  // namespace chungs

#include "chungs/optim/loss.hpp"

#include "chungs/common/error.hpp"
#include "chungs/optim/loss_depth.hpp"
#include "chungs/optim/loss_l1.hpp"
#include "chungs/optim/loss_ssim.hpp"

namespace chungs {

template <typename T>
LossTerms mapping_loss(const LossConfig& config, const RenderOutput<T>& render, const Image<T>& target_rgb,
                       const Image<T>* target_inv_depth, const Image<uint8_t>* depth_mask,
                       std::type_identity_t<RenderGrads<T>>* grads, const Image<uint8_t>* pixel_mask) {
  config.validate();
  if (pixel_mask && (!pixel_mask->same_size(render.rgb) || pixel_mask->channels() != 1))
    fail("mapping loss: pixel mask ", pixel_mask->width(), "x", pixel_mask->height(), "x", pixel_mask->channels(),
         " does not match the ", render.rgb.width(), "x", render.rgb.height(), " render");
  const double ls = config.lambda_ssim, ld = config.lambda_depth;
  const bool use_depth = target_inv_depth && ld > 0;
  Image<T>* grgb = nullptr;
  Image<T>* gdepth = nullptr;
  if (grads) {
    grads->rgb = Image<T>(render.rgb.width(), render.rgb.height(), render.rgb.channels());
    grads->depth = Image<T>();
    grads->alpha = Image<T>();
    grads->inv_depth =
        use_depth ? Image<T>(render.inv_depth.width(), render.inv_depth.height(), 1) : Image<T>();
    grgb = &grads->rgb;
    gdepth = use_depth ? &grads->inv_depth : nullptr;
  }
  LossTerms t;
  t.l1 = l1_loss(render.rgb, target_rgb, grgb, 1 - ls);
  t.ssim = ls > 0 ? ssim_loss_term(render.rgb, target_rgb, grgb, -ls) : 1.0;
  if (use_depth)
    t.depth = inverse_depth_l1(render.inv_depth, *target_inv_depth, depth_mask, gdepth, ld, &t.depth_pixels);
  t.total = (1 - ls) * t.l1 + ls * (1 - t.ssim) + (use_depth ? ld * t.depth : 0.0);
  if (grads && pixel_mask) {
    const size_t n = pixel_mask->pixels();
    const int C = grgb->channels();
    for (size_t i = 0; i < n; ++i) {
      if (pixel_mask->data()[i]) continue;
      for (int c = 0; c < C; ++c) grgb->data()[i * C + c] = T(0);
      if (gdepth) gdepth->data()[i] = T(0);
    }
  }
  return t;
}

template LossTerms mapping_loss<float>(const LossConfig&, const RenderOutput<float>&, const Image<float>&,
                                       const Image<float>*, const Image<uint8_t>*, RenderGrads<float>*,
                                       const Image<uint8_t>*);
template LossTerms mapping_loss<double>(const LossConfig&, const RenderOutput<double>&, const Image<double>&,
                                        const Image<double>*, const Image<uint8_t>*, RenderGrads<double>*,
                                        const Image<uint8_t>*);

}  // namespace chungs

// Depth supervision as L1 on inverse depth (near geometry weighs more, far and sky pixels less),
// with a validity mask.
#pragma once
#include <cstddef>
#include <cstdint>

#include "chungs/image/image.hpp"

namespace chungs {

// Mean |pred_inv - target_inv| over the valid pixels: target finite and > 0, and mask non-zero where
// a mask is given (same size, 1 channel). Pixels outside contribute neither loss nor gradient. When
// grad is given it gets weight * dL/dpred_inv added. Returns 0 when no pixel is valid; the number of
// valid pixels goes to *valid when asked. Throws Error on shape mismatch.
template <typename T>
double inverse_depth_l1(const Image<T>& pred_inv, const Image<T>& target_inv,
                        const Image<uint8_t>* mask = nullptr, Image<T>* grad = nullptr, double weight = 1.0,
                        size_t* valid = nullptr);

// Inverse of a metric depth map; pixels with depth <= 0 or not finite (no measurement) become 0,
// which inverse_depth_l1 treats as invalid.
template <typename T>
Image<T> inverse_depth_of(const Image<T>& depth);

}  // namespace chungs

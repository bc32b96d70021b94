// L1 photometric loss: the mean absolute difference over all pixels and channels.
#pragma once
#include "chungs/image/image.hpp"

namespace chungs {

// Returns mean |pred - target|. When grad is given (same shape as pred) it gets weight * dL/dpred
// added; the subgradient at pred == target is 0. Throws Error when the shapes differ.
template <typename T>
double l1_loss(const Image<T>& pred, const Image<T>& target, Image<T>* grad = nullptr, double weight = 1.0);

}  // namespace chungs

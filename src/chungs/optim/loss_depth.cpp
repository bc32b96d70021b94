#include "chungs/optim/loss_depth.hpp"

#include <cmath>

#include "chungs/common/ordered_sum.hpp"
#include "chungs/optim/loss_check.hpp"

namespace chungs {

template <typename T>
double inverse_depth_l1(const Image<T>& pred_inv, const Image<T>& target_inv, const Image<uint8_t>* mask,
                        Image<T>* grad, double weight, size_t* valid) {
  if (pred_inv.channels() != 1)
    fail("inverse-depth loss: rendered inverse depth has ", pred_inv.channels(), " channels, expected 1");
  require_same_shape(pred_inv, target_inv, "inverse-depth loss: target");
  if (mask) require_same_shape(pred_inv, *mask, "inverse-depth loss: mask");
  if (grad) require_same_shape(pred_inv, *grad, "inverse-depth loss: gradient");
  const long long n = (long long)pred_inv.size();
  const T* p = pred_inv.data();
  const T* t = target_inv.data();
  const uint8_t* m = mask ? mask->data() : nullptr;
  auto ok = [&](long long i) { return std::isfinite(t[i]) && t[i] > 0 && (!m || m[i] != 0); };

  struct Acc {
    double sum = 0;
    long long count = 0;
    Acc& operator+=(const Acc& o) { return sum += o.sum, count += o.count, *this; }
  };
  const Acc total = ordered_sum<Acc>(n, [&](long long i, Acc& acc) {
    if (ok(i)) acc.sum += std::abs(double(p[i]) - double(t[i])), ++acc.count;
  });
  const long long count = total.count;
  const double sum = total.sum;
  if (valid) *valid = size_t(count);
  if (count == 0) return 0.0;
  if (grad) {
    const T step = T(weight / double(count));
    T* g = grad->data();
#pragma omp parallel for schedule(static)
    for (long long i = 0; i < n; ++i)
      if (ok(i)) {
        const T d = p[i] - t[i];
        g[i] += d > 0 ? step : (d < 0 ? -step : T(0));
      }
  }
  return sum / double(count);
}

template <typename T>
Image<T> inverse_depth_of(const Image<T>& depth) {
  if (depth.channels() != 1) fail("inverse depth: depth map has ", depth.channels(), " channels, expected 1");
  Image<T> inv(depth.width(), depth.height(), 1);
  for (size_t i = 0; i < depth.size(); ++i) {
    const T d = depth.data()[i];
    inv.data()[i] = (std::isfinite(d) && d > 0) ? T(1) / d : T(0);
  }
  return inv;
}

template double inverse_depth_l1<float>(const Image<float>&, const Image<float>&, const Image<uint8_t>*,
                                        Image<float>*, double, size_t*);
template double inverse_depth_l1<double>(const Image<double>&, const Image<double>&, const Image<uint8_t>*,
                                         Image<double>*, double, size_t*);
template Image<float> inverse_depth_of<float>(const Image<float>&);
template Image<double> inverse_depth_of<double>(const Image<double>&);

}  // namespace chungs

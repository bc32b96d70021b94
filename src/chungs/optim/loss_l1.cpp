#include "chungs/optim/loss_l1.hpp"

#include <cmath>

#include "chungs/common/ordered_sum.hpp"
#include "chungs/optim/loss_check.hpp"

namespace chungs {

template <typename T>
double l1_loss(const Image<T>& pred, const Image<T>& target, Image<T>* grad, double weight) {
  require_same_shape(pred, target, "L1 loss: target");
  if (grad) require_same_shape(pred, *grad, "L1 loss: gradient");
  const long long n = (long long)pred.size();
  if (n == 0) return 0.0;
  const T* p = pred.data();
  const T* t = target.data();
  T* g = grad ? grad->data() : nullptr;
  const T step = T(weight / double(n));
  const double sum = ordered_sum<double>(n, [&](long long i, double& acc) {
    const T d = p[i] - t[i];
    acc += std::abs(double(d));
    if (g) g[i] += d > 0 ? step : (d < 0 ? -step : T(0));
  });
  return sum / double(n);
}

template double l1_loss<float>(const Image<float>&, const Image<float>&, Image<float>*, double);
template double l1_loss<double>(const Image<double>&, const Image<double>&, Image<double>*, double);

}  // namespace chungs

// Real spherical-harmonics basis up to degree 3 in the ordering and sign convention of 3D Gaussian
// Splatting (k = 0 DC; 1..3 degree 1; 4..8 degree 2; 9..15 degree 3), with its derivatives, so the
// colour of a Gaussian can be differentiated with respect to the viewing direction.
#pragma once

namespace chungs::sh {

constexpr double kC0 = 0.28209479177387814;
constexpr double kC1 = 0.4886025119029199;
constexpr double kC2[5] = {1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792,
                           0.5462742152960396};
constexpr double kC3[7] = {-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154,
                           -0.4570457994644658, 1.445305721320277, -0.5900435899266435};

// Basis values b[0..(degree+1)^2) at unit direction (x, y, z).
template <typename T>
inline void basis(int degree, T x, T y, T z, T* b) {
  b[0] = T(kC0);
  if (degree < 1) return;
  b[1] = T(-kC1) * y;
  b[2] = T(kC1) * z;
  b[3] = T(-kC1) * x;
  if (degree < 2) return;
  const T xx = x * x, yy = y * y, zz = z * z;
  b[4] = T(kC2[0]) * x * y;
  b[5] = T(kC2[1]) * y * z;
  b[6] = T(kC2[2]) * (2 * zz - xx - yy);
  b[7] = T(kC2[3]) * x * z;
  b[8] = T(kC2[4]) * (xx - yy);
  if (degree < 3) return;
  b[9] = T(kC3[0]) * y * (3 * xx - yy);
  b[10] = T(kC3[1]) * x * y * z;
  b[11] = T(kC3[2]) * y * (4 * zz - xx - yy);
  b[12] = T(kC3[3]) * z * (2 * zz - 3 * xx - 3 * yy);
  b[13] = T(kC3[4]) * x * (4 * zz - xx - yy);
  b[14] = T(kC3[5]) * z * (xx - yy);
  b[15] = T(kC3[6]) * x * (xx - 3 * yy);
}

// Partial derivatives of each basis function with respect to x, y and z (treated as independent;
// the caller projects onto the tangent plane of the unit sphere): db[3k + axis].
template <typename T>
inline void basis_gradient(int degree, T x, T y, T z, T* db) {
  for (int i = 0; i < 3; ++i) db[i] = 0;
  if (degree < 1) return;
  auto set = [&](int k, T gx, T gy, T gz) {
    db[3 * k] = gx;
    db[3 * k + 1] = gy;
    db[3 * k + 2] = gz;
  };
  const T c1 = T(kC1);
  set(1, 0, -c1, 0);
  set(2, 0, 0, c1);
  set(3, -c1, 0, 0);
  if (degree < 2) return;
  const T xx = x * x, yy = y * y, zz = z * z;
  set(4, T(kC2[0]) * y, T(kC2[0]) * x, 0);
  set(5, 0, T(kC2[1]) * z, T(kC2[1]) * y);
  set(6, T(kC2[2]) * -2 * x, T(kC2[2]) * -2 * y, T(kC2[2]) * 4 * z);
  set(7, T(kC2[3]) * z, 0, T(kC2[3]) * x);
  set(8, T(kC2[4]) * 2 * x, T(kC2[4]) * -2 * y, 0);
  if (degree < 3) return;
  set(9, T(kC3[0]) * 6 * x * y, T(kC3[0]) * 3 * (xx - yy), 0);
  set(10, T(kC3[1]) * y * z, T(kC3[1]) * x * z, T(kC3[1]) * x * y);
  set(11, T(kC3[2]) * -2 * x * y, T(kC3[2]) * (4 * zz - xx - 3 * yy), T(kC3[2]) * 8 * y * z);
  set(12, T(kC3[3]) * -6 * x * z, T(kC3[3]) * -6 * y * z, T(kC3[3]) * (6 * zz - 3 * xx - 3 * yy));
  set(13, T(kC3[4]) * (4 * zz - 3 * xx - yy), T(kC3[4]) * -2 * x * y, T(kC3[4]) * 8 * x * z);
  set(14, T(kC3[5]) * 2 * x * z, T(kC3[5]) * -2 * y * z, T(kC3[5]) * (xx - yy));
  set(15, T(kC3[6]) * 3 * (xx - yy), T(kC3[6]) * -6 * x * y, 0);
}

}  // namespace chungs::sh

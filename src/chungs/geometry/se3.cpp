#include "chungs/geometry/se3.hpp"

#include <Eigen/SVD>
#include <cmath>

#include "chungs/common/error.hpp"

namespace chungs {

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

Eigen::Matrix3d nearest_rotation(const Eigen::Matrix3d& m) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

SE3::SE3(const Eigen::Quaterniond& rotation, const Eigen::Vector3d& translation)
    : q(rotation.normalized()), t(translation) {}

SE3::SE3(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation)
    : q(Eigen::Quaterniond(nearest_rotation(rotation)).normalized()), t(translation) {}

SE3 SE3::from_matrix(const Eigen::Matrix4d& m, const char* what, double tol) {
  if (!m.allFinite()) fail(what, ": matrix has non-finite entries");
  // A rigid transform's last row is 0 0 0 1; anything else is not a pose, whatever R and t say.
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > tol)
    fail(what, ": bottom row is (", m(3, 0), ", ", m(3, 1), ", ", m(3, 2), ", ", m(3, 3),
         "), expected (0, 0, 0, 1)");
  Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  double err = (r.transpose() * r - Eigen::Matrix3d::Identity()).norm();
  if (err > tol || r.determinant() < 0)
    fail(what, ": rotation block is not a rotation (|R^T R - I| = ", err, ", det = ", r.determinant(), ")");
  return SE3(r, m.topRightCorner<3, 1>());
}

Eigen::Matrix4d SE3::matrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = rotation();
  m.topRightCorner<3, 1>() = t;
  return m;
}

Eigen::Matrix<double, 3, 4> SE3::matrix3x4() const { return matrix().topRows<3>(); }

SE3 SE3::inverse() const {
  Eigen::Quaterniond qi = q.conjugate();
  return SE3(qi, -(qi * t));
}

SE3 SE3::operator*(const SE3& o) const { return SE3(q * o.q, q * o.t + t); }

double SE3::angle() const {
  double w = std::min(1.0, std::abs(q.w()));
  return 2.0 * std::acos(w);
}

// Left Jacobian of SO(3) and its inverse, for the exact SE(3) exponential and logarithm.
static Eigen::Matrix3d so3_left_jacobian(const Eigen::Vector3d& phi) {
  double th = phi.norm();
  Eigen::Matrix3d K = skew(phi);
  if (th < 1e-8) return Eigen::Matrix3d::Identity() + 0.5 * K;
  return Eigen::Matrix3d::Identity() + (1 - std::cos(th)) / (th * th) * K +
         (th - std::sin(th)) / (th * th * th) * K * K;
}

SE3 SE3::exp(const Eigen::Matrix<double, 6, 1>& xi) {
  Eigen::Vector3d rho = xi.head<3>(), phi = xi.tail<3>();
  double th = phi.norm();
  Eigen::Quaterniond q = th < 1e-12 ? Eigen::Quaterniond::Identity()
                                    : Eigen::Quaterniond(Eigen::AngleAxisd(th, phi / th));
  return SE3(q, so3_left_jacobian(phi) * rho);
}

Eigen::Matrix<double, 6, 1> SE3::log() const {
  Eigen::AngleAxisd aa(q);
  Eigen::Vector3d phi = aa.axis() * aa.angle();
  if (aa.angle() > M_PI) phi = aa.axis() * (aa.angle() - 2 * M_PI);
  Eigen::Matrix<double, 6, 1> xi;
  xi.head<3>() = so3_left_jacobian(phi).inverse() * t;
  xi.tail<3>() = phi;
  return xi;
}

Sim3::Sim3(double scale, const Eigen::Quaterniond& rotation, const Eigen::Vector3d& translation)
    : s(scale), q(rotation.normalized()), t(translation) {
  if (!(scale > 0) || !std::isfinite(scale)) fail("Sim3: scale must be positive and finite, got ", scale);
}

Sim3 Sim3::from_matrix(const Eigen::Matrix4d& m) {
  Eigen::Matrix3d sr = m.topLeftCorner<3, 3>();
  double det = sr.determinant();
  if (!(det > 0)) fail("Sim3: matrix has a non-positive determinant (", det, ")");
  double s = std::cbrt(det);
  return Sim3(s, Eigen::Quaterniond(nearest_rotation(sr / s)), m.topRightCorner<3, 1>());
}

Eigen::Matrix4d Sim3::matrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = s * q.toRotationMatrix();
  m.topRightCorner<3, 1>() = t;
  return m;
}

Sim3 Sim3::inverse() const {
  Eigen::Quaterniond qi = q.conjugate();
  return Sim3(1.0 / s, qi, -(qi * t) / s);
}

Sim3 Sim3::operator*(const Sim3& o) const { return Sim3(s * o.s, q * o.q, s * (q * o.t) + t); }

SE3 Sim3::apply(const SE3& pose) const { return SE3(q * pose.q, (*this) * pose.t); }

}  // namespace chungs

// Rigid (SE3) and similarity (Sim3) transforms on Eigen, in double precision.
// Poses are camera-to-world unless a name says otherwise (T_wc maps camera points to world).
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace chungs {

struct SE3 {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();  // kept normalised
  Eigen::Vector3d t = Eigen::Vector3d::Zero();

  SE3() = default;
  SE3(const Eigen::Quaterniond& rotation, const Eigen::Vector3d& translation);
  SE3(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation);

  // From a 4x4 or 3x4 matrix; the rotation block is projected onto SO(3) (nearest rotation), and a
  // block far from a rotation (|R^T R - I| > tol) or a bottom row other than 0 0 0 1 (within tol)
  // throws Error naming `what`.
  static SE3 from_matrix(const Eigen::Matrix4d& m, const char* what = "pose", double tol = 1e-3);
  static SE3 exp(const Eigen::Matrix<double, 6, 1>& xi);  // xi = (rho, phi): translation, rotation

  Eigen::Matrix3d rotation() const { return q.toRotationMatrix(); }
  Eigen::Matrix4d matrix() const;
  Eigen::Matrix<double, 3, 4> matrix3x4() const;
  SE3 inverse() const;
  Eigen::Matrix<double, 6, 1> log() const;
  double angle() const;  // rotation angle in radians, [0, pi]

  SE3 operator*(const SE3& o) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return q * p + t; }
};

struct Sim3 {
  double s = 1.0;
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();

  Sim3() = default;
  Sim3(double scale, const Eigen::Quaterniond& rotation, const Eigen::Vector3d& translation);
  explicit Sim3(const SE3& se3) : s(1.0), q(se3.q), t(se3.t) {}
  static Sim3 from_matrix(const Eigen::Matrix4d& m);  // m = [sR t; 0 1]

  Eigen::Matrix4d matrix() const;
  Sim3 inverse() const;
  Sim3 operator*(const Sim3& o) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return s * (q * p) + t; }
  // Applies the similarity to a pose (camera-to-world): rotation composes, the camera centre moves.
  SE3 apply(const SE3& pose) const;
};

// Nearest rotation matrix (polar decomposition via SVD, det +1).
Eigen::Matrix3d nearest_rotation(const Eigen::Matrix3d& m);
Eigen::Matrix3d skew(const Eigen::Vector3d& v);

}  // namespace chungs

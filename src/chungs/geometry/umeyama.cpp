#include "chungs/geometry/umeyama.hpp"

#include <Eigen/SVD>

#include "chungs/common/error.hpp"

namespace chungs {

Sim3 umeyama_align(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                   bool with_scale) {
  if (src.size() != dst.size()) fail("alignment: ", src.size(), " source points but ", dst.size(), " targets");
  const size_t n = src.size();
  if (n < 3) fail("alignment: need at least 3 point pairs, got ", n);
  Eigen::Vector3d ms = Eigen::Vector3d::Zero(), md = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    ms += src[i];
    md += dst[i];
  }
  ms /= double(n);
  md /= double(n);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double var_src = 0, var_dst = 0;
  for (size_t i = 0; i < n; ++i) {
    Eigen::Vector3d a = src[i] - ms, b = dst[i] - md;
    cov += b * a.transpose();
    var_src += a.squaredNorm();
    var_dst += b.squaredNorm();
  }
  cov /= double(n);
  var_src /= double(n);
  var_dst /= double(n);
  if (!(var_src > 1e-20)) fail("alignment: source points are all at one place");
  if (!(var_dst > 1e-20)) fail("alignment: target points are all at one place");
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d sv = svd.singularValues();
  // Points on a line (a straight drive) leave the rotation about that line free, but no point moves
  // with it: every rotation the SVD may give is optimal and gives the same errors, so it is taken.
  // Only points that do not vary together at all leave nothing to align.
  if (!(sv(0) > 1e-12 * std::sqrt(var_src * var_dst)))
    fail("alignment: the two point sets do not vary together; rotation and scale are undetermined");
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) S(2, 2) = -1;
  Eigen::Matrix3d R = svd.matrixU() * S * svd.matrixV().transpose();
  double s = with_scale ? (sv.asDiagonal() * S).trace() / var_src : 1.0;
  Eigen::Vector3d t = md - s * R * ms;
  return Sim3(s, Eigen::Quaterniond(R), t);
}

}  // namespace chungs

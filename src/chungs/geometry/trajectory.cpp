#include "chungs/geometry/trajectory.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <optional>

#include "chungs/common/error.hpp"
#include "chungs/common/text_file.hpp"

namespace chungs {

double Trajectory::path_length() const {
  double len = 0;
  for (size_t i = 1; i < poses.size(); ++i) len += (poses[i].t - poses[i - 1].t).norm();
  return len;
}

namespace {

SE3 pose_from_row_major(const TextLine& line, int rows) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = line.number_at(size_t(r * 4 + c));
  return SE3::from_matrix(m, cat(line.file.string(), ":", line.number).c_str());
}

SE3 pose_from_tum(const TextLine& line) {
  Eigen::Vector3d t(line.number_at(1), line.number_at(2), line.number_at(3));
  Eigen::Quaterniond q(line.number_at(7), line.number_at(4), line.number_at(5), line.number_at(6));
  double n = q.norm();
  if (std::abs(n - 1.0) > 1e-2) line.fail_here(cat("quaternion is not unit length (norm ", n, ")"));
  return SE3(q, t);
}

void push_increasing(Trajectory& tr, const TextLine& l, double stamp, const SE3& pose) {
  if (!tr.stamps.empty() && !(stamp > tr.stamps.back()))
    l.fail_here(cat("timestamp ", stamp, " does not increase"));
  tr.push_back(stamp, pose);
}

}  // namespace

Trajectory read_tum_trajectory(const std::filesystem::path& file) {
  Trajectory tr;
  for_each_text_line(file, true, true, [&](const TextLine& l) {
    l.expect_fields(8);
    push_increasing(tr, l, l.number_at(0), pose_from_tum(l));
    return true;
  });
  if (tr.stamps.empty()) fail(file.string(), ": trajectory has no poses");
  return tr;
}

Trajectory read_kitti_trajectory(const std::filesystem::path& file, const std::vector<double>& stamps,
                                 double rate_hz) {
  if (stamps.empty() && !(rate_hz > 0)) fail(file.string(), ": frame rate must be positive, got ", rate_hz);
  Trajectory tr;
  size_t i = 0;
  for_each_text_line(file, false, false, [&](const TextLine& l) {
    if (!stamps.empty() && i >= stamps.size()) return ++i, true;  // counted for the message below
    if (l.tokens.size() != 12 && l.tokens.size() != 16) l.fail_here(cat("expected 12 or 16 numbers, found ", l.tokens.size()));
    // A 4x4 pose's last row is 0 0 0 1: anything else is no rigid pose (or a line of another format).
    if (l.tokens.size() == 16)
      for (int c = 0; c < 4; ++c)
        if (std::abs(l.number_at(12 + c) - (c == 3 ? 1.0 : 0.0)) > 1e-6)
          l.fail_here(cat("a 4x4 pose's last row must be 0 0 0 1, found ", l.tokens[12], " ", l.tokens[13], " ",
                          l.tokens[14], " ", l.tokens[15]));
    tr.push_back(stamps.empty() ? double(i) / rate_hz : stamps[i], pose_from_row_major(l, 3));
    ++i;
    return true;
  });
  if (tr.stamps.empty()) fail(file.string(), ": trajectory has no poses");
  if (!stamps.empty() && stamps.size() != i) fail(file.string(), ": ", i, " poses but ", stamps.size(), " timestamps");
  return tr;
}

Trajectory read_trajectory(const std::filesystem::path& file, double rate_hz) {
  std::optional<TextLine> first;  // its field count tells the format
  for_each_text_line(file, true, true, [&](const TextLine& l) {
    first = l;
    return false;
  });
  if (!first) fail(file.string(), ": trajectory has no poses");
  size_t n = first->tokens.size();
  if (n == 8) return read_tum_trajectory(file);
  if (n == 12 || n == 16) return read_kitti_trajectory(file, {}, rate_hz);
  first->fail_here(cat("cannot tell the trajectory format: ", n,
                       " fields (TUM has 8, KITTI 12, a 4x4 matrix 16)"));
}

void write_tum_trajectory(const std::filesystem::path& file, const Trajectory& tr, bool monocular) {
  prepare_output_file(file, "trajectory");
  std::ofstream out(file);
  if (!out) fail(file.string(), ": cannot open for writing (", std::strerror(errno), ")");
  if (monocular) out << kMonocularTrajectoryComment << '\n';
  out << "# timestamp tx ty tz qx qy qz qw\n" << std::setprecision(17);
  for (size_t i = 0; i < tr.size(); ++i) {
    const auto& p = tr.poses[i];
    out << std::fixed << std::setprecision(6) << tr.stamps[i] << std::defaultfloat << std::setprecision(12) << ' '
        << p.t.x() << ' ' << p.t.y() << ' ' << p.t.z() << ' ' << p.q.x() << ' ' << p.q.y() << ' ' << p.q.z()
        << ' ' << p.q.w() << '\n';
  }
  if (!out.flush()) fail(file.string(), ": write failed (", std::strerror(errno), ")");
}

void write_kitti_trajectory(const std::filesystem::path& file, const Trajectory& tr, bool monocular) {
  prepare_output_file(file, "trajectory");
  std::ofstream out(file);
  if (!out) fail(file.string(), ": cannot open for writing (", std::strerror(errno), ")");
  if (monocular) out << kMonocularTrajectoryComment << '\n';
  out << std::setprecision(12);
  for (const auto& p : tr.poses) {
    auto m = p.matrix3x4();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) out << m(r, c) << (r == 2 && c == 3 ? '\n' : ' ');
  }
  if (!out.flush()) fail(file.string(), ": write failed (", std::strerror(errno), ")");
}

void write_trajectory(const std::filesystem::path& file, const Trajectory& tr, TrajectoryFormat f, bool monocular) {
  if (f == TrajectoryFormat::Tum)
    write_tum_trajectory(file, tr, monocular);
  else
    write_kitti_trajectory(file, tr, monocular);
}

bool trajectory_is_monocular(const std::filesystem::path& file) {
  require_file(file, "trajectory");
  std::ifstream in(file);
  if (!in) fail(file.string(), ": cannot open (", std::strerror(errno), ")");
  // Only the comment block before the first pose: a long trajectory is not read through.
  std::string line;
  for (int n = 0; n < 64 && std::getline(in, line); ++n) {
    const size_t a = line.find_first_not_of(" \t\r");
    if (a == std::string::npos) continue;
    if (line[a] != '#') return false;
    if (line.compare(a, 13, "# input: mono") == 0) return true;
  }
  return false;
}

TrajectoryFormat parse_trajectory_format(const std::string& name) {
  if (name == "tum") return TrajectoryFormat::Tum;
  if (name == "kitti") return TrajectoryFormat::Kitti;
  fail("unknown trajectory format '", name, "' (use tum or kitti)");
}

std::vector<std::pair<size_t, size_t>> associate_stamps(const std::vector<double>& a, const std::vector<double>& b,
                                                        double max_dt) {
  // Candidate pairs within max_dt, found by a two-pointer sweep over sorted b, then taken greedily by
  // smallest time difference so each stamp is used once.
  std::vector<size_t> order(b.size());
  for (size_t i = 0; i < b.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t x, size_t y) { return b[x] < b[y]; });
  std::vector<std::tuple<double, size_t, size_t>> cand;
  for (size_t i = 0; i < a.size(); ++i) {
    auto lo = std::lower_bound(order.begin(), order.end(), a[i] - max_dt, [&](size_t k, double v) { return b[k] < v; });
    for (auto it = lo; it != order.end() && b[*it] <= a[i] + max_dt; ++it) cand.emplace_back(std::abs(a[i] - b[*it]), i, *it);
  }
  std::sort(cand.begin(), cand.end());
  std::vector<char> used_a(a.size(), 0), used_b(b.size(), 0);
  std::vector<std::pair<size_t, size_t>> out;
  for (auto& [d, i, j] : cand) {
    if (used_a[i] || used_b[j]) continue;
    used_a[i] = used_b[j] = 1;
    out.emplace_back(i, j);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace chungs

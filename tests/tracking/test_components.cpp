// Building blocks of the tracker on random inputs: the keypoint grid against a search of every keypoint, stereo
// sub-pixel disparity, pose-only optimisation with
// outliers, vocabulary round trip and scores, pose graph against a consistent ground truth.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>

#include "chungs/tracking/features.hpp"
#include "chungs/tracking/pose_graph.hpp"
#include "chungs/tracking/pose_optimizer.hpp"
#include "chungs/tracking/stereo_matcher.hpp"
#include "chungs/tracking/vocabulary.hpp"
#include "test_support.hpp"

using namespace chungs;
using namespace chungs::tracking;

// Every query lists exactly the keypoints a search of all of them finds, in the order the trackers relied on
// (cells row by row, left to right, each in index order), discs off the image and octave ranges included.
TEST(FeatureGrid, FindsWhatASearchOfEveryKeypointFindsInTheSameOrder) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> X(-2.f, 643.f), Y(-2.f, 483.f), R(0.5f, 60.f), Q(-80.f, 720.f);
  std::uniform_int_distribution<int> O(0, 7);
  std::vector<cv::KeyPoint> kps(3000);
  for (auto& k : kps) k = cv::KeyPoint(X(rng), Y(rng), 7.f, -1.f, 0.f, O(rng));
  const int W = 640, H = 480;
  const FeatureGrid grid(kps, W, H);
  std::vector<int> got;
  size_t found = 0;
  for (int q = 0; q < 2000; ++q) {
    const float u = Q(rng), v = Q(rng), r = R(rng);
    const int lo = O(rng), hi = std::max(lo, O(rng));
    grid.query(u, v, r, got, lo, hi);
    // The reference: the cells a disc's box reaches, each keypoint in the cell it falls in (clamped).
    std::vector<std::pair<size_t, int>> want;
    const int cols = (W + 15) / 16, rows = (H + 15) / 16;
    for (int i = 0; i < int(kps.size()); ++i) {
      const auto& k = kps[i];
      const int cx = std::clamp(int(k.pt.x / 16), 0, cols - 1), cy = std::clamp(int(k.pt.y / 16), 0, rows - 1);
      const int x0 = std::max(0, int(std::floor((u - r) / 16))), x1 = std::min(cols - 1, int(std::floor((u + r) / 16)));
      const int y0 = std::max(0, int(std::floor((v - r) / 16))), y1 = std::min(rows - 1, int(std::floor((v + r) / 16)));
      const float du = k.pt.x - u, dv = k.pt.y - v;
      if (cx < x0 || cx > x1 || cy < y0 || cy > y1 || k.octave < lo || k.octave > hi || du * du + dv * dv > r * r)
        continue;
      want.push_back({size_t(cy) * cols + cx, i});
    }
    std::stable_sort(want.begin(), want.end(), [](auto& a, auto& b) { return a.first < b.first; });
    std::vector<int> ids;
    for (auto& w : want) ids.push_back(w.second);
    ASSERT_EQ(got, ids) << "query " << q << " at (" << u << ", " << v << ") r " << r;
    found += got.size();
  }
  EXPECT_GT(found, 5000u) << "the queries found keypoints";
}

TEST(StereoMatcher, RecoversSubPixelDisparityOfShiftedTexture) {
  std::mt19937 rng(5);
  cv::Mat noise(480, 640, CV_8U);
  for (int y = 0; y < noise.rows; ++y)
    for (int x = 0; x < noise.cols; ++x) noise.at<uint8_t>(y, x) = uint8_t(rng());
  cv::Mat left;
  cv::GaussianBlur(noise, left, cv::Size(0, 0), 1.5);
  cv::normalize(left, left, 0, 255, cv::NORM_MINMAX);
  const double disp = 12.37;  // right image = left shifted by a non-integer disparity
  cv::Mat M = (cv::Mat_<double>(2, 3) << 1, 0, -disp, 0, 1, 0), right;
  cv::warpAffine(left, right, M, left.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT);
  OrbOptions o;
  Features lf = extract_orb(left, o), rf = extract_orb(right, o);
  const double bf = 400 * 0.1;
  int n = match_stereo(left, right, lf, rf, bf);
  ASSERT_GT(n, 200);
  int good = 0;
  for (size_t i = 0; i < lf.size(); ++i)
    if (lf.has_depth(i)) good += std::abs((lf.kps[i].pt.x - lf.u_right[i]) - disp) < 0.25;
  EXPECT_GT(good, 0.9 * n) << good << " of " << n << " within 0.25 px";
}

TEST(StereoMatcher, DepthMapGivesVirtualRightColumn) {
  Features f;
  f.kps = {cv::KeyPoint(10.2f, 5.8f, 31), cv::KeyPoint(3, 3, 31), cv::KeyPoint(50, 2, 31)};
  f.depth.assign(3, 0);
  f.u_right.assign(3, -1);
  ImageF depth(20, 10, 1, 2.5f);
  depth(3, 3) = 0;  // invalid
  EXPECT_EQ(attach_depth(depth, f, 40.0), 1);
  EXPECT_FLOAT_EQ(f.depth[0], 2.5f);
  EXPECT_NEAR(f.u_right[0], 10.2 - 40.0 / 2.5, 1e-5);
  // A negative virtual right column is still one (it was read as "none" when -1 marked a missing column).
  EXPECT_TRUE(has_right(f.u_right[0]));
  EXPECT_FALSE(has_right(f.u_right[1]));
  EXPECT_FALSE(f.has_depth(1));
  EXPECT_FALSE(f.has_depth(2));
}

TEST(PoseOptimizer, RecoversPoseDespiteOutliers) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-1, 1);
  std::normal_distribution<double> N(0, 0.5);
  const Intrinsics k{500, 500, 320, 240, 50};
  Eigen::Matrix<double, 6, 1> xi;
  xi << 0.3, -0.2, 0.5, 0.05, -0.1, 0.08;
  const SE3 truth = SE3::exp(xi);
  std::vector<PoseObservation> obs;
  for (int i = 0; i < 300; ++i) {
    Eigen::Vector3d pc(3 * U(rng), 2 * U(rng), 4 + 3 * (U(rng) + 1));
    Eigen::Vector3d X = truth.inverse() * pc;
    double u = k.fx * pc.x() / pc.z() + k.cx + N(rng), v = k.fy * pc.y() / pc.z() + k.cy + N(rng);
    double ur = i % 2 ? u - k.bf / pc.z() + N(rng) : double(kNoRight);
    if (i % 5 == 0) u += 40 * U(rng) + 30, v -= 30;  // gross outliers
    obs.push_back({X, u, v, ur, 1.0});
  }
  Eigen::Matrix<double, 6, 1> off;
  off << 0.1, 0.05, -0.1, 0.02, 0.03, -0.02;
  SE3 T = truth * SE3::exp(off);
  std::vector<char> inl;
  int n = optimize_pose(T, k, obs, inl);
  EXPECT_GE(n, 230);
  EXPECT_LE(n, 245);
  for (size_t i = 0; i < obs.size(); i += 5) EXPECT_FALSE(inl[i]) << i;
  EXPECT_LT((T.t - truth.t).norm(), 0.01);
  EXPECT_LT((T.inverse() * truth).angle(), 1e-3);
}

TEST(Vocabulary, SavesLoadsAndScoresNoisyCopiesHighest) {
  std::mt19937 rng(3);
  std::vector<cv::Mat> docs;
  for (int d = 0; d < 6; ++d) {
    cv::Mat m(200, 32, CV_8U);
    for (int i = 0; i < m.rows * 32; ++i) m.data[i] = uint8_t(rng());
    docs.push_back(m);
  }
  Vocabulary v = Vocabulary::train(docs, 10, 3);
  EXPECT_GT(v.words(), 300);
  test::TempDir dir;
  v.save(dir / "voc.bin");
  Vocabulary w = Vocabulary::load(dir / "voc.bin");
  ASSERT_EQ(w.words(), v.words());
  for (int i = 0; i < 50; ++i) EXPECT_EQ(w.word(docs[1].ptr<uint8_t>(i)), v.word(docs[1].ptr<uint8_t>(i)));
  cv::Mat noisy = docs[2].clone();
  for (int i = 0; i < noisy.rows; ++i) noisy.at<uint8_t>(i, int(rng() % 32)) ^= uint8_t(1u << (rng() % 8));
  BowVector q = v.transform(noisy);
  double own = Vocabulary::score(q, v.transform(docs[2]));
  for (int d = 0; d < 6; ++d) {
    if (d != 2) {
      EXPECT_GT(own, 2 * Vocabulary::score(q, v.transform(docs[d]))) << d;
    }
  }
  EXPECT_NEAR(Vocabulary::score(q, q), 1.0, 1e-5);
  std::ofstream(dir / "bad.bin") << "not a vocabulary";
  EXPECT_THROW(Vocabulary::load(dir / "bad.bin"), Error);
}

TEST(PoseGraph, ClosesLoopOfConsistentMeasurements) {
  std::mt19937 rng(9);
  std::normal_distribution<double> N(0, 1);
  std::unordered_map<long, SE3> truth, poses;
  const int n = 30;
  for (long i = 0; i < n; ++i) {
    Eigen::Matrix<double, 6, 1> xi;
    xi << 5 * std::cos(i * 0.2), 0.3 * N(rng), 5 * std::sin(i * 0.2), 0.1 * N(rng), i * 0.2, 0.1 * N(rng);
    truth[i] = SE3::exp(xi);
  }
  std::vector<PoseGraphEdge> edges;
  for (long i = 1; i < n; ++i) edges.push_back({i - 1, i, truth[i - 1].inverse() * truth[i]});
  edges.push_back({0, n - 1, truth[0].inverse() * truth[n - 1]});
  // Start from a drifted chain: every step perturbed.
  poses[0] = truth[0];
  for (long i = 1; i < n; ++i) {
    Eigen::Matrix<double, 6, 1> e;
    e << 0.02 * N(rng), 0.02 * N(rng), 0.02 * N(rng), 0.01 * N(rng), 0.01 * N(rng), 0.01 * N(rng);
    poses[i] = poses[i - 1] * edges[size_t(i - 1)].T_ij * SE3::exp(e);
  }
  double err0 = (poses[n - 1].t - truth[n - 1].t).norm();
  optimize_pose_graph(poses, edges, {0});
  for (long i = 0; i < n; ++i) {
    EXPECT_LT((poses[i].t - truth[i].t).norm(), 1e-4) << i << " (start error " << err0 << ")";
    EXPECT_LT((poses[i].inverse() * truth[i]).angle(), 1e-5) << i;
  }
}

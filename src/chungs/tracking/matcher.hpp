// Data association: map points projected into a frame and matched by descriptor near their projection,
// and brute-force descriptor matching for the PnP fallback and relocalisation.
#pragma once
#include <vector>

#include "chungs/geometry/se3.hpp"
#include "chungs/tracking/features.hpp"
#include "chungs/tracking/map.hpp"
#include "chungs/tracking/reprojection.hpp"

namespace chungs::tracking {

struct ProjectionSearch {
  float radius = 8;       // pixels at level 0, scaled by the keypoint's pyramid scale
  int max_distance = 100; // Hamming
  float ratio = 0.9f;     // best / second best, when both lie on the same pyramid level
};

// For each point id in `candidates` (skipping ones already in `matches`), projects it with T_cw and picks the best
// free keypoint of `f` near the projection. `matches` has one entry per keypoint (point id or -1). Returns the number
// of new matches. `visible` counts points that project inside the image (for the point's found ratio).
int search_by_projection(const Map& map, const std::vector<long>& candidates, const SE3& T_cw, const Intrinsics& k,
                         int width, int height, const Features& f, const FeatureGrid& grid, std::vector<long>& matches,
                         const ProjectionSearch& opt, std::vector<long>* visible = nullptr);

// Mutual-nearest-neighbour descriptor matches with a ratio test: pairs (index in a, index in b).
std::vector<std::pair<int, int>> match_descriptors(const cv::Mat& a, const cv::Mat& b, int max_distance = 64,
                                                   float ratio = 0.8f);

}  // namespace chungs::tracking

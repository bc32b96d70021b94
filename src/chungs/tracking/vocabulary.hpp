// A bag-of-words vocabulary of binary (ORB) descriptors: a tree of k-majority clusters (k-means where the
// centre of a cluster is the bitwise majority of its members), words at the leaves weighted by inverse
// document frequency. Trained by the project from ORB descriptors; saved as a small binary file.
#pragma once
#include <array>
#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

namespace chungs::tracking {

// Sparse, L1-normalised tf-idf histogram: (word, weight) sorted by word.
using BowVector = std::vector<std::pair<int, float>>;

class Vocabulary {
 public:
  // `documents`: one N x 32 descriptor matrix per training image. Throws Error when there are too few
  // descriptors for even one level of `branching` clusters.
  static Vocabulary train(const std::vector<cv::Mat>& documents, int branching = 10, int levels = 3,
                          uint64_t seed = 1);
  static Vocabulary load(const std::filesystem::path& file);
  void save(const std::filesystem::path& file) const;

  int words() const { return int(idf_.size()); }
  int word(const uint8_t* descriptor) const;
  BowVector transform(const cv::Mat& descriptors) const;
  // Similarity in [0, 1]: 1 - |a - b|_1 / 2 of the normalised histograms.
  static double score(const BowVector& a, const BowVector& b);

 private:
  struct Node {
    std::array<uint8_t, 32> centre{};
    int first_child = -1, children = 0;  // children are contiguous in nodes_
    int word = -1;
  };
  void build(int node, std::vector<const uint8_t*>& members, int level, int branching, int levels, uint64_t& rng);
  std::vector<Node> nodes_;
  std::vector<float> idf_;
};

}  // namespace chungs::tracking

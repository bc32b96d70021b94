#include "chungs/tracking/vocabulary.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <fstream>

#include "chungs/common/error.hpp"
#include "chungs/tracking/features.hpp"

namespace chungs::tracking {
namespace {

constexpr uint32_t kMagic = 0x42575643;  // "CVWB"

uint64_t next(uint64_t& s) {  // splitmix64: reproducible across platforms
  uint64_t z = (s += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

std::array<uint8_t, 32> majority(const std::vector<const uint8_t*>& m) {
  std::array<int, 256> ones{};
  for (const uint8_t* d : m)
    for (int b = 0; b < 256; ++b) ones[b] += (d[b >> 3] >> (b & 7)) & 1;
  std::array<uint8_t, 32> c{};
  for (int b = 0; b < 256; ++b)
    if (2 * ones[b] > int(m.size())) c[b >> 3] |= uint8_t(1 << (b & 7));
  return c;
}

}  // namespace

void Vocabulary::build(int node, std::vector<const uint8_t*>& members, int level, int branching, int levels,
                       uint64_t& rng) {
  if (level == levels || int(members.size()) <= branching) {
    nodes_[node].word = int(idf_.size());
    idf_.push_back(0.f);
    return;
  }
  // k-means++ seeding with Hamming distances, then a few k-majority iterations.
  std::vector<std::array<uint8_t, 32>> centres;
  std::array<uint8_t, 32> c0;
  std::memcpy(c0.data(), members[next(rng) % members.size()], 32);
  centres.push_back(c0);
  std::vector<int> dist(members.size(), INT_MAX);
  while (int(centres.size()) < branching) {
    double total = 0;
    for (size_t i = 0; i < members.size(); ++i) {
      dist[i] = std::min(dist[i], hamming(members[i], centres.back().data()));
      total += double(dist[i]) * dist[i];
    }
    if (total <= 0) break;
    double pick = double(next(rng) % (1ull << 53)) / double(1ull << 53) * total;
    size_t chosen = members.size() - 1;
    for (size_t i = 0; i < members.size(); ++i) {
      pick -= double(dist[i]) * dist[i];
      if (pick <= 0) { chosen = i; break; }
    }
    std::array<uint8_t, 32> c;
    std::memcpy(c.data(), members[chosen], 32);
    centres.push_back(c);
  }
  std::vector<std::vector<const uint8_t*>> groups;
  for (int it = 0; it < 8; ++it) {
    groups.assign(centres.size(), {});
    for (const uint8_t* d : members) {
      int best = INT_MAX, bi = 0;
      for (size_t k = 0; k < centres.size(); ++k) {
        int h = hamming(d, centres[k].data());
        if (h < best) best = h, bi = int(k);
      }
      groups[bi].push_back(d);
    }
    bool changed = false;
    for (size_t k = 0; k < centres.size(); ++k) {
      if (groups[k].empty()) continue;
      auto c = majority(groups[k]);
      changed |= c != centres[k];
      centres[k] = c;
    }
    if (!changed) break;
  }
  const int first = int(nodes_.size());
  nodes_[node].first_child = first;
  nodes_[node].children = int(centres.size());
  for (auto& c : centres) {
    Node n;
    n.centre = c;
    nodes_.push_back(n);
  }
  for (size_t k = 0; k < centres.size(); ++k) build(first + int(k), groups[k], level + 1, branching, levels, rng);
}

Vocabulary Vocabulary::train(const std::vector<cv::Mat>& documents, int branching, int levels, uint64_t seed) {
  if (branching < 2 || levels < 1) fail("vocabulary: branching ", branching, " and levels ", levels, " must be >= 2, >= 1");
  std::vector<const uint8_t*> all;
  for (const auto& d : documents) {
    if (d.empty()) continue;
    if (d.cols != 32 || d.type() != CV_8U) fail("vocabulary: descriptors must be N x 32 bytes, got ", d.rows, "x", d.cols);
    for (int i = 0; i < d.rows; ++i) all.push_back(d.ptr<uint8_t>(i));
  }
  if (int(all.size()) < 2 * branching) fail("vocabulary: ", all.size(), " descriptors are too few to train ", branching, " clusters");
  Vocabulary v;
  v.nodes_.emplace_back();
  uint64_t rng = seed;
  v.build(0, all, 0, branching, levels, rng);
  // Inverse document frequency: log(N / documents containing the word).
  std::vector<int> df(v.idf_.size(), 0);
  int docs = 0;
  for (const auto& d : documents) {
    if (d.empty()) continue;
    ++docs;
    std::vector<char> seen(v.idf_.size(), 0);
    for (int i = 0; i < d.rows; ++i) seen[v.word(d.ptr<uint8_t>(i))] = 1;
    for (size_t w = 0; w < seen.size(); ++w) df[w] += seen[w];
  }
  for (size_t w = 0; w < df.size(); ++w) v.idf_[w] = float(std::log(double(docs) / std::max(1, df[w])));
  return v;
}

int Vocabulary::word(const uint8_t* d) const {
  if (nodes_.empty()) fail("vocabulary: empty (not trained or loaded)");
  int n = 0;
  while (nodes_[n].children > 0) {
    int best = INT_MAX, bi = nodes_[n].first_child;
    for (int c = nodes_[n].first_child; c < nodes_[n].first_child + nodes_[n].children; ++c) {
      int h = hamming(d, nodes_[c].centre.data());
      if (h < best) best = h, bi = c;
    }
    n = bi;
  }
  return nodes_[n].word;
}

BowVector Vocabulary::transform(const cv::Mat& desc) const {
  std::vector<float> tf(idf_.size(), 0.f);
  for (int i = 0; i < desc.rows; ++i) {
    int w = word(desc.ptr<uint8_t>(i));
    tf[w] += idf_[w];
  }
  BowVector v;
  double sum = 0;
  for (size_t w = 0; w < tf.size(); ++w)
    if (tf[w] > 0) v.emplace_back(int(w), tf[w]), sum += tf[w];
  for (auto& [w, x] : v) x = float(x / sum);
  return v;
}

double Vocabulary::score(const BowVector& a, const BowVector& b) {
  // For normalised vectors, 1 - |a-b|/2 = sum over shared words of (|a|+|b|-|a-b|)/2 = sum of min(a, b).
  double s = 0;
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (a[i].first < b[j].first) ++i;
    else if (b[j].first < a[i].first) ++j;
    else s += std::min(a[i++].second, b[j++].second);
  }
  return s;
}

void Vocabulary::save(const std::filesystem::path& file) const {
  std::ofstream out(file, std::ios::binary);
  if (!out) fail(file.string(), ": cannot write vocabulary");
  uint32_t head[3] = {kMagic, uint32_t(nodes_.size()), uint32_t(idf_.size())};
  out.write(reinterpret_cast<const char*>(head), sizeof head);
  for (const Node& n : nodes_) {
    out.write(reinterpret_cast<const char*>(n.centre.data()), 32);
    int32_t ints[3] = {n.first_child, n.children, n.word};
    out.write(reinterpret_cast<const char*>(ints), sizeof ints);
  }
  out.write(reinterpret_cast<const char*>(idf_.data()), std::streamsize(idf_.size() * sizeof(float)));
  if (!out) fail(file.string(), ": write failed");
}

Vocabulary Vocabulary::load(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) fail(file.string(), ": cannot open vocabulary");
  uint32_t head[3];
  if (!in.read(reinterpret_cast<char*>(head), sizeof head) || head[0] != kMagic)
    fail(file.string(), ": not a vocabulary file (bad magic)");
  Vocabulary v;
  v.nodes_.resize(head[1]);
  v.idf_.resize(head[2]);
  for (Node& n : v.nodes_) {
    int32_t ints[3];
    in.read(reinterpret_cast<char*>(n.centre.data()), 32);
    in.read(reinterpret_cast<char*>(ints), sizeof ints);
    n.first_child = ints[0], n.children = ints[1], n.word = ints[2];
    if (n.children < 0 || (n.children > 0 && (n.first_child <= 0 || n.first_child + n.children > int(head[1]))) ||
        (n.children == 0 && (n.word < 0 || n.word >= int(head[2]))))
      fail(file.string(), ": corrupt vocabulary node");
  }
  in.read(reinterpret_cast<char*>(v.idf_.data()), std::streamsize(v.idf_.size() * sizeof(float)));
  if (!in) fail(file.string(), ": truncated vocabulary");
  return v;
}

}  // namespace chungs::tracking

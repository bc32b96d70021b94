// Parallel sums that give the same bits on every call and at any thread count: the range is cut into
// fixed blocks, each summed in order, and the block sums are added in order. An OpenMP reduction adds
// its threads' partial sums in the order they finish, so the same loss could differ in its last bits
// between two calls; finite-difference checks on a 16-core machine read that as a gradient error.
#pragma once
#include <algorithm>
#include <vector>

namespace chungs {

// body(i, acc) adds element i of [0, n) into acc. Acc{} is zero and Acc has operator+=.
template <class Acc, class Body>
Acc ordered_sum(long long n, Body&& body) {
  constexpr long long kBlock = 4096;
  const long long blocks = n > 0 ? (n + kBlock - 1) / kBlock : 0;
  std::vector<Acc> part(size_t(blocks), Acc{});
#pragma omp parallel for schedule(static)
  for (long long b = 0; b < blocks; ++b) {
    Acc acc{};
    const long long end = std::min(n, (b + 1) * kBlock);
    for (long long i = b * kBlock; i < end; ++i) body(i, acc);
    part[size_t(b)] = acc;
  }
  Acc total{};
  for (const Acc& a : part) total += a;
  return total;
}

}  // namespace chungs

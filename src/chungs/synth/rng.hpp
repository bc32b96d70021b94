// Deterministic random numbers for scene generation. std:: distributions are implementation-defined,
// so the same seed could give different worlds with another standard library; these cannot.
#pragma once
#include <cstdint>

namespace chungs::synth {

// SplitMix64 finaliser: a good 64-bit mixing function, used both as generator step and as hash.
inline uint64_t mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

inline uint64_t hash_combine(uint64_t a, uint64_t b) { return mix64(a ^ (mix64(b) + 0x9e3779b97f4a7c15ULL)); }

class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(mix64(seed + 0x632be59bd9b4e019ULL)) {}
  uint64_t next() {
    state_ += 0x9e3779b97f4a7c15ULL;
    return mix64(state_);
  }
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }  // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  int range(int lo, int hi) { return lo + int(next() % uint64_t(hi - lo + 1)); }  // inclusive
  bool chance(double p) { return uniform() < p; }

 private:
  uint64_t state_;
};

}  // namespace chungs::synth

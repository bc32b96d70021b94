#include "chungs/depth/hole_fill.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "chungs/common/error.hpp"

namespace chungs {

namespace {

struct Level {
  int w = 0, h = 0;
  std::vector<float> value;
  std::vector<uint8_t> known;
};

// Over-relaxed Gauss-Seidel sweeps (SOR) of the 4-neighbour average over the unknown pixels,
// alternating direction: plain Gauss-Seidel needs ~n^2 sweeps across a hole n pixels wide, SOR ~n.
void relax(Level& l, int sweeps) {
  constexpr double kOmega = 1.8;
  for (int s = 0; s < sweeps; ++s) {
    const bool forward = s % 2 == 0;
    for (int yy = 0; yy < l.h; ++yy) {
      const int y = forward ? yy : l.h - 1 - yy;
      for (int xx = 0; xx < l.w; ++xx) {
        const int x = forward ? xx : l.w - 1 - xx;
        const size_t i = size_t(y) * size_t(l.w) + size_t(x);
        if (l.known[i]) continue;
        double sum = 0;
        int n = 0;
        if (x > 0) sum += l.value[i - 1], ++n;
        if (x + 1 < l.w) sum += l.value[i + 1], ++n;
        if (y > 0) sum += l.value[i - size_t(l.w)], ++n;
        if (y + 1 < l.h) sum += l.value[i + size_t(l.w)], ++n;
        if (n > 0) l.value[i] = float((1 - kOmega) * l.value[i] + kOmega * sum / n);
      }
    }
  }
}

}  // namespace

ImageF fill_holes_membrane(const ImageF& inv_depth) {
  if (inv_depth.channels() != 1) fail("hole fill: inverse depth with ", inv_depth.channels(), " channels");
  ImageF out = inv_depth;
  const int w = inv_depth.width(), h = inv_depth.height();
  if (w == 0 || h == 0) return out;
  // Level 0 is the image; each next one averages the known pixels of 2x2 blocks, until one pixel is left.
  std::vector<Level> levels(1);
  levels[0].w = w, levels[0].h = h;
  levels[0].value.assign(inv_depth.vec().begin(), inv_depth.vec().end());
  levels[0].known.resize(levels[0].value.size());
  size_t known = 0;
  for (size_t i = 0; i < levels[0].value.size(); ++i) {
    const float v = levels[0].value[i];
    levels[0].known[i] = v > 0 && std::isfinite(v);
    if (!levels[0].known[i]) levels[0].value[i] = 0;
    known += levels[0].known[i];
  }
  if (known == 0 || known == levels[0].value.size()) return out;
  while (levels.back().w > 1 || levels.back().h > 1) {
    const Level& f = levels.back();
    Level c;
    c.w = (f.w + 1) / 2, c.h = (f.h + 1) / 2;
    c.value.assign(size_t(c.w) * size_t(c.h), 0.f);
    c.known.assign(c.value.size(), 0);
    for (int y = 0; y < c.h; ++y)
      for (int x = 0; x < c.w; ++x) {
        double sum = 0;
        int n = 0;
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx) {
            const int fx = 2 * x + dx, fy = 2 * y + dy;
            if (fx >= f.w || fy >= f.h) continue;
            const size_t i = size_t(fy) * size_t(f.w) + size_t(fx);
            if (f.known[i]) sum += f.value[i], ++n;
          }
        const size_t i = size_t(y) * size_t(c.w) + size_t(x);
        if (n > 0) c.value[i] = float(sum / n), c.known[i] = 1;
      }
    levels.push_back(std::move(c));
  }
  // Coarse to fine: an unknown pixel starts from its parent's value, then relaxes among its level's
  // known pixels. A few sweeps a level carry the values across the level's own pixels; the coarser
  // levels have already carried them across the image.
  for (size_t l = levels.size() - 1; l-- > 0;) {
    Level& f = levels[l];
    const Level& c = levels[l + 1];
    for (int y = 0; y < f.h; ++y)
      for (int x = 0; x < f.w; ++x) {
        const size_t i = size_t(y) * size_t(f.w) + size_t(x);
        if (!f.known[i]) f.value[i] = c.value[size_t(y / 2) * size_t(c.w) + size_t(x / 2)];
      }
    relax(f, l == 0 ? 150 : 60);
  }
  for (size_t i = 0; i < out.vec().size(); ++i)
    if (!levels[0].known[i]) out.vec()[i] = levels[0].value[i];
  return out;
}

}  // namespace chungs

// The pruning rule on the GPU against its CPU twin (select_for_pruning) on random opacities, radii and
// visit counts: the same places in the view in the same order.
#ifdef CHUNGS_WITH_CUDA
#include <gtest/gtest.h>

#include "test_support.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/cuda/devices.hpp"
#include "chungs/optim/cuda/prune.hpp"
#include "chungs/optim/prune.hpp"

namespace chungs {
namespace {

struct Case {
  std::vector<float> opacity, radius;
  std::vector<uint32_t> ids, visits;
};

Case random_case(size_t capacity, size_t n, std::mt19937& rng) {
  Case c;
  std::normal_distribution<float> logit(-2.f, 1.5f);
  std::uniform_real_distribution<float> r(0.f, 900.f);
  std::uniform_int_distribution<uint32_t> v(0, 80);
  c.opacity.resize(capacity);
  for (float& o : c.opacity) o = logit(rng);
  c.opacity[capacity / 3] = NAN;  // a diverged Gaussian is pruned whatever its age
  c.visits.resize(capacity);
  for (uint32_t& x : c.visits) x = v(rng);
  c.visits[capacity / 3] = 0;
  std::vector<uint32_t> all(capacity);
  std::iota(all.begin(), all.end(), 0u);
  std::shuffle(all.begin(), all.end(), rng);
  c.ids.assign(all.begin(), all.begin() + n);
  if (std::find(c.ids.begin(), c.ids.end(), uint32_t(capacity / 3)) == c.ids.end()) c.ids[n / 2] = uint32_t(capacity / 3);
  c.radius.resize(n);
  for (float& x : c.radius) x = r(rng);
  c.radius[n / 4] = NAN;
  return c;
}

TEST(CudaPrune, SelectsWhatTheCpuRuleSelectsInTheSameOrder) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(11);
  cuda::CudaPruneSelector selector;
  for (int round = 0; round < 6; ++round) {
    const size_t capacity = 5000 + 3000 * size_t(round), n = capacity / 2 + 17;
    const Case c = random_case(capacity, n, rng);
    cuda::DeviceArray<float> op, rad;
    cuda::DeviceArray<uint32_t> ids, visits, places;
    op.upload(c.opacity), rad.upload(c.radius), ids.upload(c.ids), visits.upload(c.visits);
    std::vector<uint32_t> in_order(n);  // the list is the caller's own
    std::iota(in_order.begin(), in_order.end(), 0u);
    places.upload(in_order);
    PruneConfig cfg;
    cfg.min_visits = round % 2 ? 30 : 0;
    cfg.min_opacity = round == 4 ? 0.f : 0.05f + 0.02f * float(round);
    cfg.max_radius_fraction = round == 3 ? 0.f : round == 5 ? 2.f : 0.5f;  // round 3: no size test; 5: the default
    const float* o = c.opacity.data();
    const GaussianArrays<float> view{o, o, o, o, o, capacity};
    const bool with_radius = round != 2;
    const std::vector<uint32_t> want =
        select_for_pruning(cfg, view, c.ids, with_radius ? std::span<const float>(c.radius) : std::span<const float>(),
                           1241, cfg.min_visits > 0 ? std::span<const uint32_t>(c.visits) : std::span<const uint32_t>());
    std::vector<uint32_t> got;
    selector.select(cfg, op.data(), capacity, ids.data(), n, with_radius ? rad.data() : nullptr, 1241,
                    cfg.min_visits > 0 ? visits.data() : nullptr, places.data(), got);
    ASSERT_FALSE(want.empty()) << "round " << round;
    ASSERT_LT(want.size(), n) << "round " << round;
    EXPECT_EQ(got, want) << "round " << round;
  }
}

TEST(CudaPrune, AListInSlotOrderReportsThePlacesOfTheCallersList) {
  // The step renders its list in slot order (SlotOrder) and must get back places in the list it wrote.
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(23);
  cuda::CudaPruneSelector selector;
  const size_t capacity = 20000, n = 9000;
  const Case c = random_case(capacity, n, rng);
  std::vector<uint32_t> places(n);
  std::iota(places.begin(), places.end(), 0u);
  std::sort(places.begin(), places.end(), [&](uint32_t a, uint32_t b) { return c.ids[a] < c.ids[b]; });
  std::vector<uint32_t> sorted(n);
  std::vector<float> sorted_radius(n);
  for (size_t i = 0; i < n; ++i) sorted[i] = c.ids[places[i]], sorted_radius[i] = c.radius[places[i]];
  cuda::DeviceArray<float> op(c.opacity), rad(sorted_radius);
  cuda::DeviceArray<uint32_t> ids(sorted), where(places), visits(c.visits);
  PruneConfig cfg;
  cfg.min_opacity = 0.1f;
  cfg.max_radius_fraction = 0.5f;
  cfg.min_visits = 30;
  const float* o = c.opacity.data();
  const GaussianArrays<float> view{o, o, o, o, o, capacity};
  const std::vector<uint32_t> want = select_for_pruning(cfg, view, c.ids, c.radius, 1241, c.visits);
  std::vector<uint32_t> got;
  selector.select(cfg, op.data(), capacity, ids.data(), n, rad.data(), 1241, visits.data(), where.data(),
                  got);
  ASSERT_GT(want.size(), 10u);
  EXPECT_EQ(got, want);
}

TEST(CudaPrune, AnEmptyViewSelectsNothingAndMissingVisitsAreRefused) {
  CHUNGS_REQUIRE_GPU();
  cuda::CudaPruneSelector selector;
  cuda::DeviceArray<float> op(4);
  cuda::DeviceArray<uint32_t> ids(4);
  std::vector<uint32_t> got{7};
  selector.select(PruneConfig{}, op.data(), 4, ids.data(), 0, nullptr, 100, nullptr, ids.data(), got);
  EXPECT_TRUE(got.empty());
  PruneConfig aged;
  aged.min_visits = 5;
  EXPECT_THROW(selector.select(aged, op.data(), 4, ids.data(), 4, nullptr, 100, nullptr, ids.data(), got),
               Error);
}

}  // namespace
}  // namespace chungs
#endif

// The fused CUDA sparse Adam against its CPU twin on random parameters, moments and gradients.
#ifdef CHUNGS_WITH_CUDA
#include <gtest/gtest.h>

#include "test_support.hpp"

#include <algorithm>
#include <random>
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/cuda/devices.hpp"
#include "chungs/optim/cuda/adam.hpp"
#include "chungs/render/cuda/device_buffer.hpp"

namespace chungs {
namespace {

void fill(std::vector<float>& v, std::mt19937& rng, float scale, bool positive = false) {
  std::normal_distribution<float> N(0, 1);
  for (float& x : v) x = positive ? scale * std::abs(N(rng)) : scale * N(rng);
}

GaussianBlock random_block(size_t n, std::mt19937& rng) {
  GaussianBlock b;
  b.resize(n);
  for (auto* p : {&b.params, &b.adam_m, &b.adam_v})
    for (auto* v : {&p->mean, &p->log_scale, &p->rotation, &p->opacity, &p->sh})
      fill(*v, rng, 0.1f, p == &b.adam_v);
  std::uniform_int_distribution<uint32_t> steps(0, 50);
  std::uniform_real_distribution<float> U(0.01f, 1.f);
  for (auto& s : b.adam_steps) s = steps(rng);
  for (auto& f : b.lr_position_factor) f = U(rng);
  return b;
}

// Device copies of a block's arrays.
struct DeviceBlock {
  cuda::DeviceArray<float> p[5], m[5], v[5];
  cuda::DeviceArray<uint32_t> steps;
  cuda::DeviceArray<float> factor;
  size_t n;
  explicit DeviceBlock(const GaussianBlock& b) : n(b.size()) {
    const GaussianParams* src[3] = {&b.params, &b.adam_m, &b.adam_v};
    cuda::DeviceArray<float>* dst[3] = {p, m, v};
    for (int s = 0; s < 3; ++s) {
      dst[s][0].upload(src[s]->mean), dst[s][1].upload(src[s]->log_scale), dst[s][2].upload(src[s]->rotation);
      dst[s][3].upload(src[s]->opacity), dst[s][4].upload(src[s]->sh);
    }
    steps.upload(b.adam_steps);
    factor.upload(b.lr_position_factor);
  }
  static GaussianArraysMut<float> view(cuda::DeviceArray<float>* a, size_t n) {
    return {a[0].data(), a[1].data(), a[2].data(), a[3].data(), a[4].data(), n};
  }
  AdamState state() { return {view(m, n), view(v, n), steps.data(), factor.data(), n}; }
  void download(GaussianBlock& b) const {
    GaussianParams* dst[3] = {&b.params, &b.adam_m, &b.adam_v};
    const cuda::DeviceArray<float>* src[3] = {p, m, v};
    for (int s = 0; s < 3; ++s) {
      src[s][0].download(dst[s]->mean), src[s][1].download(dst[s]->log_scale);
      src[s][2].download(dst[s]->rotation), src[s][3].download(dst[s]->opacity),
          src[s][4].download(dst[s]->sh);
    }
    steps.download(b.adam_steps);
    factor.download(b.lr_position_factor);
  }
};

// ||a - b|| / ||b||: elementwise ratios would flag the moments where beta1 m and (1 - beta1) g
// nearly cancel, and fused multiply-adds round those differently.
double max_rel(const std::vector<float>& a, const std::vector<float>& b) {
  double num = 0, den = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    num += (double(a[i]) - b[i]) * (double(a[i]) - b[i]);
    den += double(b[i]) * b[i];
  }
  return std::sqrt(num / den);
}

TEST(CudaAdam, MatchesCpuTwinOnSparseVisibleSubset) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(7);
  const size_t capacity = 3000, n = 2000;
  GaussianBlock cpu = random_block(capacity, rng);
  DeviceBlock gpu(cpu);
  std::vector<uint32_t> ids(capacity);
  for (size_t i = 0; i < capacity; ++i) ids[i] = uint32_t(i);
  std::shuffle(ids.begin(), ids.end(), rng);
  ids.resize(n);
  std::vector<uint8_t> visible(n);
  for (auto& v : visible) v = rng() % 4 != 0;
  cuda::DeviceArray<uint32_t> dids(ids);
  cuda::DeviceArray<uint8_t> dvis(visible);
  AdamConfig cfg;
  cfg.lr_position = 0.01f;  // large enough that the position step shows against float rounding
  for (int step = 0; step < 3; ++step) {
    GaussianGrads<float> g;
    g.resize(n);
    for (auto* v : {&g.mean, &g.log_scale, &g.rotation, &g.opacity, &g.sh}) fill(*v, rng, 0.5f);
    sparse_adam_step(cfg, mut_view_of(cpu.params), adam_state_of(cpu), ids, visible, g);
    cuda::DeviceArray<float> gm(g.mean), gs(g.log_scale), gr(g.rotation), go(g.opacity), gsh(g.sh);
    cuda::sparse_adam_step(cfg, DeviceBlock::view(gpu.p, capacity), gpu.state(), dids.data(), dvis.data(), n,
                           {n, gm.data(), gs.data(), gr.data(), go.data(), gsh.data()});
  }
  GaussianBlock got = cpu;
  gpu.download(got);
  EXPECT_EQ(got.adam_steps, cpu.adam_steps);
  EXPECT_LT(max_rel(got.lr_position_factor, cpu.lr_position_factor), 1e-5);
  const GaussianParams* a[3] = {&got.params, &got.adam_m, &got.adam_v};
  const GaussianParams* b[3] = {&cpu.params, &cpu.adam_m, &cpu.adam_v};
  for (int s = 0; s < 3; ++s) {
    SCOPED_TRACE(s);
    EXPECT_LT(max_rel(a[s]->mean, b[s]->mean), 1e-5);
    EXPECT_LT(max_rel(a[s]->log_scale, b[s]->log_scale), 1e-5);
    EXPECT_LT(max_rel(a[s]->rotation, b[s]->rotation), 1e-5);
    EXPECT_LT(max_rel(a[s]->opacity, b[s]->opacity), 1e-5);
    EXPECT_LT(max_rel(a[s]->sh, b[s]->sh), 1e-5);
  }
}

TEST(CudaAdam, IndexOutOfRangeThrowsAndLeavesOthersValid) {
  CHUNGS_REQUIRE_GPU();
  std::mt19937 rng(8);
  GaussianBlock blk = random_block(10, rng);
  DeviceBlock gpu(blk);
  const std::vector<uint32_t> ids = {1, 2, 10};
  const std::vector<uint8_t> visible = {1, 1, 1};
  cuda::DeviceArray<uint32_t> dids(ids);
  cuda::DeviceArray<uint8_t> dvis(visible);
  cuda::DeviceArray<float> gm(std::vector<float>(9, 1.f)), gs(std::vector<float>(9, 1.f)),
      gr(std::vector<float>(12, 1.f)), go(std::vector<float>(3, 1.f)),
      gsh(std::vector<float>(3 * kShFloats, 1.f));
  try {
    cuda::sparse_adam_step(AdamConfig{}, DeviceBlock::view(gpu.p, 10), gpu.state(), dids.data(), dvis.data(),
                           3, {3, gm.data(), gs.data(), gr.data(), go.data(), gsh.data()});
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("index 2"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace chungs
#endif

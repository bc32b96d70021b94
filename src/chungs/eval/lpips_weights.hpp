// The weights LPIPS (v0.1, 'alex') needs: torchvision AlexNet's five feature convolutions and the
// five non-negative 1x1 heads LPIPS learned on top of them. They are read from a DCLPIPS1 file
// (format in LPIPS_WEIGHTS.md, written by scripts/lpips_convert.py from the published .pth files).
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace chungs {

struct AlexConvShape {
  int out, in, kernel, stride, pad;
  int torch_index;  // position in torchvision's alexnet().features, which names the tensors
};

// torchvision's AlexNet (the single-tower variant LPIPS uses), conv1 to conv5.
inline constexpr std::array<AlexConvShape, 5> kAlexConv = {{
    {64, 3, 11, 4, 2, 0},
    {192, 64, 5, 1, 2, 3},
    {384, 192, 3, 1, 1, 6},
    {256, 384, 3, 1, 1, 8},
    {256, 256, 3, 1, 1, 10},
}};
// The smallest image side the five layers accept (the two poolings need 3 pixels each).
inline constexpr int kLpipsMinSide = 31;

struct ConvWeights {
  std::vector<float> weight;  // [out][in][kernel][kernel], PyTorch's order
  std::vector<float> bias;    // [out]
};

struct LpipsWeights {
  std::array<ConvWeights, 5> conv;
  std::array<std::vector<float>, 5> lin;  // per-channel weight of each layer's squared difference
};

inline constexpr char kLpipsMagic[8] = {'D', 'C', 'L', 'P', 'I', 'P', 'S', '1'};
inline constexpr uint32_t kLpipsFormatVersion = 1;

// CRC-32 as zlib computes it (reflected polynomial 0xEDB88320), so Python's zlib.crc32 agrees.
uint32_t crc32(const void* data, size_t len, uint32_t crc = 0);

// The 15 tensor names and shapes of a file, in file order: each conv's weight and bias, then the heads.
struct LpipsTensorSpec {
  std::string name;
  std::vector<uint32_t> shape;
};
std::vector<LpipsTensorSpec> lpips_tensor_specs();

// Throws Error naming the file for anything but a complete, undamaged file of exactly these tensors,
// including negative head weights (the published ones are clamped to >= 0, so such a file is not one).
LpipsWeights read_lpips_weights(const std::filesystem::path& file);
// The inverse, for tests and tools; sizes must match kAlexConv.
void write_lpips_weights(const std::filesystem::path& file, const LpipsWeights& w);
std::string lpips_weights_bytes(const LpipsWeights& w);

}  // namespace chungs

// A tiny but valid dataset in the process's temporary folder, for the dataset-reader targets: the
// readers open folders, so each input replaces one of the skeleton's text files (the first byte
// picks which), the reader opens the folder and loads frame 0, and the file gets its valid text
// back, so the next input finds the rest of the dataset intact.
#pragma once
#include <string>
#include <utility>
#include <vector>

#include "chungs/datasets/dataset.hpp"
#include "chungs/image/image_io.hpp"
#include "fuzz_input.hpp"

namespace chungs::fuzz {

// Images are tiny: every input decodes one or two of them, and their content does not matter.
constexpr int kSkeletonWidth = 8, kSkeletonHeight = 6;

inline void write_gray(const fs::path& file) {
  Image8 im(kSkeletonWidth, kSkeletonHeight, 1);
  for (size_t i = 0; i < im.size(); ++i) im.data()[i] = uint8_t(37 * i);
  write_png(file, im);
}

inline void write_rgb(const fs::path& file) {
  Image8 im(kSkeletonWidth, kSkeletonHeight, 3);
  for (size_t i = 0; i < im.size(); ++i) im.data()[i] = uint8_t(11 * i);
  write_image(file, im);
}

// Depth in whatever units the reader divides by; 1000-3000 is metres for each of them.
inline void write_depth(const fs::path& file) {
  Image16 im(kSkeletonWidth, kSkeletonHeight, 1);
  for (size_t i = 0; i < im.size(); ++i) im.data()[i] = uint16_t(1000 + 40 * i);
  write_png(file, im);
}

class DatasetSkeleton {
 public:
  // `texts`: the fuzzable files (relative to `root`) with their valid contents; `images` writes the
  // rest once.
  template <typename WriteImages>
  DatasetSkeleton(fs::path root, std::vector<std::pair<fs::path, std::string>> texts, WriteImages images)
      : root_(temp_folder().dir() / root), texts_(std::move(texts)) {
    images(root_);
    for (const auto& [name, text] : texts_) temp_folder().write(root_ / name, text);
  }

  const fs::path& root() const { return root_; }

  // Replaces the picked file by the input, opens the dataset and reads its first frame.
  template <typename Open>
  void run(const uint8_t* data, size_t size, Open open) const {
    if (size < 1) return;
    const auto& [name, text] = texts_[data[0] % texts_.size()];
    temp_folder().write(root_ / name, data + 1, size - 1);
    // A listed image may be anywhere (an absolute path in an index file), so the error has to name
    // a path, not necessarily one in this folder.
    refusing(std::string_view("/"), [&] {
      const std::unique_ptr<Dataset> dataset = open(root_);
      for (size_t i = 0; i < dataset->size(); ++i) {
        dataset->timestamp(i);
        dataset->gt_pose(i);
      }
      if (dataset->size() > 0) dataset->frame(0);
    });
    temp_folder().write(root_ / name, text);
  }

 private:
  fs::path root_;
  std::vector<std::pair<fs::path, std::string>> texts_;
};

}  // namespace chungs::fuzz

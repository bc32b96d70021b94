// Any dataset through its left (or only) camera alone (issue 25): the right image, the stereo baseline and the
// sensor depth are dropped from every frame, so the tracker and the mapper see what one camera gives.
// KITTI keeps its left camera, EuRoC cam0, TUM and Replica their RGB images; ground truth stays for evaluation.
#pragma once
#include <memory>
#include <string>

#include "chungs/datasets/dataset.hpp"

namespace chungs {

// How a dataset is read: "auto" (everything it has) or "mono" (the left camera only).
// Throws Error naming the value when it is neither.
enum class InputMode { Auto, Mono };
InputMode parse_input_mode(const std::string& s);

// The dataset as `mode` reads it; `auto` hands the dataset back unchanged.
std::unique_ptr<Dataset> with_input_mode(std::unique_ptr<Dataset> dataset, InputMode mode);

}  // namespace chungs

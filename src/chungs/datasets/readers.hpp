// One opener per on-disk format; open_dataset() dispatches on the kind. Each throws Error naming
// the file (and line) at fault when the folder is missing, corrupt or inconsistent.
#pragma once
#include <filesystem>
#include <memory>

#include "chungs/datasets/dataset.hpp"

namespace chungs::ds {

std::unique_ptr<Dataset> open_kitti(const std::filesystem::path& path);
std::unique_ptr<Dataset> open_tum(const std::filesystem::path& path);
std::unique_ptr<Dataset> open_replica(const std::filesystem::path& path);
std::unique_ptr<Dataset> open_euroc(const std::filesystem::path& path);
std::unique_ptr<Dataset> open_3dmatch(const std::filesystem::path& path);

}  // namespace chungs::ds

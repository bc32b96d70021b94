// Evaluation results as JSON (nlohmann::json) for reports and `diskchungs eval --json`.
// Non-finite numbers have no JSON spelling: they are written as null (an identical image pair's
// PSNR of +inf, an empty mask's NaN); the text output prints them as inf / nan.
#pragma once
#include <filesystem>
#include <optional>

#include <nlohmann/json.hpp>

#include "chungs/eval/image_metrics.hpp"
#include "chungs/eval/image_set.hpp"
#include "chungs/eval/trajectory_metrics.hpp"

namespace chungs {

nlohmann::json json_number(double v);  // null when not finite
nlohmann::json to_json(const ErrorStats& s);
nlohmann::json to_json(const Sim3& s);  // {scale, rotation [qw qx qy qz], translation [x y z]}
// {alignment, matched, transform, ...stats}; per-pose errors only when asked (they can be long).
nlohmann::json to_json(const AteResult& r, bool with_errors = false);
nlohmann::json to_json(const RpeResult& r);  // {delta, translation: stats (m), rotation_deg: stats}
nlohmann::json to_json(const ImageMetrics& m);
// {count, mean_psnr, mean_ssim, mean_mse, mean_lpips, images: [...]}; without LPIPS weights
// mean_lpips and each image's lpips are null and lpips_unavailable says why.
nlohmann::json to_json(const ImageSetResult& r);
nlohmann::json lpips_json(const std::optional<double>& v);

// Writes `j` (indented) through a temporary file renamed into place; Error names the file.
void write_json(const std::filesystem::path& file, const nlohmann::json& j);

}  // namespace chungs

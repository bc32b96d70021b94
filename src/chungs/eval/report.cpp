#include "chungs/eval/report.hpp"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>

#include "chungs/common/error.hpp"

namespace chungs {

using nlohmann::json;

json json_number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json to_json(const ErrorStats& s) {
  return {{"rmse", json_number(s.rmse)},     {"mean", json_number(s.mean)}, {"median", json_number(s.median)},
          {"std", json_number(s.std)},       {"min", json_number(s.min)},   {"max", json_number(s.max)},
          {"count", s.count}};
}

json to_json(const Sim3& s) {
  return {{"scale", s.s},
          {"rotation_wxyz", {s.q.w(), s.q.x(), s.q.y(), s.q.z()}},
          {"translation", {s.t.x(), s.t.y(), s.t.z()}}};
}

json to_json(const AteResult& r, bool with_errors) {
  json j = to_json(r.stats);
  j["alignment"] = alignment_name(r.align);
  j["matched"] = r.matched();
  j["transform"] = to_json(r.alignment);
  if (with_errors) j["errors"] = r.errors;
  return j;
}

json to_json(const RpeResult& r) {
  return {{"delta", r.delta}, {"translation", to_json(r.trans)}, {"rotation_deg", to_json(r.rot_deg)}};
}

json to_json(const ImageMetrics& m) {
  return {{"psnr", json_number(m.psnr)}, {"ssim", json_number(m.ssim)}, {"mse", json_number(m.mse)},
          {"pixels", m.pixels}};
}

json lpips_json(const std::optional<double>& v) { return v ? json_number(*v) : json(nullptr); }

json to_json(const ImageSetResult& r) {
  json images = json::array();
  for (const auto& im : r.images) {
    json j = to_json(im.metrics);
    j["lpips"] = lpips_json(im.lpips);
    j["name"] = im.pair.name;
    j["ref"] = im.pair.ref.string();
    j["test"] = im.pair.test.string();
    images.push_back(std::move(j));
  }
  json j = {{"count", r.images.size()},          {"mean_psnr", json_number(r.mean_psnr)},
            {"mean_ssim", json_number(r.mean_ssim)}, {"mean_mse", json_number(r.mean_mse)},
            {"mean_lpips", lpips_json(r.mean_lpips)}, {"infinite_psnr", r.infinite_psnr},
            {"images", std::move(images)}};
  if (!r.mean_lpips) j["lpips_unavailable"] = r.lpips_unavailable;
  return j;
}

void write_json(const std::filesystem::path& file, const json& j) {
  prepare_output_file(file, "JSON file");
  const std::filesystem::path tmp = file.string() + ".tmp";
  {
    std::ofstream out(tmp);
    if (!out) fail(tmp.string(), ": cannot open for writing (", std::strerror(errno), ")");
    out << j.dump(2) << "\n";
    out.flush();
    if (!out) fail(tmp.string(), ": write failed (", std::strerror(errno), ")");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, file, ec);
  if (ec) fail(file.string(), ": cannot replace (", ec.message(), ")");
}

}  // namespace chungs

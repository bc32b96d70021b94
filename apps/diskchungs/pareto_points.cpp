#include "pareto_points.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>

#include "chungs/common/error.hpp"
#include "chungs/mapping/mapper_config.hpp"

namespace chungs::app {
namespace {

std::string speed_text(double speed) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", speed);
  return buf;
}

std::vector<std::string> entries(const std::string& text, const char* flag) {
  if (text.empty()) fail(flag, " must list at least one value (or none), got an empty list");
  std::vector<std::string> out;
  size_t begin = 0;
  while (true) {
    const size_t end = text.find(',', begin);
    out.push_back(text.substr(begin, end == std::string::npos ? std::string::npos : end - begin));
    if (out.back().empty()) fail(flag, " has an empty entry in '", text, "'");
    if (end == std::string::npos) return out;
    begin = end + 1;
  }
}

template <class T>
bool parse_whole(const std::string& s, T& v) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

nlohmann::json lpips_or_null(const nlohmann::json& eval) {
  const auto it = eval.find("mean_lpips");
  return it != eval.end() && it->is_number() ? *it : nlohmann::json();
}

nlohmann::json quality(const nlohmann::json& report, const char* key) {
  if (!report.contains(key)) return nullptr;
  const nlohmann::json& e = report[key];
  // No frame scored (a run of fewer frames than the hold-out period): no quality, not a quality of 0.
  const bool scored = e.value("count", 0) > 0;
  nlohmann::json q = {{"psnr", scored ? e.value("mean_psnr", nlohmann::json()) : nlohmann::json()},
                      {"ssim", scored ? e.value("mean_ssim", nlohmann::json()) : nlohmann::json()},
                      {"lpips", scored ? lpips_or_null(e) : nlohmann::json()},
                      {"frames", e.value("count", 0)}};
  if (q["lpips"].is_null()) q["lpips_unavailable"] = e.value("lpips_unavailable", std::string("not in the report"));
  return q;
}

std::string cell(const nlohmann::json& v, const char* format) {
  if (!v.is_number()) return "";
  char buf[48];
  std::snprintf(buf, sizeof buf, format, v.get<double>());
  return buf;
}

const nlohmann::json& at(const nlohmann::json& row, const char* group, const char* key) {
  static const nlohmann::json null;
  return row.contains(group) && row[group].is_object() && row[group].contains(key) ? row[group][key] : null;
}

}  // namespace

std::string ParetoSetting::folder() const {
  return anytime ? "anytime-" + speed_text(speed) : "fixed-" + std::to_string(iterations);
}

std::string ParetoSetting::describe() const {
  return anytime ? "anytime " + speed_text(speed) + "x speed" : "fixed " + std::to_string(iterations) + " steps per keyframe";
}

std::vector<ParetoSetting> parse_pareto_settings(const std::string& iterations, const std::string& speeds) {
  std::vector<ParetoSetting> out;
  if (iterations != "none")
    for (const std::string& e : entries(iterations, "--iterations")) {
      ParetoSetting s;
      if (!parse_whole(e, s.iterations) || s.iterations < 0)
        fail("--iterations entries must be whole numbers of steps, 0 or more, got '", e, "'");
      out.push_back(s);
    }
  if (speeds != "none")
    for (const std::string& e : entries(speeds, "--speeds")) {
      ParetoSetting s;
      s.anytime = true;
      if (!parse_whole(e, s.speed) || !(s.speed >= kMinSpeed && s.speed <= kMaxSpeed))
        fail("--speeds entries must be factors from ", kMinSpeed, " to ", kMaxSpeed, ", got '", e, "'");
      out.push_back(s);
    }
  if (out.empty()) fail("--iterations and --speeds are both none: there is no point to map");
  // Two entries of one folder would map the same point twice (10 and 010, 1 and 1.0).
  for (size_t i = 0; i < out.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (out[i].folder() == out[j].folder())
        fail(out[i].anytime ? "--speeds" : "--iterations", " lists ", out[i].describe(), " twice");
  return out;
}

nlohmann::json pareto_row(const ParetoSetting& s, const nlohmann::json& r) {
  const nlohmann::json& t = r["time"];
  nlohmann::json row = {
      {"mode", s.anytime ? "anytime" : "fixed"},
      {"setting", s.anytime ? nlohmann::json(s.speed) : nlohmann::json(s.iterations)},
      {"folder", s.folder()},
      {"processing_fps", t.value("processing_fps", NAN)},
      {"mapping_s", t.value("mapping_s", NAN)},
      {"evaluation_s", t.contains("evaluation_s") ? t["evaluation_s"] : nlohmann::json()},
      {"intake_kmh", t.contains("intake_kmh") ? t["intake_kmh"] : nlohmann::json()},
      {"frames", r.value("frames", 0)},
      {"keyframes", r.value("keyframes", 0)},
      {"steps_per_keyframe_mean", r.contains("pacing") ? r["pacing"].value("steps_per_keyframe_mean", NAN) : NAN},
      {"gaussians", r["gaussians"].value("total", 0)},
      {"device", r.value("device", std::string())},
      {"held_out", quality(r, "held_out")},
      {"keyframes_eval", quality(r, "keyframes_eval")}};
  if (r.contains("stopped")) row["stopped"] = r["stopped"];
  return row;
}

std::string pareto_csv(const std::vector<nlohmann::json>& rows) {
  std::string out =
      "mode,setting,processing_fps,mapping_s,steps_per_keyframe_mean,gaussians,held_out_psnr,held_out_ssim,"
      "held_out_lpips,keyframe_psnr,keyframe_ssim,keyframe_lpips,intake_kmh,folder\n";
  for (const auto& r : rows) {
    // An LPIPS cell stays empty without weights; pareto.json says why.
    out += r["mode"].get<std::string>() + "," + cell(r["setting"], "%g") + "," + cell(r["processing_fps"], "%.4f") +
           "," + cell(r["mapping_s"], "%.2f") + "," + cell(r["steps_per_keyframe_mean"], "%.2f") + "," +
           cell(r["gaussians"], "%.0f") + "," + cell(at(r, "held_out", "psnr"), "%.4f") + "," +
           cell(at(r, "held_out", "ssim"), "%.5f") + "," + cell(at(r, "held_out", "lpips"), "%.5f") + "," +
           cell(at(r, "keyframes_eval", "psnr"), "%.4f") + "," + cell(at(r, "keyframes_eval", "ssim"), "%.5f") +
           "," + cell(at(r, "keyframes_eval", "lpips"), "%.5f") + "," + cell(r["intake_kmh"], "%.2f") + "," +
           r["folder"].get<std::string>() + "\n";
  }
  return out;
}

std::string pareto_table(const std::vector<nlohmann::json>& rows) {
  char line[256];
  std::snprintf(line, sizeof line, "%-8s %8s %9s %9s %8s %10s | %8s %8s %8s | %8s %8s\n", "mode", "setting",
                "proc FPS", "mapping s", "steps/kf", "Gaussians", "HO PSNR", "HO SSIM", "HO LPIPS", "KF PSNR",
                "KF SSIM");
  std::string out = line;
  auto num = [](const nlohmann::json& v, const char* f) {
    const std::string c = cell(v, f);
    return c.empty() ? std::string("n/a") : c;
  };
  for (const auto& r : rows) {
    std::snprintf(line, sizeof line, "%-8s %8s %9s %9s %8s %10s | %8s %8s %8s | %8s %8s\n",
                  r["mode"].get<std::string>().c_str(), num(r["setting"], r["mode"] == "fixed" ? "%g" : "%gx").c_str(),
                  num(r["processing_fps"], "%.3f").c_str(), num(r["mapping_s"], "%.1f").c_str(),
                  num(r["steps_per_keyframe_mean"], "%.1f").c_str(), num(r["gaussians"], "%.0f").c_str(),
                  num(at(r, "held_out", "psnr"), "%.3f").c_str(), num(at(r, "held_out", "ssim"), "%.4f").c_str(),
                  num(at(r, "held_out", "lpips"), "%.4f").c_str(), num(at(r, "keyframes_eval", "psnr"), "%.3f").c_str(),
                  num(at(r, "keyframes_eval", "ssim"), "%.4f").c_str());
    out += line;
  }
  for (const auto& r : rows)
    if (at(r, "held_out", "lpips").is_null() && at(r, "held_out", "lpips_unavailable").is_string()) {
      out += "LPIPS: not available (" + at(r, "held_out", "lpips_unavailable").get<std::string>() + ")\n";
      break;
    }
  return out;
}

ParetoPoint pareto_plot_point(const nlohmann::json& row) {
  ParetoPoint p;
  p.anytime = row["mode"] == "anytime";
  char label[64];
  if (p.anytime && row["intake_kmh"].is_number())
    std::snprintf(label, sizeof label, "%gX %.0f KM/H", row["setting"].get<double>(), row["intake_kmh"].get<double>());
  else
    std::snprintf(label, sizeof label, p.anytime ? "%gX" : "%g", row["setting"].get<double>());
  p.label = label;
  p.fps = row["processing_fps"].is_number() ? row["processing_fps"].get<double>() : NAN;
  auto q = [](const nlohmann::json& e) {
    ParetoQuality out;
    if (!e.is_object()) return ParetoQuality{NAN, NAN, std::nullopt};
    out.psnr = e["psnr"].is_number() ? e["psnr"].get<double>() : NAN;
    out.ssim = e["ssim"].is_number() ? e["ssim"].get<double>() : NAN;
    if (e["lpips"].is_number()) out.lpips = e["lpips"].get<double>();
    return out;
  };
  p.held_out = q(row["held_out"]);
  p.keyframes = q(row["keyframes_eval"]);
  return p;
}

}  // namespace chungs::app

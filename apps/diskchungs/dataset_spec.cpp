#include "dataset_spec.hpp"

#include <cerrno>
#include <cstdlib>
#include <set>

#include "chungs/common/decimal.hpp"
#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/synth/street_dataset.hpp"

namespace chungs {

namespace {

constexpr const char* kStreet = "synth-street";

double number(const std::string& spec, const std::string& key, const std::string& value) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(value.c_str(), &end);
  if (!shows_a_decimal_number(value) || *end != '\0' || errno == ERANGE)
    fail("dataset '", spec, "': value '", value, "' of ", key, " is not a number");
  return v;
}

uint64_t whole(const std::string& spec, const std::string& key, const std::string& value, uint64_t max,
               uint64_t min = 0) {
  char* end = nullptr;
  errno = 0;
  const unsigned long long v = std::strtoull(value.c_str(), &end, 10);
  if (value.empty() || value[0] == '-' || *end != '\0' || errno == ERANGE || v < min || v > max)
    fail("dataset '", spec, "': value '", value, "' of ", key, " is not a whole number from ", min, " to ", max);
  return v;
}

std::unique_ptr<Dataset> open_street(const std::string& spec, const std::string& args) {
  synth::StreetDatasetOptions o;
  bool have_width = false, have_height = false;
  std::set<std::string> seen;
  size_t at = 0;
  while (at < args.size()) {
    size_t comma = args.find(',', at);
    if (comma == std::string::npos) comma = args.size();
    const std::string item = args.substr(at, comma - at);
    at = comma + 1;
    const size_t eq = item.find('=');
    if (eq == std::string::npos || eq == 0)
      fail("dataset '", spec, "': '", item,
           "' is not key=value (keys: length, width, height, seed, frames, depth, traffic, startup)");
    const std::string key = item.substr(0, eq), value = item.substr(eq + 1);
    if (!seen.insert(key).second) fail("dataset '", spec, "': key '", key, "' is given twice");
    if (key == "length") {
      o.street.length_m = number(spec, key, value);
      if (!(o.street.length_m > 0) || o.street.length_m > synth::kMaxStreetLengthM)
        fail("dataset '", spec, "': length ", value, " m must be in (0, ", synth::kMaxStreetLengthM, "]");
    } else if (key == "width") {
      o.width = int(whole(spec, key, value, 16384));
      have_width = true;
    } else if (key == "height") {
      o.height = int(whole(spec, key, value, 16384));
      have_height = true;
    } else if (key == "seed") {
      o.street.seed = whole(spec, key, value, UINT64_MAX);
    } else if (key == "frames") {
      // From 1: 0 is the reader's "every frame of the route", which a typed 0 must not become.
      o.max_frames = whole(spec, key, value, uint64_t(1) << 32, 1);
    } else if (key == "depth") {
      if (value != "0" && value != "1")
        fail("dataset '", spec, "': value '", value, "' of depth must be 0 or 1");
      o.depth = value == "1";
    } else if (key == "traffic") {
      o.street.traffic = number(spec, key, value);
      if (!(o.street.traffic >= 0 && o.street.traffic <= 50))
        fail("dataset '", spec, "': traffic ", value, " (moving vehicles per 100 m) must be from 0 to 50");
    } else if (key == "startup") {
      if (value != "none" && value != "cross" && value != "turn" && value != "cross+turn")
        fail("dataset '", spec, "': value '", value, "' of startup must be none, cross, turn or cross+turn");
      o.street.startup_cross = value == "cross" || value == "cross+turn";
      o.street.start_turn = value == "turn" || value == "cross+turn";
    } else {
      fail("dataset '", spec, "': unknown key '", key,
           "' (keys: length, width, height, seed, frames, depth, traffic, startup)");
    }
  }
  if (have_width != have_height) fail("dataset '", spec, "': give both width and height, or neither");
  auto dataset = std::make_unique<synth::StreetDataset>(o);
  // frames is a most: a street shorter than asked for gave fewer frames without a word.
  if (o.max_frames > dataset->size())
    log::warn("dataset '", spec, "': frames=", o.max_frames, " is more than the street's ", dataset->size(),
              " frames; all ", dataset->size(), " are used");
  return dataset;
}

}  // namespace

std::unique_ptr<Dataset> open_dataset_spec(const std::string& spec) {
  const std::string prefix = std::string(kStreet) + ":";
  if (spec == kStreet) return open_street(spec, "");
  if (spec.rfind(prefix, 0) == 0) return open_street(spec, spec.substr(prefix.size()));
  return open_dataset(spec);
}

}  // namespace chungs

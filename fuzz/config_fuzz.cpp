// The YAML settings (config/config.hpp) as `--config FILE` loads them. A file that loads must also
// print (`info --config`) as YAML that loads back to the same text: users start from that print.
#include <cstdio>
#include <cstdlib>

#include "chungs/config/config.hpp"
#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto file = chungs::fuzz::temp_folder().write("config.yaml", data, size);
  chungs::Config loaded;
  bool ok = false;
  chungs::fuzz::refusing(file, [&] {
    loaded = chungs::load_config(file);
    ok = true;
  });
  if (!ok) return 0;
  const std::string printed = chungs::config_to_yaml(loaded);
  try {
    const std::string again = chungs::config_to_yaml(chungs::config_from_yaml(printed, "printed"));
    if (again != printed) {
      std::fprintf(stderr, "printed config reads back differently:\n%s---\n%s", printed.c_str(), again.c_str());
      std::abort();
    }
  } catch (const chungs::Error& e) {
    std::fprintf(stderr, "printed config does not load: %s\n%s", e.what(), printed.c_str());
    std::abort();
  }
  return 0;
}

// run_state.json, as `run --resume` reads it (mapping/map_state.hpp, run_pipeline.cpp): parsed,
// checked, asked for the frame to continue at, and its timeline read back.
#include "chungs/mapping/map_state.hpp"
#include "chungs/pipeline/timeline.hpp"
#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto file = chungs::fuzz::temp_folder().write("run_state.json", data, size);
  chungs::fuzz::refusing(file, [&] {
    const nlohmann::json state = chungs::read_json_file(file);
    chungs::validate_run_state(state, file);
    // The frame count of a dataset a resumed run could have.
    chungs::resume_frame(state, file, 1000);
    if (!state.contains("timeline")) return;
    // The pipeline turns any exception of the timeline's reader into an Error naming the file.
    try {
      chungs::timeline_from_json(state["timeline"]);
    } catch (const std::exception&) {
    }
  });
  return 0;
}

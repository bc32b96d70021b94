// `diskchungs export`: a map folder (or one chunk, or a box of it) as a standard 3DGS PLY.
#include <cmath>
#include <cstdio>

#include "chungs/common/error.hpp"
#include "chungs/pipeline/ply_export.hpp"
#include "command.hpp"
#include "flag_checks.hpp"
#include "map_paths.hpp"

namespace chungs::app {
namespace {

struct ExportArgs {
  std::string map, out;
  std::vector<double> box;
  std::vector<int> chunk;
};

const Command cmd{"export", "write a map (whole, one chunk, or a box) as a 3DGS PLY file", [](CLI::App& app) {
  auto a = std::make_shared<ExportArgs>();
  app.add_option("--map", a->map, "map folder")->required();
  app.add_option("--out", a->out, "PLY file to write")->required();
  app.add_option("--chunk", a->chunk, "only the chunk with these coordinates: CX CY CZ")->expected(3);
  app.add_option("--box", a->box, "only Gaussians inside: XMIN YMIN ZMIN XMAX YMAX ZMAX (metres)")->expected(6);
  return [a, &app]() {
    if (given(app, "--box")) {
      // A NaN or swapped corner selects nothing, and an infinite one is no box: each would write an
      // empty PLY without a word.
      const std::vector<double>& b = a->box;
      bool ok = true;
      for (int k = 0; k < 3; ++k)
        ok = ok && std::isfinite(b[k]) && std::isfinite(b[k + 3]) && b[k] <= b[k + 3];
      require_flag(ok, "--box", "finite XMIN YMIN ZMIN XMAX YMAX ZMAX with each minimum at most its maximum",
                   cat(b[0], " ", b[1], " ", b[2], " ", b[3], " ", b[4], " ", b[5]));
    }
    require_flag(!a->out.empty(), "--out", "a PLY file", "an empty path");
    refuse_inside_map(a->out, a->map, "--out");
    ChunkStore store(a->map, reader_config());  // a reader never repairs or rewrites the map
    PlySelection s;
    if (!a->chunk.empty()) s.chunk = chunk_id(ChunkCoord{a->chunk[0], a->chunk[1], a->chunk[2]});
    if (!a->box.empty()) {
      s.box_lo = Eigen::Vector3d(a->box[0], a->box[1], a->box[2]);
      s.box_hi = Eigen::Vector3d(a->box[3], a->box[4], a->box[5]);
    }
    const uint64_t n = export_ply(store, a->out, s);
    std::printf("wrote %llu Gaussians to %s\n", (unsigned long long)n, a->out.c_str());
    return 0;
  };
}};

}  // namespace
}  // namespace chungs::app

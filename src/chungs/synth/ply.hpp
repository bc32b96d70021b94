// PLY triangle-mesh reader (ascii and binary_little_endian): vertex x y z with optional
// red green blue [alpha] (uchar, or float in [0, 1]), faces as a vertex_indices list (polygons are
// fan-triangulated). Other elements and properties are skipped. Errors name the file.
#pragma once
#include <filesystem>

#include "chungs/synth/mesh.hpp"

namespace chungs::synth {

// The mesh gets one material: VertexColor (unlit) when the file has colours, else a lit Flat grey.
Mesh read_ply(const std::filesystem::path& file);

}  // namespace chungs::synth

// Where a reader of a map folder (export, render) may write: never inside the folder, which a reader
// must leave as its manifest commits it (DESIGN.md); by default beside it.
#pragma once
#include <filesystem>
#include <string>

namespace chungs::app {

// Throws naming `flag` and both paths when `out` is the map folder or lies inside it (after links,
// `.` and `..` are resolved): `export --out MAP/manifest.txt` once replaced the manifest.
void refuse_inside_map(const std::string& out, const std::string& map, const std::string& flag);

// The folder MAP<suffix> beside the map folder (a trailing slash on `map` names the same folder).
std::filesystem::path beside_map(const std::string& map, const std::string& suffix);

}  // namespace chungs::app

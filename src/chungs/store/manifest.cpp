#include "chungs/store/manifest.hpp"

#include <cinttypes>
#include <cstdio>
#include <sstream>

#include "chungs/common/error.hpp"
#include "chungs/store/atomic_file.hpp"
#include "chungs/store/checksum.hpp"
#include "chungs/store/chunk_file.hpp"

namespace chungs {

namespace {
constexpr const char* kMagic = "diskchungs-manifest";

std::string hex64(uint64_t v) {
  char b[20];
  std::snprintf(b, sizeof b, "%016" PRIx64, v);
  return b;
}

uint64_t parse_u64(const std::string& s, int base, const std::filesystem::path& file, int line,
                   const char* what) {
  size_t used = 0;
  uint64_t v = 0;
  try {
    v = std::stoull(s, &used, base);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != s.size() || s[0] == '-')
    fail(file.string(), ":", line, ": bad ", what, " '", s, "'");
  return v;
}
}  // namespace

uint64_t Manifest::total_gaussians() const {
  uint64_t n = 0;
  for (const auto& [id, e] : chunks) n += e.count;
  return n;
}

std::string Manifest::serialize() const {
  std::ostringstream os;
  char num[40];
  std::snprintf(num, sizeof num, "%.17g", chunk_size);
  os << kMagic << ' ' << kManifestVersion << '\n'
     << "chunk_size " << num << '\n'
     << "sh_degree " << sh_degree << '\n'
     << "next_generation " << next_generation << '\n';
  for (const auto& [k, v] : config) {
    if (k.empty() || k.find_first_of(" \t\r\n\v\f") != std::string::npos)
      fail("manifest: config key '", k, "' must be non-empty and free of blanks");
    if (v.find_first_of("\r\n") != std::string::npos)
      fail("manifest: config value of '", k, "' must not contain line breaks");
    os << "config " << k << ' ' << v << '\n';
  }
  for (const auto& [id, e] : chunks)
    os << "chunk " << hex64(id) << ' ' << e.count << ' ' << e.file_bytes << ' ' << hex64(e.checksum) << ' '
       << e.generation << '\n';
  std::string body = os.str();
  const size_t entries = config.size() + chunks.size();
  return body + "end " + std::to_string(entries) + ' ' + hex64(xxh64(body.data(), body.size())) + '\n';
}

Manifest Manifest::parse(const std::string& text, const std::filesystem::path& file) {
  const std::string where = file.string();
  const size_t end_at = text.rfind("\nend ");
  if (end_at == std::string::npos || text.empty() || text.back() != '\n')
    fail(where, ": manifest has no end line (truncated or not a manifest)");
  const std::string body = text.substr(0, end_at + 1);
  int line_no = 1;
  for (char c : body) line_no += c == '\n';
  std::istringstream end_line(text.substr(end_at + 1));
  std::string tag, count_s, sum_s, extra;
  end_line >> tag >> count_s >> sum_s;
  if (tag != "end" || sum_s.empty() || (end_line >> extra)) fail(where, ":", line_no, ": malformed end line");
  const uint64_t declared = parse_u64(count_s, 10, file, line_no, "entry count");
  if (parse_u64(sum_s, 16, file, line_no, "checksum") != xxh64(body.data(), body.size()))
    fail(where, ": manifest checksum mismatch: the file is corrupt");

  Manifest m;
  std::istringstream lines(body);
  std::string line;
  int n = 0;
  bool have_size = false, have_degree = false;
  int version = 0;
  while (std::getline(lines, line)) {
    ++n;
    std::istringstream ls(line);
    std::string key;
    ls >> key;
    auto bad = [&](const std::string& msg) { fail(where, ":", n, ": ", msg); };
    if (n == 1) {
      if (key != kMagic || !(ls >> version)) bad("not a diskchungs manifest");
      if (version < 1 || version > kManifestVersion)
        bad(cat("manifest version ", version, " is not supported (this build reads versions 1 to ",
                kManifestVersion, ")"));
    } else if (key == "chunk_size") {
      if (!(ls >> m.chunk_size) || !(m.chunk_size >= kMinChunkSize && m.chunk_size <= kMaxChunkSize))
        bad(cat("bad chunk_size (a map's is in [", kMinChunkSize, ", ", kMaxChunkSize, "] metres)"));
      have_size = true;
    } else if (key == "sh_degree") {
      if (!(ls >> m.sh_degree) || m.sh_degree < 0 || m.sh_degree > 3) bad("bad sh_degree");
      have_degree = true;
    } else if (key == "next_generation" && version >= 2) {
      std::string g;
      if (!(ls >> g) || (ls >> extra)) bad("bad next_generation");
      m.next_generation = parse_u64(g, 10, file, n, "next_generation");
    } else if (key == "config") {
      std::string k;
      ls >> k;
      std::string v;
      std::getline(ls, v);
      if (!v.empty() && v[0] == ' ') v.erase(0, 1);
      if (k.empty() || !m.config.emplace(k, v).second) bad("missing or repeated config key '" + k + "'");
      // serialize() refuses it, so a map read with one could never be checkpointed again.
      if (v.find('\r') != std::string::npos) bad("config value of '" + k + "' holds a carriage return");
    } else if (key == "chunk") {
      std::string id_s, count_s2, bytes_s, sum2, gen_s;
      const bool fields = (ls >> id_s >> count_s2 >> bytes_s >> sum2) && (version < 2 || (ls >> gen_s));
      if (!fields || (ls >> extra))
        bad(version < 2 ? "chunk line needs 4 fields" : "chunk line needs 5 fields");
      const ChunkId id = parse_u64(id_s, 16, file, n, "chunk id");
      ManifestEntry e{parse_u64(count_s2, 10, file, n, "count"), parse_u64(bytes_s, 10, file, n, "file size"),
                      parse_u64(sum2, 16, file, n, "checksum"),
                      version < 2 ? 0 : parse_u64(gen_s, 10, file, n, "generation")};
      // Readers size pools and budgets by these counts before any chunk file is opened.
      if (e.count > kMaxChunkGaussians)
        bad(cat(chunk_name(id), " is listed with ", e.count, " Gaussians, more than a chunk may hold (",
                kMaxChunkGaussians, ")"));
      if (!m.chunks.emplace(id, e).second) bad("repeated " + chunk_name(id));
    } else {
      bad("unknown entry '" + key + "'");
    }
  }
  if (!have_size || !have_degree) fail(where, ": manifest lacks chunk_size or sh_degree");
  if (declared != m.config.size() + m.chunks.size())
    fail(where, ": end line announces ", declared, " entries, found ", m.config.size() + m.chunks.size());
  return m;
}

Manifest Manifest::read(const std::filesystem::path& file) {
  const std::vector<uint8_t> bytes = read_whole_file(file);
  return parse(std::string(bytes.begin(), bytes.end()), file);
}

void Manifest::write(const std::filesystem::path& file, bool durable) const {
  const std::string text = serialize();
  const ConstBuffer part{text.data(), text.size()};
  write_file_atomically(file, {&part, 1}, durable);
}

}  // namespace chungs

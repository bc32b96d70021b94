// Whatever Manifest::parse accepts, serialize() writes back: a map folder whose manifest reads but
// cannot be written fails at its next checkpoint instead of when it is opened, with a message that
// names no file. The manifest fuzz target found a config value holding a carriage return
// (fuzz/corpus/manifest/config_value_carriage_return).
#include <gtest/gtest.h>

#include <cinttypes>
#include <cstdio>
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/store/checksum.hpp"
#include "chungs/store/manifest.hpp"

using namespace chungs;

namespace {

// A manifest's text with a correct end line, as a writer that allowed `value` would make it.
std::string manifest_text(const std::string& value) {
  const std::string body =
      "diskchungs-manifest 2\nchunk_size 10\nsh_degree 3\nnext_generation 0\nconfig note " + value + "\n";
  char sum[20];
  std::snprintf(sum, sizeof sum, "%016" PRIx64, xxh64(body.data(), body.size()));
  return body + "end 1 " + sum + "\n";
}

}  // namespace

TEST(ManifestReadBack, ConfigValueWithCarriageReturnIsRefusedNamingFileAndLine) {
  try {
    Manifest::parse(manifest_text("made on\r a typewriter"), "map/manifest.txt");
    ADD_FAILURE() << "accepted a config value that serialize() cannot write back";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("map/manifest.txt:5: config value of 'note'"), std::string::npos)
        << e.what();
  }
}

TEST(ManifestReadBack, AcceptedConfigValuesWriteBackUnchanged) {
  for (const char* value : {"", "  two leading blanks", "\ttab first", "trailing blank ", "a\vb\fc"}) {
    const Manifest m = Manifest::parse(manifest_text(value), "map/manifest.txt");
    ASSERT_EQ(m.config.at("note"), value);
    EXPECT_EQ(Manifest::parse(m.serialize(), "map/manifest.txt").config.at("note"), value);
  }
}

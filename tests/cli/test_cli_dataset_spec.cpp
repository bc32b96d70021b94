// `--dataset synth-street:KEY=VALUE,...` is read as typed: a value out of range, a key unknown or given
// twice, or a number that would stand for "the default" is refused naming the spec and the key, before
// the map folder is made.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "cli/cli_support.hpp"
#include "test_support.hpp"

using chungs::test::run_cli;

namespace {

TEST(CliDatasetSpec, SyntheticStreetKeysAreRefusedNamingTheSpecAndTheKey) {
  chungs::test::TempDir dir;
  const auto out = dir / "map";
  for (const auto& [spec, says] : std::vector<std::pair<std::string, std::string>>{
           {"synth-street:length=-5", "length -5 m must be in (0, "},
           {"synth-street:length=20,frames=0", "value '0' of frames is not a whole number from 1 to "},  // was every frame
           {"synth-street:length=20,frames=-1", "of frames is not a whole number"},
           {"synth-street:length=20,length=30", "key 'length' is given twice"},
           {"synth-street:length=20,colour=red", "unknown key 'colour'"},
           {"synth-street:length=20,width=64", "give both width and height, or neither"},
           {"synth-street:length=20,traffic=nan", "traffic"},
           {"synth-street:length=20,startup=left", "of startup must be none, cross, turn or cross+turn"}}) {
    auto r = run_cli("run --poses gt --device cpu --dataset " + spec + " --out " + out.string());
    EXPECT_EQ(r.code, 1) << spec << "\n" << r.out;
    EXPECT_NE(r.out.find("error: dataset '" + spec + "': "), std::string::npos) << spec << "\n" << r.out;
    EXPECT_NE(r.out.find(says), std::string::npos) << spec << "\n" << r.out;
    EXPECT_FALSE(std::filesystem::exists(out)) << spec << " made " << out;
  }
}

}  // namespace

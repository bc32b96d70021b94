// Datasets named on the command line: everything open_dataset accepts ("kind:path"), plus the
// synthetic street drive rendered on demand:
//   synth-street:length=10000,width=620,height=188[,seed=N][,frames=N][,depth=0|1][,traffic=N][,startup=S]
// (length in metres, default 1000; image size default 1241x376, both or neither; seed default 1;
// frames: stop after this many, 0 for the whole route; depth: also hand out rendered depth;
// traffic: moving vehicles per 100 m, default 0; startup: none (default), cross (a lorry crosses close
// ahead in the first frames), turn (the drive begins just before its first corner) or cross+turn).
#pragma once
#include <memory>
#include <string>

#include "chungs/datasets/dataset.hpp"

namespace chungs {

// Throws Error naming the bad key or value (or whatever open_dataset rejects).
std::unique_ptr<Dataset> open_dataset_spec(const std::string& spec);

}  // namespace chungs

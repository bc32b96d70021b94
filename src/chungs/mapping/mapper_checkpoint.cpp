// Mapper's checkpoints (the resume point) and their recovery on open.
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <sstream>

#include "chungs/common/log.hpp"
#include "chungs/mapping/mapper.hpp"
#include "chungs/mapping/sky_file.hpp"
#include "chungs/store/atomic_file.hpp"

namespace chungs {

namespace fs = std::filesystem;

// A run that ends without a checkpoint (an error) leaves the folder as its last checkpoint did,
// as the chunk store does with its chunk files: the keyframe files stored since go now, where
// --resume would have dropped them on open. Ids only grow, so they are the ids after the last
// keyframe that checkpoint names.
void Mapper::remove_keyframes_after_checkpoint() {
  const uint64_t first_new = keyframes_in_checkpoint_ ? keyframes_[keyframes_in_checkpoint_ - 1].id + 1 : 0;
  try {
    for (uint64_t id : keyframe_store_->ids())
      if (id >= first_new) keyframe_store_->erase(id);
  } catch (const std::exception& e) {
    log::error("mapper: could not remove the keyframes stored after the last checkpoint: ", e.what());
  }
}

// A checkpoint is one commit of the chunk store whose manifest names it (`checkpoint` entry): its
// keyframe list and run state are written first under numbered names, the commit makes them the
// truth, and only then do they take the names that readers use. A crash before the commit leaves
// the previous checkpoint whole; after it, opening finishes the renaming.
void Mapper::recover_checkpoint_files() {
  const auto tag = store_->config_value("checkpoint");
  checkpoint_seq_ = 0;
  if (tag) {
    char* end = nullptr;
    errno = 0;
    checkpoint_seq_ = std::strtoull(tag->c_str(), &end, 10);
    if (tag->empty() || *end != '\0' || errno == ERANGE || (*tag)[0] == '-')
      fail(folder_.string(), "/manifest.txt: checkpoint '", *tag, "' is not a checkpoint number");
  }
  for (const auto& e : fs::directory_iterator(folder_)) {
    const std::string name = e.path().filename().string();
    unsigned long long seq = 0;
    char rest[64] = {};
    if (std::sscanf(name.c_str(), "checkpoint-%llu-%63s", &seq, rest) != 2) continue;
    const std::string final_name = rest;
    if (final_name != "keyframes.txt" && final_name != "run_state.json" && final_name != "sky.bin") continue;
    if (tag && seq == checkpoint_seq_)
      fs::rename(e.path(), folder_ / final_name);
    else
      fs::remove(e.path());
  }
}

void Mapper::checkpoint(const nlohmann::json& run_state, bool behind, TextPieces more) {
  residency_->finish_checkpoint();  // its files are renamed, its sequence number is taken
  const uint64_t seq = checkpoint_seq_ + 1;
  keyframes_in_checkpoint_ = keyframes_.size();
  for (auto& k : keyframes_) {
    k.uses = selector_.usage(k.id).uses;
    k.last_loss = selector_.usage(k.id).last_loss;
  }
  // The picks drawn ahead are not steps yet: a resumed run draws them again.
  for (const PickAhead& p : picks_ahead_)
    if (KeyframeRecord* k = mutable_keyframe(p.keyframe)) k->uses += 1;
  const fs::path keyframes_file = checkpoint_file(folder_, seq, "keyframes.txt");
  const fs::path state_file = checkpoint_file(folder_, seq, "run_state.json");
  const fs::path sky_file = checkpoint_file(folder_, seq, "sky.bin");
  std::optional<SkyTexture> sky = sky_on_ ? backend_->sky() : std::nullopt;  // as it is now
  nlohmann::json j = run_state;
  j["iterations"] = iterations_;
  // Also held by the manifest; here they let a lost manifest be rebuilt at the map's own geometry.
  j["chunk_size"] = store_->chunk_size();
  j["sh_degree"] = store_->sh_degree();
  // What the keyframe list of this checkpoint holds: a list damaged since (lines lost, emptied) is refused
  // on resume, where it would have dropped the keyframes it no longer names and deleted their images.
  j["keyframe_list"] = {{"count", keyframes_.size()}, {"last_id", keyframes_.empty() ? 0 : keyframes_.back().id}};
  j["far_level_distance"] = config_.culling.far_level_distance;
  std::ostringstream s;
  s << rng_;
  j["rng"] = s.str();
  const bool durable = config_.store.durable;
  // Everything the commit names is written first, under numbered names (see above). Behind the
  // caller this runs on a writer thread: hence the copies of the keyframe list and the index.
  // What grows with the drive goes out in pieces of text, never as a JSON tree or one long string
  // (common/text_pieces.hpp): with the heap never trimmed, a transient peak that grows at every
  // checkpoint is host memory that grows with the drive.
  auto write_state = [this, keyframes_file, state_file, sky_file, durable, behind,
                      records = std::deque<KeyframeRecord>(keyframes_.begin(), keyframes_.end()),
                      j = std::move(j), index = keyframe_chunks_, more = std::move(more),
                      sky = std::move(sky)]() mutable {
    // The keyframe list about to be committed must not name a keyframe whose file could be lost.
    keyframe_store_->commit(!behind);
    write_text_atomically(keyframes_file, keyframe_records_text(records), durable);
    std::string head = j.dump();  // an object with at least "iterations" and "rng"
    head.pop_back();              // its closing brace
    TextPieces text;
    text += head;
    text += ",\"keyframe_chunks\":";
    index.append_json(text);
    text.splice(std::move(more));
    text += "}\n";
    write_text_atomically(state_file, text, durable);
    if (sky) write_sky_file(sky_file, *sky, durable);
  };
  auto publish = [this, keyframes_file, state_file, sky_file, durable, has_sky = sky_on_] {
    fs::rename(keyframes_file, folder_ / "keyframes.txt");
    fs::rename(state_file, folder_ / "run_state.json");
    if (has_sky) fs::rename(sky_file, folder_ / "sky.bin");
    if (durable) sync_directory(folder_);
  };
  store_->set_config("checkpoint", std::to_string(seq));
  if (behind) {
    residency_->begin_checkpoint(std::move(write_state), std::move(publish));
  } else {
    write_state();
    residency_->flush();  // every modified chunk, then the manifest naming this checkpoint
    publish();
  }
  checkpoint_seq_ = seq;
}

}  // namespace chungs

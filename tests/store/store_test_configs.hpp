// Chunk-store settings the store's tests share.
#pragma once
#include "chungs/store/chunk_store.hpp"

namespace chungs::test {

// No flushes: kill- and power-safety have their own tests (crash_test.cpp); elsewhere flushes only cost time.
inline ChunkStoreConfig unflushed_store() {
  ChunkStoreConfig c;
  c.durable = false;
  return c;
}

// The same with float32 chunk files, for tests that compare exact round trips.
inline ChunkStoreConfig exact_unflushed_store() {
  ChunkStoreConfig c = unflushed_store();
  c.half_moments = c.half_sh_rest = false;
  return c;
}

}  // namespace chungs::test

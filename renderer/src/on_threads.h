// Running parallel work on a chosen number of threads.
#pragma once

#include <tbb/task_arena.h>

namespace penumbra {

/// Runs `body` (which may use TBB's parallel algorithms) on `threads` threads (0: all cores).
template <class Body>
void onThreads(int threads, const Body& body) {
  tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
  arena.execute(body);
}

}  // namespace penumbra

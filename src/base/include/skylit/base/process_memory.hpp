#pragma once
// This process's memory as a long-running service reports it: what the heap holds for the program
// (exact, in bytes), what the allocator keeps from the system, and what is resident. Growth of the
// first is a leak; the others also move with the allocator's retention and the kernel's paging.
#include <cstddef>

namespace skylit {

struct ProcessMemory {
  std::size_t heap_in_use_bytes = 0;  // allocated by the program and not yet freed (malloc's view)
  std::size_t heap_held_bytes = 0;    // obtained from the system by malloc: in use + free but kept
  std::size_t resident_bytes = 0;     // resident set (/proc/self/statm), 0 where unknown
};

// Walks malloc's arenas (cost grows with their free lists): call it for a report, not per frame.
ProcessMemory process_memory();

}  // namespace skylit

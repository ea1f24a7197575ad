// ProcessMemory from glibc's mallinfo2 and /proc/self/statm.
#include "skylit/base/process_memory.hpp"

#include <malloc.h>
#include <unistd.h>

#include <fstream>

namespace skylit {

ProcessMemory process_memory() {
  ProcessMemory m;
  const struct mallinfo2 info = mallinfo2();
  m.heap_in_use_bytes = info.uordblks + info.hblkhd;  // chunks handed out, from arenas and mmap
  m.heap_held_bytes = info.arena + info.hblkhd;
  std::ifstream statm("/proc/self/statm");
  std::size_t size_pages = 0, resident_pages = 0;
  if (statm >> size_pages >> resident_pages) m.resident_bytes = resident_pages * std::size_t(sysconf(_SC_PAGESIZE));
  return m;
}

}  // namespace skylit

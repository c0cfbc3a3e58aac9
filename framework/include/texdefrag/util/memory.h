// Process memory and CPU-time figures for the run report.
#pragma once

#include <cstddef>

namespace texdefrag {
/// Peak resident set size of this process so far, bytes (VmHWM); 0 where unknown.
size_t peak_rss_bytes();
/// Current resident set size, bytes (VmRSS); 0 where unknown.
size_t current_rss_bytes();
/// Resets the peak counter where the kernel allows (writes 5 to /proc/self/clear_refs); returns
/// false when it cannot, in which case peak figures are process-wide.
bool reset_peak_rss();
/// Returns the memory the allocator holds free to the system (glibc: malloc_trim), so that what an
/// earlier step freed in small pieces does not stay resident beside a later step's large buffers
/// (those come from fresh pages). No effect with other allocators.
void release_free_memory();
/// CPU time of this process so far (user + system, every thread), seconds.
double process_cpu_seconds();
}  // namespace texdefrag

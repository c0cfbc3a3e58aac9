// Bounded OSGB reading: osgDB reads each file first in a child process with resource limits (see
// texdefrag/io/osgb.h and docs/io.md "OSGB: bounded reading").
//
// note: why a child process. osgDB's binary reader takes string, array and image sizes from the
// file and allocates them before reading the bytes (a 1 KB file can ask for gigabytes, zero-filled
// for a minute), loops over element counts read from the file, follows ProxyNode file names while
// reading, and dereferences null on some malformed files (fuzz_osgb found each). None of that can
// be bounded from outside its code in this process: a pre-scan would have to re-implement every
// serializer of every OSG version. A child process can be: RLIMIT_AS makes a huge allocation fail
// (std::bad_alloc, or the sanitizer runtime's out-of-memory report in an ASan build), RLIMIT_CPU
// stops a loop, the parent's wall clock stops a child blocked on a read, and a crash ends only the
// child. osgDB is deterministic on the same bytes, so a file the child read is then read here.
#include "osgb_source.h"
#include "texdefrag/io/osgb.h"

#include <osg/Notify>
#include <osgDB/Registry>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <new>
#include <string>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TEXDEFRAG_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define TEXDEFRAG_ASAN 1
#endif
#ifdef TEXDEFRAG_ASAN
#include <sanitizer/common_interface_defs.h>
#endif

namespace texdefrag {

namespace {
constexpr uint64_t kMiB = 1024 * 1024;
}  // namespace

OsgbReadLimits osgb_read_limits(uint64_t file_bytes) {
  // note: the memory term covers decoded textures, which a JPEG compresses 10-50x for photographs
  // and far more for flat colours: 512 MiB holds an 8192 x 8192 RGBA page twice. osgb_prod5's
  // files (up to 2.5 MB) need at most 23 MiB resident in the child.
  OsgbReadLimits l;
  l.memory_bytes = 512 * kMiB + 64 * file_bytes;
  l.cpu_seconds = 2.0 + 2.0 * static_cast<double>(file_bytes) / static_cast<double>(kMiB);
  l.wall_seconds = 10.0 + 4.0 * l.cpu_seconds;
  return l;
}

namespace {
std::mutex g_limits_mutex;
std::optional<OsgbReadLimits> g_limits;  // set_osgb_read_limits
}  // namespace

void set_osgb_read_limits(std::optional<OsgbReadLimits> limits) {
  std::lock_guard<std::mutex> lock(g_limits_mutex);
  g_limits = limits;
}

namespace osgb_detail {

OsgbReadLimits limits_for(uint64_t file_bytes) {
  std::lock_guard<std::mutex> lock(g_limits_mutex);
  return g_limits ? *g_limits : osgb_read_limits(file_bytes);
}

std::mutex& osgdb_mutex() {
  static std::mutex m;
  return m;
}

namespace {

// What the child writes on its pipe: one of these bytes, then for 'E' and 'X' a message.
constexpr char kRead = 'K';        // osgDB returned a node
constexpr char kOsgError = 'E';    // osgDB returned no node: its message follows
constexpr char kNoMemory = 'M';    // std::bad_alloc (the address-space limit)
constexpr char kException = 'X';   // another C++ exception: its what() follows
constexpr char kSanitizer = 'S';   // the sanitizer runtime is stopping the child (its report is on stderr)

int g_child_pipe = -1;  // the child's end of the pipe (set in the child only)

void child_write(char status, const std::string& message) {
  std::string out(1, status);
  out += message.substr(0, 4000);
  const char* p = out.data();
  size_t left = out.size();
  while (left > 0) {
    const ssize_t n = ::write(g_child_pipe, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    p += n;
    left -= static_cast<size_t>(n);
  }
}

#ifdef TEXDEFRAG_ASAN
void on_sanitizer_death() { child_write(kSanitizer, ""); }
#endif

/// Address space mapped now (the first field of /proc/self/statm, in pages), in bytes.
uint64_t mapped_bytes() {
  std::ifstream in("/proc/self/statm");
  uint64_t pages = 0;
  in >> pages;
  return pages * static_cast<uint64_t>(::sysconf(_SC_PAGESIZE));
}

/// The child: limits, default signal dispositions (a crash ends it quietly; no inherited handler
/// of a fuzzer, sanitizer or interpreter runs here), osgDB's read, one status on the pipe, _exit.
[[noreturn]] void child_main(const std::string& path, const OsgbReadLimits& limits, int out_fd) {
  g_child_pipe = out_fd;
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT, SIGINT, SIGTERM, SIGHUP, SIGXCPU, SIGALRM, SIGPIPE})
    ::signal(sig, SIG_DFL);
  sigset_t none;
  sigemptyset(&none);
  ::sigprocmask(SIG_SETMASK, &none, nullptr);
  const rlimit core{0, 0};
  ::setrlimit(RLIMIT_CORE, &core);
  const rlim_t cpu = static_cast<rlim_t>(std::ceil(limits.cpu_seconds));
  const rlimit cpu_limit{cpu, cpu + 1};  // SIGXCPU at the soft limit, SIGKILL one second later
  ::setrlimit(RLIMIT_CPU, &cpu_limit);
  const rlim_t as = static_cast<rlim_t>(mapped_bytes() + limits.memory_bytes);
  const rlimit as_limit{as, as};
  ::setrlimit(RLIMIT_AS, &as_limit);
#ifdef TEXDEFRAG_ASAN
  __sanitizer_set_death_callback(on_sanitizer_death);
#endif
  osg::setNotifyLevel(osg::FATAL);  // its warnings are printed by the read in the parent
  try {
    osgDB::ReaderWriter::ReadResult rr = osgDB::Registry::instance()->readNode(path, nullptr);
    if (rr.validNode()) {
      child_write(kRead, "");
    } else {
      std::string why = rr.message();
      if (why.empty())
        why = rr.notFound() ? "no osgDB plugin reads it (is osgdb_osg installed?)" : "unreadable or truncated";
      child_write(kOsgError, why);
    }
  } catch (const std::bad_alloc&) {
    child_write(kNoMemory, "");
  } catch (const std::exception& e) {
    child_write(kException, e.what());
  } catch (...) {
    child_write(kException, "an exception that is not a std::exception");
  }
  ::_exit(0);  // note: no destructors, no atexit handlers (a fuzzer's or a leak checker's)
}

/// What the parent saw of the child.
struct ChildOutcome {
  std::string message;  ///< the bytes the child wrote on its pipe
  bool timed_out = false;
  int status = 0;  ///< waitpid status
  double cpu_seconds = 0;
};

ChildOutcome wait_child(pid_t pid, int in_fd, double wall_seconds) {
  ChildOutcome o;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(wall_seconds);
  char buf[4096];
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      o.timed_out = true;
      ::kill(pid, SIGKILL);
      break;
    }
    pollfd p{in_fd, POLLIN, 0};
    const int r = ::poll(&p, 1, static_cast<int>(std::min<long long>(left.count(), 1000)));
    if (r < 0 && errno != EINTR) break;
    if (r <= 0) continue;
    const ssize_t n = ::read(in_fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // EOF: the child exited (or closed its end)
    if (o.message.size() < 8192) o.message.append(buf, static_cast<size_t>(n));
  }
  rusage u{};
  while (::wait4(pid, &o.status, 0, &u) < 0 && errno == EINTR) {
  }
  o.cpu_seconds = static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
                  1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  return o;
}

std::string mib(uint64_t bytes) { return std::to_string((bytes + kMiB - 1) / kMiB) + " MiB"; }

std::string seconds(double s) {
  char b[32];
  std::snprintf(b, sizeof b, "%.0f s", s);
  return b;
}

/// Throws the FormatError that says what stopped the child, or returns when it read the file.
void judge(const std::string& path, const OsgbReadLimits& limits, const ChildOutcome& o) {
  const std::string malformed = "; the file is malformed (or needs more than the limits of docs/io.md \"OSGB: bounded reading\")";
  const std::string reader = path + ": OpenSceneGraph's reader ";
  if (o.timed_out)
    throw FormatError(reader + "did not finish within " + seconds(limits.wall_seconds) +
                      " (wall time) reading this file and was stopped" + malformed);
  const char status = o.message.empty() ? '\0' : o.message[0];
  const std::string text = o.message.size() > 1 ? o.message.substr(1) : std::string();
  if (status == kRead && WIFEXITED(o.status) && WEXITSTATUS(o.status) == 0) return;
  if (status == kOsgError) throw FormatError(path + ": cannot read the scene graph: " + text);
  if (status == kException)
    throw FormatError(path + ": cannot read the scene graph (malformed OSGB?): " + text);
  if (status == kNoMemory)
    throw FormatError(reader + "exceeded " + mib(limits.memory_bytes) + " reading this file" + malformed);
  if (status == kSanitizer)
    throw FormatError(reader + "was stopped by the sanitizer runtime reading this file (its report is above; "
                      "under the limit of " + mib(limits.memory_bytes) + " it is usually 'out of memory')" + malformed);
  if (WIFSIGNALED(o.status)) {
    const int sig = WTERMSIG(o.status);
    if (sig == SIGXCPU || (sig == SIGKILL && o.cpu_seconds + 0.5 >= std::ceil(limits.cpu_seconds)))
      throw FormatError(reader + "exceeded " + seconds(std::ceil(limits.cpu_seconds)) +
                        " of CPU time reading this file and was stopped" + malformed);
    const char* name = ::strsignal(sig);
    throw FormatError(reader + "crashed reading this file (signal " + std::to_string(sig) + ", " +
                      (name ? name : "unknown") + "); the file is malformed");
  }
  throw FormatError(reader + "ended without a result reading this file (exit status " +
                    std::to_string(WIFEXITED(o.status) ? WEXITSTATUS(o.status) : -1) + ")");
}

}  // namespace

void read_in_bounded_child(const std::string& path, const OsgbReadLimits& limits) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0)
    throw FormatError(path + ": cannot start the bounded OSGB reader (pipe: " + std::strerror(errno) + ")");
  std::fflush(nullptr);  // the child must not flush the parent's buffered output again
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int e = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw FormatError(path + ": cannot start the bounded OSGB reader (fork: " + std::strerror(e) + ")");
  }
  if (pid == 0) {
    ::close(fds[0]);
    child_main(path, limits, fds[1]);
  }
  ::close(fds[1]);
  const ChildOutcome o = wait_child(pid, fds[0], limits.wall_seconds);
  ::close(fds[0]);
  judge(path, limits, o);
}

}  // namespace osgb_detail
}  // namespace texdefrag

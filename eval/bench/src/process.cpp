// Child processes of a batch: posix_spawn with captured output, a timeout, and the child's own
// peak memory from wait4's rusage.
#include "texdefrag/eval/bench.h"
#include "texdefrag/util/paths.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

extern char** environ;

namespace texdefrag::bench {
namespace {

std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The last `max_lines` non-empty lines of `text`.
std::string tail_lines(const std::string& text, size_t max_lines) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    // Progress bars end with carriage returns; keep only what follows the last one.
    const size_t cr = line.rfind('\r');
    if (cr != std::string::npos) line = line.substr(cr + 1);
    if (!line.empty()) lines.push_back(line);
  }
  std::string r;
  for (size_t i = lines.size() > max_lines ? lines.size() - max_lines : 0; i < lines.size(); ++i)
    r += (r.empty() ? "" : " | ") + lines[i];
  return r;
}

}  // namespace

std::string ChildResult::describe() const {
  if (!start_error.empty()) return "could not start: " + start_error;
  std::string s;
  if (timed_out) s = "timed out after " + std::to_string(wall_s) + " s";
  else if (signal != 0) s = std::string("killed by signal ") + std::to_string(signal) + " (" + strsignal(signal) + ")";
  else if (exit_code != 0) s = "exit code " + std::to_string(exit_code);
  else s = "ok";
  const std::string t = tail_lines(err, 6);
  if (!t.empty()) s += ": " + t;
  return s;
}

ChildResult run_child(const std::vector<std::string>& argv, const std::string& capture_prefix, double timeout_s) {
  ChildResult r;
  if (argv.empty()) {
    r.start_error = "empty command";
    return r;
  }
  const std::string out_path = capture_prefix + ".stdout", err_path = capture_prefix + ".stderr";
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);

  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&fa, STDERR_FILENO, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const auto t0 = std::chrono::steady_clock::now();
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, args[0], &fa, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) {
    r.start_error = argv[0] + ": " + std::strerror(rc);
    return r;
  }
  int status = 0;
  struct rusage ru {};
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  for (;;) {
    const pid_t w = wait4(pid, &status, timeout_s > 0 ? WNOHANG : 0, &ru);
    if (w == pid) break;
    if (w < 0 && errno != EINTR) {
      r.start_error = std::string("wait4: ") + std::strerror(errno);
      return r;
    }
    if (w == 0) {
      if (elapsed() > timeout_s && !r.timed_out) {
        r.timed_out = true;
        kill(pid, SIGKILL);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  r.wall_s = elapsed();
  r.max_rss_bytes = static_cast<long>(ru.ru_maxrss) * 1024;  // Linux: kilobytes
  if (WIFEXITED(status)) {
    r.exit_code = WEXITSTATUS(status);
  } else if (WIFSIGNALED(status)) {
    r.signal = WTERMSIG(status);
  }
  r.out = read_all(out_path);
  r.err = read_all(err_path);
  return r;
}

PlotsResult run_plots(const std::vector<std::string>& args, const std::string& capture_prefix) {
  PlotsResult p;
  const std::string script = (std::filesystem::path(data_dir("plots")) / "plots.py").string();
  if (!std::filesystem::is_regular_file(script)) {
    p.message = "plots: script " + script + " not found; no figures written";
    return p;
  }
  const std::string python = python_executable();
  std::vector<std::string> argv = {python, script};
  argv.insert(argv.end(), args.begin(), args.end());
  const ChildResult r = run_child(argv, capture_prefix);
  p.out = r.out;
  if (!r.start_error.empty())
    p.message = "plots: cannot run Python (" + python + ": " + r.start_error +
                "); set TEXDEFRAG_PYTHON at configure time. No figures written";
  else if (r.exit_code == 3)
    p.message = "plots: matplotlib is not available to " + python + "; summary.md written, no figures (" + r.describe() + ")";
  else if (!r.ok())
    p.message = "plots: failed (" + r.describe() + ")";
  else
    p.figures = true;
  return p;
}

}  // namespace texdefrag::bench

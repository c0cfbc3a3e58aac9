// The one write service (see texdefrag/io/output_set.h).
//
// note: the lock is an flock(2) on `.texdefrag.lock`, so a killed run never leaves a folder locked
// for ever; after taking it we check that the path still names the locked file (another run may
// have unlinked it between our open and our flock), and retry if not.
#include "texdefrag/io/output_set.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iterator>
#include <random>
#include <sstream>
#include <system_error>

namespace fs = std::filesystem;

namespace texdefrag {
namespace {

constexpr const char* kLockName = ".texdefrag.lock";
constexpr const char* kStagingPrefix = ".texdefrag-staging-";

fs::path canonical_or_absolute(const fs::path& p) {
  std::error_code ec;
  fs::path c = fs::weakly_canonical(p, ec);
  if (ec) c = fs::absolute(p, ec).lexically_normal();
  return c;
}

/// True when `inner` equals `outer` or lies inside it (component-wise).
bool is_within(const fs::path& inner, const fs::path& outer) {
  auto i = inner.begin(), o = outer.begin();
  for (; o != outer.end(); ++o, ++i) {
    if (o->empty() && std::next(o) == outer.end()) return true;  // trailing separator
    if (i == inner.end() || *i != *o) return false;
  }
  return true;
}

std::string quoted(const std::string& s) { return "'" + s + "'"; }

}  // namespace

std::string relative_name_problem(const std::string& name) {
  if (name.empty()) return "is empty";
  for (char c : name)
    if (static_cast<unsigned char>(c) < 32 || c == 127) return "has a control character";
  if (name.front() == '/') return "is an absolute path";
  if (name.find('\\') != std::string::npos) return "has a '\\' (folders are separated by '/')";
  std::stringstream ss(name);
  std::string part;
  bool first = true;
  size_t parts = 0;
  while (std::getline(ss, part, '/')) {
    ++parts;
    if (part.empty()) return "has an empty folder component ('//')";
    if (part == "..") return "has a '..' component";
    if (part == ".") return "has a '.' component";
    if (first && (part == kLockName || part.rfind(kStagingPrefix, 0) == 0))
      return "names texdefrag's own lock or staging folder";
    first = false;
  }
  if (name.back() == '/') return "ends with '/' (not a file name)";
  return parts ? "" : "is empty";
}

std::string file_stem_problem(const std::string& stem) {
  const std::string p = relative_name_problem(stem);
  if (!p.empty()) return p;
  if (stem.find('/') != std::string::npos) return "has a folder (a stem is a file name without '/')";
  return "";
}

std::string protected_match(const std::string& path, const std::vector<std::string>& protected_paths) {
  const fs::path c = canonical_or_absolute(path);
  for (const std::string& p : protected_paths)
    if (!p.empty() && is_within(c, canonical_or_absolute(p))) return p;
  return "";
}

OutputSet::OutputSet(const std::string& output_dir, std::vector<std::string> protected_paths, std::string input_label)
    : dir_(output_dir), protected_(std::move(protected_paths)), input_label_(std::move(input_label)) {
  if (dir_.empty()) throw OutputError("no output folder given");
  const std::string hit = protected_match(dir_, protected_);
  if (!hit.empty())
    throw OutputError("output folder " + dir_ + " is, or lies inside, the input file " + hit +
                      (input_label_.empty() ? "" : " (referenced by " + input_label_ + ")") + "; choose another folder");
  std::error_code ec;
  const bool existed = fs::exists(dir_, ec);
  if (!existed) {
    fs::create_directories(dir_, ec);
    if (ec) throw OutputError("cannot create output folder " + dir_ + ": " + ec.message());
    created_dir_ = true;
  }
  if (!fs::is_directory(dir_, ec)) throw OutputError("output folder " + dir_ + " exists and is not a folder");
  canon_dir_ = fs::canonical(dir_, ec).string();
  if (ec) throw OutputError("cannot resolve output folder " + dir_ + ": " + ec.message());
  try {
    lock();
    // Staging folders left by runs that were killed: we hold the lock, so none is alive.
    for (const auto& e : fs::directory_iterator(canon_dir_, ec))
      if (e.path().filename().string().rfind(kStagingPrefix, 0) == 0) fs::remove_all(e.path(), ec);
    std::random_device rd;
    char suffix[32];
    std::snprintf(suffix, sizeof suffix, "%ld-%08x", static_cast<long>(::getpid()), static_cast<unsigned>(rd()));
    staging_ = (fs::path(canon_dir_) / (std::string(kStagingPrefix) + suffix)).string();
    if (!fs::create_directory(staging_, ec) || ec)
      throw OutputError("cannot create staging folder " + staging_ + ": " + (ec ? ec.message() : "it exists"));
  } catch (...) {
    cleanup();
    throw;
  }
}

OutputSet::~OutputSet() {
  if (!committed_) cleanup();
}

void OutputSet::lock() {
  const std::string path = (fs::path(canon_dir_) / kLockName).string();
  for (int attempt = 0; attempt < 100; ++attempt) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) throw OutputError("cannot create lock file " + path + ": " + std::strerror(errno));
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int e = errno;
      char buf[32] = {0};
      const ssize_t n = ::pread(fd, buf, sizeof buf - 1, 0);
      ::close(fd);
      std::string holder = n > 0 ? std::string(buf, static_cast<size_t>(n)) : std::string();
      holder.erase(std::remove(holder.begin(), holder.end(), '\n'), holder.end());
      if (e == EWOULDBLOCK)
        throw OutputError("output folder " + dir_ + " is in use by another texdefrag run (lock file " +
                          (fs::path(dir_) / kLockName).string() +
                          (holder.empty() ? "" : " held by process " + holder) +
                          "); wait for it to finish or choose another folder");
      throw OutputError("cannot lock " + path + ": " + std::strerror(e));
    }
    struct stat a{}, b{};
    if (::fstat(fd, &a) == 0 && ::stat(path.c_str(), &b) == 0 && a.st_ino == b.st_ino && a.st_dev == b.st_dev) {
      const std::string pid = std::to_string(::getpid()) + "\n";
      if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, pid.data(), pid.size(), 0) < 0) {
        // note: the pid only improves the message of a second run; the lock holds without it.
      }
      lock_fd_ = fd;
      return;
    }
    ::close(fd);  // the file was replaced between open and flock: take the new one
  }
  throw OutputError("cannot lock " + path + ": it keeps being replaced");
}

void OutputSet::cleanup() noexcept {
  std::error_code ec;
  if (!staging_.empty()) fs::remove_all(staging_, ec);
  if (lock_fd_ >= 0) {
    ::unlink((fs::path(canon_dir_) / kLockName).c_str());
    ::close(lock_fd_);
    lock_fd_ = -1;
  }
  if (created_dir_ && !committed_) fs::remove(dir_, ec);  // only when empty
}

std::string OutputSet::final_path(const std::string& name) const { return (fs::path(dir_) / name).string(); }

std::string OutputSet::checked_final(const std::string& name) const {
  const std::string shown = final_path(name);
  const std::string problem = relative_name_problem(name);
  if (!problem.empty())
    throw OutputError(shown + ": refusing to write: output name " + quoted(name) + " " + problem +
                      " (outputs are plain relative names under the output folder)");
  const fs::path target = fs::path(canon_dir_) / name;
  const fs::path resolved = canonical_or_absolute(target);
  if (!is_within(resolved, fs::path(canon_dir_)) || resolved == fs::path(canon_dir_))
    throw OutputError(shown + ": refusing to write: it resolves to " + resolved.string() +
                      ", outside the output folder " + canon_dir_ + " (through a symbolic link)");
  const std::string hit = protected_match(target.string(), protected_);
  if (!hit.empty())
    throw OutputError(shown + ": refusing to write onto the input file " + hit +
                      (input_label_.empty() ? "" : " (referenced by " + input_label_ + ")") +
                      "; choose another output folder or output.name");
  return target.string();
}

void OutputSet::check(const std::string& name) const { checked_final(name); }

std::string OutputSet::path_for(const std::string& name) {
  if (committed_) throw OutputError(final_path(name) + ": the output set was already committed");
  checked_final(name);
  if (std::find(claimed_.begin(), claimed_.end(), name) != claimed_.end() || name == manifest_)
    throw OutputError(final_path(name) + ": written twice in one run (two outputs with one name)");
  const fs::path staged = fs::path(staging_) / name;
  std::error_code ec;
  fs::create_directories(staged.parent_path(), ec);
  if (ec) throw OutputError(final_path(name) + ": cannot create folder " + staged.parent_path().string() + ": " + ec.message());
  claimed_.push_back(name);
  return staged.string();
}

std::string OutputSet::manifest_path_for(const std::string& name) {
  if (!manifest_.empty()) throw OutputError(final_path(name) + ": a manifest (" + manifest_ + ") was already claimed");
  const std::string p = path_for(name);
  claimed_.pop_back();
  manifest_ = name;
  return p;
}

void OutputSet::write_file(const std::string& name, const std::string& data) {
  const std::string p = path_for(name);
  std::FILE* f = std::fopen(p.c_str(), "wb");
  if (!f) throw OutputError(final_path(name) + ": cannot create " + p + ": " + std::strerror(errno));
  const bool written = std::fwrite(data.data(), 1, data.size(), f) == data.size();
  const int e = errno;
  if (std::fclose(f) != 0 || !written) throw OutputError(final_path(name) + ": write failed: " + std::strerror(e));
}

std::vector<std::string> OutputSet::names() const {
  std::vector<std::string> v = claimed_;
  if (!manifest_.empty()) v.push_back(manifest_);
  return v;
}

void OutputSet::commit() {
  if (committed_) throw OutputError(dir_ + ": the output set was already committed");
  const std::vector<std::string> order = names();
  std::error_code ec;
  for (const std::string& n : order) {
    const fs::path staged = fs::path(staging_) / n;
    if (!fs::is_regular_file(staged, ec))
      throw OutputError(final_path(n) + ": asked for but never written (nothing of the output set was committed)");
    checked_final(n);  // again: folders may have changed since the name was claimed
    if (fs::is_directory(fs::path(canon_dir_) / n, ec))
      throw OutputError(final_path(n) + ": a folder of that name is in the way (nothing was committed)");
  }
  // A manifest from a previous run must not vouch for a half-replaced set.
  if (!manifest_.empty()) fs::remove(fs::path(canon_dir_) / manifest_, ec);
  std::vector<fs::path> moved;
  for (const std::string& n : order) {
    const fs::path staged = fs::path(staging_) / n, target = fs::path(canon_dir_) / n;
    fs::create_directories(target.parent_path(), ec);
    if (std::rename(staged.c_str(), target.c_str()) != 0) {
      const int e = errno;
      for (const fs::path& m : moved) fs::remove(m, ec);
      throw OutputError(final_path(n) + ": cannot move it into place from " + staged.string() + ": " + std::strerror(e) +
                        " (the files of this run already moved were removed)");
    }
    moved.push_back(target);
  }
  committed_ = true;
  cleanup();
}

}  // namespace texdefrag

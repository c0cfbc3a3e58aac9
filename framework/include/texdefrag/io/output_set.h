// The one write service: every file a run produces (writers, stage side outputs, debug files) is
// asked for here, so that no file the input references is ever written and the output set appears
// as a whole.
//
// Contract of an OutputSet (one per run):
// - names are plain relative paths under the output folder ("model.obj", "tiles/a.png"): no
//   absolute path, no "." or ".." component, no empty component, no control character; a name
//   whose final place resolves (through symbolic links) outside the output folder is refused.
// - a name that is, canonically, a protected file (every file the input references: OBJ, MTLs,
//   pages, label files...) or lies inside a protected path (a protected folder) is refused; so is
//   an output folder that is a protected file or inside a protected folder.
// - files are written under a hidden staging folder inside the output folder
//   (`.texdefrag-staging-<pid>-<random>`); nothing is visible under a final name before commit().
// - commit() first removes a previous manifest of the same name, then moves every staged file into
//   place in the order they were asked for, the manifest (if any) last. A reader that finds the
//   manifest knows the set beside it is complete.
// - the output folder is locked for the OutputSet's lifetime (`.texdefrag.lock`, an flock held
//   by this process; the kernel releases it if the process dies): a second run into the same
//   folder fails at construction with an error naming the lock file.
// - destroyed without commit() (an exception, a cancel), it removes its staging folder: no final
//   name is created, the folder is removed again if this OutputSet created it and it is empty.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace texdefrag {

/// A refused name, a held lock or a failed write or rename. The message names the file(s).
struct OutputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Checks that `name` is a plain relative file name as OutputSet takes it. Returns "" when it is,
/// else why not (e.g. "is an absolute path", "has a '..' component").
std::string relative_name_problem(const std::string& name);

/// Checks that `stem` is a file stem: a relative name with one component that does not start with
/// '.'. Returns "" when it is, else why not.
std::string file_stem_problem(const std::string& stem);

/// The entry of `protected_paths` that `path` is, or lies inside, compared canonically (through
/// symbolic links; missing tails compared lexically); "" when none.
std::string protected_match(const std::string& path, const std::vector<std::string>& protected_paths);

class OutputSet {
 public:
  /// output_dir: created (with its parents) if missing. protected_paths: the files the input
  /// references (any number; missing ones still protect their place). input_label: names the
  /// input in refusals ("the input in/model.obj references it"); may be empty.
  /// Throws OutputError when the folder is protected, cannot be created, or is locked by another run.
  OutputSet(const std::string& output_dir, std::vector<std::string> protected_paths, std::string input_label = "");
  /// Without commit(): removes the staging folder (and the output folder if this set created it and
  /// it is empty). Releases the lock.
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  /// Claims `name` and returns the staging path to write it to (its folder exists). Throws
  /// OutputError naming the file when the name is not plain, escapes the folder, is protected or
  /// was already claimed, or after commit().
  std::string path_for(const std::string& name);
  /// Checks `name` as path_for does, without claiming it (to refuse a run before its stages run).
  void check(const std::string& name) const;
  /// Claims `name` as the manifest: committed last, and its old copy removed first.
  std::string manifest_path_for(const std::string& name);
  /// Writes `data` to path_for(name).
  void write_file(const std::string& name, const std::string& data);

  /// Where `name` appears after commit() (output folder / name). Not checked.
  std::string final_path(const std::string& name) const;
  const std::string& dir() const { return dir_; }
  /// Names claimed so far, in order (manifest last if claimed).
  std::vector<std::string> names() const;

  /// Moves every claimed file into place (see the contract above). Throws OutputError naming the
  /// file when a claimed file was not written or a rename fails (the staging folder is removed).
  void commit();
  bool committed() const { return committed_; }

 private:
  std::string checked_final(const std::string& name) const;
  void lock();
  void cleanup() noexcept;

  std::string dir_;          ///< the output folder as given
  std::string canon_dir_;    ///< canonical output folder
  std::vector<std::string> protected_;
  std::string input_label_;
  std::string staging_;      ///< staging folder path
  std::vector<std::string> claimed_;
  std::string manifest_;
  int lock_fd_ = -1;
  bool created_dir_ = false;
  bool committed_ = false;
};

}  // namespace texdefrag

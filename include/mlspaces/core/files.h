// Reading whole files and writing them atomically (temp file + fsync + rename).
#pragma once

#include "mlspaces/core/export.h"

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace mlspaces {

/// Reads a whole file. @throws Error naming the path if it cannot be opened or read.
MLSPACES_API std::string ReadFile(const std::filesystem::path& path);

/// Reads a whole file opened with openat(dir_fd, path) (dir_fd may be AT_FDCWD): hot lookups
/// keep an O_PATH descriptor of their folder and save the kernel the walk of the full path.
/// Small files cost open, one read and close (no stat). `path_for_errors` names the file in
/// errors. @throws Error as ReadFile.
MLSPACES_API std::string ReadFileAt(int dir_fd, const char* path,
                                    const std::filesystem::path& path_for_errors);

/// True when `path` exists and is not a directory (follows symlinks).
MLSPACES_API bool IsFile(const std::filesystem::path& path);

/// Writes `data` to a temp file beside `path`, flushes it to disk (unless `sync` is false) and
/// renames it over `path`, so readers see the old file or the new one, never a half-written
/// one. Creates missing parent folders. `sync = false` is for batches of small files that the
/// caller makes durable with one syncfs() instead of an fsync each.
/// @throws Error naming the path on failure (the temp file is removed).
MLSPACES_API void WriteFileAtomic(const std::filesystem::path& path, std::string_view data,
                                  bool sync = true);

/// `path` relative to `base`, with '/' separators (the form the index files store).
MLSPACES_API std::string RelativeGenericPath(const std::filesystem::path& path,
                                             const std::filesystem::path& base);

/// A suffix unique to this process and call, for temp files renamed into place:
/// ".tmp.<pid>.<n>" (what WriteFileAtomic uses; crash leftovers match "*.tmp.*").
MLSPACES_API std::string TempSuffix();

/// Removes the entries of `dir` (not recursive; files or folders) that are temp files of
/// processes that no longer exist: names with TempSuffix's ".tmp.<pid>." whose pid is gone.
/// Temp files of live processes (another run sharing the folder) are kept. @returns how many.
MLSPACES_API size_t RemoveDeadTempFiles(const std::filesystem::path& dir);

/// A temp folder to build `path` in before renaming it into place: `<path><TempSuffix()>` in
/// the same parent (made with its missing parents; dead processes' leftovers there removed
/// first). The folder itself is not made. It is removed with its contents when this object dies,
/// unless Keep() was called once it was renamed into place.
class MLSPACES_API StagingFolder {
 public:
  explicit StagingFolder(const std::filesystem::path& path);
  ~StagingFolder();
  StagingFolder(const StagingFolder&) = delete;
  StagingFolder& operator=(const StagingFolder&) = delete;
  const std::filesystem::path& path() const { return path_; }
  void Keep() { path_.clear(); }

 private:
  std::filesystem::path path_;
};

/// Flushes the whole file system holding `dir` (syncfs): one call makes a batch of files
/// written without fsync durable. Best effort: an unopenable folder is ignored.
MLSPACES_API void SyncFileSystem(const std::filesystem::path& dir);

/// "<what>: <strerror(errno)>", for an Error after a failed POSIX call (reads errno first).
MLSPACES_API std::string Errno(std::string_view what);

/// Writes all of `data` to `fd`, retrying short writes and EINTR.
/// @returns false when a write fails (errno says why) or writes nothing (e.g. a closed pipe).
MLSPACES_API bool WriteAll(int fd, std::string_view data);

// --- File-system edits that throw Error -------------------------------------------------------
// std::filesystem's throwing calls raise std::filesystem::filesystem_error, which is not an
// mlspaces::Error; library code uses these instead (or the error_code overloads).

/// fs::create_directories. @throws Error naming `dir` and the reason.
MLSPACES_API void CreateDirectories(const std::filesystem::path& dir);

/// fs::rename. @throws Error naming both paths and the reason.
MLSPACES_API void RenamePath(const std::filesystem::path& from, const std::filesystem::path& to);

/// fs::remove_all (a missing path is no error). @throws Error naming `path` and the reason.
MLSPACES_API void RemoveAll(const std::filesystem::path& path);

/// fs::remove of one file or empty folder (a missing path is no error).
/// @throws Error naming `path` and the reason.
MLSPACES_API void RemovePath(const std::filesystem::path& path);

/// The entries of `dir` (files, folders, links; not recursive), sorted by name.
/// @throws Error naming `dir` when it cannot be read.
MLSPACES_API std::vector<std::filesystem::path> ListFolder(const std::filesystem::path& dir);

/// fsync of a file, or of a folder (`directory`) after a rename into it.
/// @throws Error naming `error_path` on failure.
MLSPACES_API void FsyncPath(const std::filesystem::path& path, bool directory,
                            const std::string& error_path);

}  // namespace mlspaces

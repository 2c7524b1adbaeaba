// .tar.zst archives (libarchive): deterministic writing and safe extraction. Plain functions
// on files: safe to call from several threads on different archives.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace mlspaces {

// =============================================================================================
// Writing

/// One file to put in an archive.
struct MLSPACES_API ArchiveMember {
  std::string path;              ///< path inside the archive, relative, '/'-separated
  std::filesystem::path source;  ///< the file on disk
};

struct MLSPACES_API ArchiveWriteOptions {
  int zstd_level = 3;
  /// fsync the archive and its folder. `pack` turns this off and flushes the whole package
  /// with one syncfs before publishing it (300,000 fsyncs would dominate a 150,000-archive pack).
  bool sync = true;
};

/// Writes a .tar.zst (POSIX pax/ustar, regular files only, members in the given order,
/// mtime 0, uid/gid 0, no user/group names, mode 0644) so the same inputs give the same
/// bytes. Written to a temp file and renamed into place. @returns the archive size in bytes.
/// @throws Error naming the archive or the member's source file.
uint64_t WriteTarZst(const std::filesystem::path& out, std::span<const ArchiveMember> members,
                     const ArchiveWriteOptions& options = {});

// =============================================================================================
// Reading

/// What an extraction produced.
struct MLSPACES_API ExtractReport {
  std::vector<std::string> files;  ///< regular files (and links) created, archive paths, in order
  uint64_t bytes = 0;              ///< regular file bytes written
};

/// Extracts a .tar.zst into `dest` (created if missing; normally an empty staging folder).
/// Refuses, with an Error naming the archive and the member, and leaving `dest` to be deleted
/// by the caller: absolute paths, '..' components, empty names, symlinks whose target leaves
/// `dest` (absolute, or climbing above it), hard links to anything but an earlier member,
/// device files, FIFOs and sockets, and a truncated or corrupt stream. Regular files are made
/// read-only (0444); folders 0755.
MLSPACES_API ExtractReport ExtractTarZst(const std::filesystem::path& archive,
                                         const std::filesystem::path& dest);

/// Regular-file paths of a .tar.zst, in archive order, without extracting. @throws Error.
MLSPACES_API std::vector<std::string> ListTarZst(const std::filesystem::path& archive);

}  // namespace mlspaces

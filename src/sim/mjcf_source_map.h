// Maps MuJoCo's MJCF error messages back to the source file, line and element (internal to
// mlspaces_sim; used by the composer).
//
// Why this exists: MuJoCo 3.5 reports "Element 'geom', line 5" or "Element name 'm', id 0,
// line 8", but not which file: elements of an <attach>ed model carry the line of the model's
// own file, elements of an <include>d file carry line 0, a parse error inside a <model> file
// only names the <model> element, and a few compile errors (a repeated name, a missing mesh
// file) name no element at all. Only when MuJoCo has reported an error, this module reads the
// source files again (the scene, its includes, its <model> files, the models attached at run
// time, each with its name prefix) and finds the element MuJoCo means. Nothing here runs on
// the success path.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace mlspaces::sim::internal {

/// One top-level source: the composed file (text given for FromString) or a model attached
/// at run time, with the prefix its names got.
struct SourceRoot {
  std::filesystem::path path;  // absolute
  std::string text;            // the file's text when it is not on disk; empty: read `path`
  std::string prefix;
};

/// Throws mlspaces::Error for a message of MuJoCo's XML parser (mj_parseXML) on `root`:
/// path = the file at fault (the root, an included file, a <model> file), field = "line N,
/// element <tag>" (or "line N" for malformed XML), message = MuJoCo's, on one line.
[[noreturn]] void ThrowParseError(std::string_view message, const SourceRoot& root);

/// Throws mlspaces::Error for a message of MuJoCo's compiler (mj_compile, mjs_attach) on the
/// model composed from `roots` (roots[0] the composed file, then the run-time attaches).
[[noreturn]] void ThrowCompileError(std::string_view message, const std::vector<SourceRoot>& roots);

/// The <model> assets of `root` and of the files it includes: name and resolved file.
std::vector<std::pair<std::string, std::filesystem::path>> ModelAssets(const SourceRoot& root);

/// MuJoCo's message on one line: its lines joined with "; ", without the "Element ..." lines
/// (the location goes to Error's path and field) and without "XML Error: " / "Error: ".
std::string OneLine(std::string_view message);

}  // namespace mlspaces::sim::internal

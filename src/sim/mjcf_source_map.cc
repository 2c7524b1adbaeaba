#include "mjcf_source_map.h"

#include <algorithm>
#include <map>
#include <optional>
#include <regex>

#include <pugixml.hpp>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"

namespace mlspaces::sim::internal {
namespace {

namespace fs = std::filesystem;

constexpr int kMaxDepth = 32;

/// One element of a source file.
struct Elem {
  fs::path file;
  int line = 0;
  std::string tag;
  std::string name;       // with the prefixes of the attaches it came through; "" when unnamed
  std::string ref;        // <include>/<model>: the resolved file; mesh, texture, ...: its file
  bool included = false;  // from an <include>d file (MuJoCo reports line 0 for those)
};

/// The elements of a root, its includes and its attached <model> files, in file order.
class Index {
 public:
  void AddRoot(const SourceRoot& root) {
    std::map<std::string, fs::path> models;
    Add(root.path, root.text, root.path.parent_path(), root.prefix, false, 0, &models);
  }

  const std::vector<Elem>& elems() const { return elems_; }

 private:
  void Add(const fs::path& file, std::string text, const fs::path& model_dir,
           const std::string& prefix, bool included, int depth,
           std::map<std::string, fs::path>* models) {
    if (depth > kMaxDepth) return;
    if (text.empty()) {
      try {
        text = ReadFile(file);
      } catch (const Error&) {
        return;
      }
    }
    pugi::xml_document doc;
    if (!doc.load_buffer(text.data(), text.size())) return;
    std::vector<size_t> starts{0};
    for (size_t i = 0; i < text.size(); ++i) {
      if (text[i] == '\n') starts.push_back(i + 1);
    }
    auto line_of = [&](pugi::xml_node n) {
      return static_cast<int>(
          std::upper_bound(starts.begin(), starts.end(), static_cast<size_t>(n.offset_debug())) -
          starts.begin());
    };
    std::vector<std::pair<std::string, std::string>> attaches;  // model, prefix
    auto walk = [&](auto&& self, pugi::xml_node node) -> void {
      for (pugi::xml_node e = node.first_child(); e; e = e.next_sibling()) {
        if (e.type() != pugi::node_element) continue;
        Elem el{file, line_of(e), e.name(), "", "", included};
        if (const char* n = e.attribute("name").value(); *n) el.name = prefix + n;
        const std::string f = e.attribute("file").value();
        if (!f.empty())
          el.ref = el.tag == "include" || el.tag == "model"
                       ? (model_dir / f).lexically_normal().string()
                       : f;
        elems_.push_back(el);
        if (el.tag == "include" && !f.empty()) {
          Add(el.ref, "", model_dir, prefix, true, depth + 1, models);
        } else if (el.tag == "model" && !f.empty()) {
          (*models)[e.attribute("name").value()] = el.ref;
        } else if (el.tag == "attach") {
          attaches.emplace_back(e.attribute("model").value(), e.attribute("prefix").value());
        }
        self(self, e);
      }
    };
    walk(walk, doc);
    for (const auto& [model, attach_prefix] : attaches) {
      auto it = models->find(model);
      if (it == models->end()) continue;
      std::map<std::string, fs::path> child_models;
      Add(it->second, "", it->second.parent_path(), prefix + attach_prefix, false, depth + 1,
          &child_models);
    }
  }

  std::vector<Elem> elems_;
};

std::string Field(int line, std::string_view tag) {
  std::string f = "line " + std::to_string(line);
  if (!tag.empty()) f += ", element <" + std::string(tag) + ">";
  return f;
}

/// The last "Element 'tag', line N" of a parser message, and the text before it.
struct Located {
  std::string inner;
  std::string tag;
  int line = 0;
};

std::optional<Located> LastElement(std::string_view message) {
  static const std::regex kElement(R"(\n?Element '([^']*)', line (\d+)\s*$)");
  std::string s(message);
  std::smatch m;
  if (!std::regex_search(s, m, kElement)) return std::nullopt;
  return Located{s.substr(0, m.position(0)), m[1].str(), std::stoi(m[2].str())};
}

std::string StripPrefix(std::string s, std::string_view prefix) {
  if (s.rfind(prefix, 0) == 0) s.erase(0, prefix.size());
  return s;
}

/// The element MuJoCo means by (tag, line) in `root`'s own text or, for line 0, in its
/// included files; its <model>/<include> reference follows in `ref`.
std::optional<Elem> FindInRoot(const Index& index, const SourceRoot& root, std::string_view tag,
                               int line) {
  for (const Elem& e : index.elems()) {
    if (e.tag != tag) continue;
    if (line > 0 && !e.included && e.file == root.path && e.line == line) return e;
    if (line == 0 && e.included) return e;
  }
  return std::nullopt;
}

}  // namespace

std::vector<std::pair<std::string, fs::path>> ModelAssets(const SourceRoot& root) {
  Index index;
  index.AddRoot(SourceRoot{root.path, root.text, ""});
  std::vector<std::pair<std::string, fs::path>> out;
  for (const Elem& e : index.elems()) {
    if (e.tag != "model" || e.ref.empty() || (e.file != root.path && !e.included)) continue;
    out.emplace_back(e.name, e.ref);
  }
  return out;
}

std::string OneLine(std::string_view message) {
  std::string out;
  size_t start = 0;
  while (start <= message.size()) {
    size_t end = message.find('\n', start);
    if (end == std::string_view::npos) end = message.size();
    std::string line(message.substr(start, end - start));
    start = end + 1;
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    if (line.empty() || line.rfind("Element", 0) == 0) continue;
    line = StripPrefix(StripPrefix(std::move(line), "XML Error: "), "Error: ");
    if (!out.empty()) out += "; ";
    out += line;
  }
  return out.empty() ? std::string("MuJoCo reported an error") : out;
}

void ThrowParseError(std::string_view message, const SourceRoot& root) {
  const std::string path = root.path.string();
  // Malformed XML (tinyxml2): "XML parse error 14:\nError=... Line number=3: ...".
  static const std::regex kXmlLine(R"(Line number=(\d+))");
  std::optional<Located> at = LastElement(message);
  if (!at) {
    std::string s(message);
    std::smatch m;
    // tinyxml2's "Error=XML_ERROR_MISMATCHED_ELEMENT ErrorID=14 (0xe) Line number=3: XMLElement
    // name=body" reads as "XML parse error: XML_ERROR_MISMATCHED_ELEMENT (XMLElement name=body)".
    static const std::regex kTinyXml(
        R"(Error=(\w+) ErrorID=\d+ \(0x[0-9a-fA-F]+\) Line number=(\d+):? ?([^\n]*))");
    if (std::regex_search(s, m, kTinyXml)) {
      std::string text = "XML parse error: " + m[1].str();
      if (m[3].length() > 0) text += " (" + m[3].str() + ")";
      throw Error(text, path, "line " + m[2].str());
    }
    if (std::regex_search(s, m, kXmlLine)) {
      throw Error(OneLine(message), path, "line " + m[1].str());
    }
    throw Error(OneLine(message), path);
  }
  // An error inside a <model> or <include>d file: MuJoCo names only the element that read it.
  std::string inner = StripPrefix(at->inner, "XML Error: ");
  const bool nested_model = inner.rfind("could not parse model file with error: ", 0) == 0;
  const bool nested_include = inner.rfind("Include error: '", 0) == 0;
  if (nested_model || nested_include) {
    inner = nested_model ? StripPrefix(inner, "could not parse model file with error: ")
                         : StripPrefix(inner, "Include error: '");
    if (nested_include && !inner.empty() && inner.back() == '\'') inner.pop_back();
    Index index;
    index.AddRoot(root);
    std::optional<Elem> e = FindInRoot(index, root, at->tag, at->line);
    const bool located = LastElement(inner) || inner.find("Line number=") != std::string::npos;
    if (e && !e->ref.empty() && located) ThrowParseError(inner, SourceRoot{e->ref, "", ""});
    if (e) throw Error(OneLine(inner), e->file.string(), Field(e->line, e->tag));
    throw Error(OneLine(inner), path, Field(at->line, at->tag));
  }
  if (at->line > 0) throw Error(OneLine(message), path, Field(at->line, at->tag));
  // Line 0: the element is in an included file.
  Index index;
  index.AddRoot(root);
  if (std::optional<Elem> e = FindInRoot(index, root, at->tag, 0)) {
    throw Error(OneLine(message), e->file.string(), Field(e->line, e->tag));
  }
  throw Error(OneLine(message), path, "element <" + at->tag + "> of an included file");
}

void ThrowCompileError(std::string_view message, const std::vector<SourceRoot>& roots) {
  const std::string fallback = roots.empty() ? std::string() : roots[0].path.string();
  const std::string text(message);
  Index index;
  for (const SourceRoot& r : roots) index.AddRoot(r);
  std::smatch m;
  // "Element name 'a/m', id 0, line 18": the element's (prefixed) name and its own file's line.
  static const std::regex kNamed(R"(Element name '([^']*)', id \d+, line (\d+))");
  if (std::regex_search(text, m, kNamed)) {
    const std::string name = m[1].str();
    const int line = std::stoi(m[2].str());
    const Elem* best = nullptr;
    for (const Elem& e : index.elems()) {
      if (e.name != name) continue;
      const bool line_ok = line > 0 ? e.line == line && !e.included : e.included;
      if (!line_ok) continue;
      if (!name.empty() || e.file == roots[0].path) {
        best = &e;
        break;
      }
      if (!best) best = &e;
    }
    if (best) throw Error(OneLine(message), best->file.string(), Field(best->line, best->tag));
    throw Error(OneLine(message), fallback, line > 0 ? "line " + std::to_string(line) : "");
  }
  // "repeated name 'x/link' in body": name both definitions.
  static const std::regex kRepeated(R"(repeated name '([^']*)' in (\w+))");
  if (std::regex_search(text, m, kRepeated)) {
    const std::string name = m[1].str(), kind = m[2].str();
    std::vector<const Elem*> defs;
    for (const Elem& e : index.elems()) {
      const bool same_kind = e.tag == kind || (kind == "joint" && e.tag == "freejoint");
      if (e.name == name && same_kind) defs.push_back(&e);
    }
    if (defs.size() >= 2) {
      auto where = [](const Elem& e) {
        return e.file.string() + " line " + std::to_string(e.line);
      };
      throw Error("name '" + name + "' of <" + kind + "> is defined twice: " + where(*defs[0]) +
                      " and " + where(*defs[1]),
                  defs[1]->file.string(), Field(defs[1]->line, defs[1]->tag));
    }
  }
  // "Error opening file 'x.obj'": the asset element naming that file.
  static const std::regex kOpening(R"(Error opening file '([^']*)')");
  if (std::regex_search(text, m, kOpening)) {
    const std::string missing = m[1].str();
    for (const Elem& e : index.elems()) {
      if (e.ref.empty() || e.tag == "include" || e.tag == "model") continue;
      if (missing == e.ref || missing.ends_with("/" + e.ref)) {
        throw Error("file not found: " + missing, e.file.string(), Field(e.line, e.tag));
      }
    }
  }
  throw Error(OneLine(message), fallback);
}

}  // namespace mlspaces::sim::internal

#include "mlspaces/sim/mjcf_composer.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <numbers>
#include <regex>
#include <set>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include <pugixml.hpp>

#include "mjcf_math.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"

namespace mlspaces::sim {
namespace {

namespace fs = std::filesystem;
using internal::Quat;
using internal::Vec3;

constexpr const char* kSrc = "mlspaces-src";
constexpr const char* kDefaultsHold = "mlspaces-defaults";
constexpr int kMaxDepth = 32;

/// Reference attributes: values that name another element (prefixed with the names).
const std::unordered_set<std::string>& RefAttrs() {
  static const std::unordered_set<std::string> s = {
      "mesh",     "material",  "hfield",  "texture",   "target",     "body",
      "body1",    "body2",     "geom",    "geom1",     "geom2",      "site",
      "site1",    "site2",     "sidesite", "joint",    "joint1",     "joint2",
      "jointinparent", "tendon", "tendon1", "tendon2", "actuator",   "refsite",
      "slidersite", "cranksite", "objname", "refname"};
  return s;
}

const std::unordered_set<std::string> kWorldClassTags = {"joint", "geom", "site", "camera",
                                                         "light"};
const std::unordered_set<std::string> kPosedTags = {"body", "geom", "site", "camera", "frame",
                                                    "inertial"};
const char* const kMergedSections[] = {"asset",    "contact", "equality", "tendon",
                                       "actuator", "sensor",  "custom"};

struct Shared {
  ComposeOptions options;
  std::vector<std::string> files;
  std::vector<std::vector<size_t>> line_starts;
  std::vector<std::string> warnings;
  int next_instance = 0;
};

std::string Format17(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  // Prefer the shortest form that round-trips, for readable output.
  for (int prec = 6; prec < 17; ++prec) {
    char b2[32];
    std::snprintf(b2, sizeof b2, "%.*g", prec, v);
    if (std::strtod(b2, nullptr) == v) return b2;
  }
  return buf;
}

template <size_t N>
std::string FormatVec(const std::array<double, N>& v) {
  std::string s;
  for (size_t i = 0; i < N; ++i) {
    if (i) s += ' ';
    s += Format17(v[i]);
  }
  return s;
}

std::pair<std::string, int> SourceOf(const Shared& sh, pugi::xml_node node) {
  for (pugi::xml_node n = node; n; n = n.parent()) {
    pugi::xml_attribute a = n.attribute(kSrc);
    if (!a) continue;
    std::string v = a.value();
    size_t colon = v.find(':');
    size_t idx = std::stoul(v.substr(0, colon));
    int line = std::stoi(v.substr(colon + 1));
    return {idx < sh.files.size() ? sh.files[idx] : std::string(), line};
  }
  return {sh.files.empty() ? std::string() : sh.files[0], 0};
}

[[noreturn]] void Fail(const Shared& sh, pugi::xml_node node, const std::string& message) {
  auto [file, line] = SourceOf(sh, node);
  std::string field = line > 0 ? "line " + std::to_string(line) + ", element <" +
                                     std::string(node.name()) + ">"
                               : std::string();
  throw Error(message, file, field);
}

std::vector<double> ParseNumbers(const Shared& sh, pugi::xml_node node, const char* attr) {
  std::vector<double> out;
  const char* s = node.attribute(attr).value();
  while (true) {
    while (*s == ' ' || *s == '\t' || *s == '\n' || *s == '\r') ++s;
    if (!*s) break;
    char* end = nullptr;
    errno = 0;
    double v = std::strtod(s, &end);
    if (end == s || (*end && *end != ' ' && *end != '\t' && *end != '\n' && *end != '\r') ||
        !std::isfinite(v)) {
      Fail(sh, node, std::string("bad number in attribute '") + attr + "': '" +
                         node.attribute(attr).value() + "'");
    }
    out.push_back(v);
    s = end;
  }
  return out;
}

template <size_t N>
std::array<double, N> ParseFixed(const Shared& sh, pugi::xml_node node, const char* attr) {
  std::vector<double> v = ParseNumbers(sh, node, attr);
  if (v.size() != N) {
    Fail(sh, node, std::string("attribute '") + attr + "' needs " + std::to_string(N) +
                       " numbers, got '" + node.attribute(attr).value() + "'");
  }
  std::array<double, N> out;
  std::copy(v.begin(), v.end(), out.begin());
  return out;
}

bool IsElement(pugi::xml_node n) { return n.type() == pugi::node_element; }

template <typename F>
void ForEachElement(pugi::xml_node node, F&& f) {
  for (pugi::xml_node c = node.first_child(); c; c = c.next_sibling()) {
    if (!IsElement(c)) continue;
    f(c);
    ForEachElement(c, f);
  }
}

std::vector<pugi::xml_node> Children(pugi::xml_node node, const char* name = nullptr) {
  std::vector<pugi::xml_node> out;
  for (pugi::xml_node c = node.first_child(); c; c = c.next_sibling()) {
    if (IsElement(c) && (!name || std::string_view(c.name()) == name)) out.push_back(c);
  }
  return out;
}

pugi::xml_node FindBody(pugi::xml_node node, std::string_view name) {
  for (pugi::xml_node c : Children(node)) {
    std::string_view tag = c.name();
    if (tag == "body" && name == c.attribute("name").value()) return c;
    if (tag == "body" || tag == "frame" || tag == "worldbody") {
      if (pugi::xml_node f = FindBody(c, name)) return f;
    }
  }
  return {};
}

void ApplyPose(const Shared& sh, pugi::xml_node n, const Pose& t) {
  std::string_view tag = n.name();
  auto xform = [&](const Vec3& p) {
    Vec3 r = internal::Rotate(t.quat, p);
    return Vec3{r[0] + t.pos[0], r[1] + t.pos[1], r[2] + t.pos[2]};
  };
  if (tag == "light") {
    Vec3 pos = n.attribute("pos") ? ParseFixed<3>(sh, n, "pos") : Vec3{0, 0, 0};
    Vec3 dir = n.attribute("dir") ? ParseFixed<3>(sh, n, "dir") : Vec3{0, 0, -1};
    if (!n.attribute("pos")) n.append_attribute("pos");
    if (!n.attribute("dir")) n.append_attribute("dir");
    n.attribute("pos").set_value(FormatVec(xform(pos)).c_str());
    n.attribute("dir").set_value(FormatVec(internal::Rotate(t.quat, dir)).c_str());
    return;
  }
  if (tag != "body" && tag != "geom" && tag != "site" && tag != "camera" && tag != "frame") {
    Fail(sh, n, "element <" + std::string(tag) + "> is not allowed in a <frame> or attachment");
  }
  if ((tag == "geom" || tag == "site") && n.attribute("fromto")) {
    auto ft = ParseFixed<6>(sh, n, "fromto");
    Vec3 a = xform({ft[0], ft[1], ft[2]}), b = xform({ft[3], ft[4], ft[5]});
    n.attribute("fromto").set_value(
        FormatVec(std::array<double, 6>{a[0], a[1], a[2], b[0], b[1], b[2]}).c_str());
    return;
  }
  Vec3 pos = n.attribute("pos") ? ParseFixed<3>(sh, n, "pos") : Vec3{0, 0, 0};
  Quat q = n.attribute("quat") ? internal::QuatNormalize(ParseFixed<4>(sh, n, "quat"))
                               : Quat{1, 0, 0, 0};
  if (!n.attribute("pos")) n.append_attribute("pos");
  if (!n.attribute("quat")) n.append_attribute("quat");
  n.attribute("pos").set_value(FormatVec(xform(pos)).c_str());
  n.attribute("quat").set_value(
      FormatVec(internal::QuatNormalize(internal::QuatMul(t.quat, q))).c_str());
}

Pose ReadPose(const Shared& sh, pugi::xml_node n) {
  Pose p;
  if (n.attribute("pos")) p.pos = ParseFixed<3>(sh, n, "pos");
  if (n.attribute("quat")) p.quat = internal::QuatNormalize(ParseFixed<4>(sh, n, "quat"));
  return p;
}

bool IsIdentity(const Pose& p) {
  return p.pos == std::array<double, 3>{0, 0, 0} && p.quat == std::array<double, 4>{1, 0, 0, 0};
}

void FoldFrames(const Shared& sh, pugi::xml_node node) {
  pugi::xml_node c = node.first_child();
  while (c) {
    if (!IsElement(c)) {
      c = c.next_sibling();
      continue;
    }
    std::string_view tag = c.name();
    if (tag == "frame") {
      Pose t = ReadPose(sh, c);
      pugi::xml_node first;
      for (pugi::xml_node gc : Children(c)) {
        pugi::xml_node moved = node.insert_move_before(gc, c);
        ApplyPose(sh, moved, t);
        if (!first) first = moved;
      }
      pugi::xml_node after = c.next_sibling();
      node.remove_child(c);
      c = first ? first : after;
      continue;
    }
    if (tag == "body") FoldFrames(sh, c);
    c = c.next_sibling();
  }
}

/// One model file being composed: the scene, or one <attach>ed model.
class Instance {
 public:
  static std::unique_ptr<Instance> FromFile(Shared* sh, const fs::path& file,
                                            const std::string& prefix, int depth,
                                            pugi::xml_node from = {}) {
    std::string text;
    try {
      text = ReadFile(file);
    } catch (const Error& e) {
      if (from) Fail(*sh, from, "cannot read model file '" + file.string() + "'");
      throw;
    }
    return FromText(sh, text, file, prefix, depth);
  }

  static std::unique_ptr<Instance> FromText(Shared* sh, std::string_view text,
                                            const fs::path& file, const std::string& prefix,
                                            int depth) {
    auto inst = std::unique_ptr<Instance>(new Instance(sh));
    inst->file_ = fs::absolute(file).lexically_normal();
    inst->dir_ = inst->file_.parent_path();
    inst->prefix_ = prefix;
    inst->id_ = sh->next_instance++;
    inst->depth_ = depth;
    inst->Process(text);
    return inst;
  }

  pugi::xml_node root() const { return root_; }
  const std::vector<std::pair<std::string, std::string>>& compiler_attrs() const {
    return compiler_attrs_;
  }
  const fs::path& file() const { return file_; }
  const std::string& prefix() const { return prefix_; }

  std::unique_ptr<Instance> Clone(Shared* sh) const {
    auto c = std::unique_ptr<Instance>(new Instance(sh));
    c->doc_.reset(doc_);
    c->root_ = c->doc_.document_element();
    c->file_ = file_;
    c->dir_ = dir_;
    c->prefix_ = prefix_;
    c->id_ = id_;
    c->depth_ = depth_;
    c->compiler_attrs_ = compiler_attrs_;
    return c;
  }

  /// Splices `child` into this model under `parent` (before `before`, or at the end), at
  /// `pose`; `body` picks one body subtree. Returns the top-level body names inserted.
  std::vector<std::string> Splice(const Instance& child, pugi::xml_node parent,
                                  pugi::xml_node before, const Pose& pose, std::string_view body,
                                  pugi::xml_node error_node) {
    std::vector<pugi::xml_node> sources;
    bool subtree = !body.empty();
    if (subtree) {
      std::string want = child.prefix_ + std::string(body);
      pugi::xml_node found;
      for (pugi::xml_node wb : Children(child.root_, "worldbody")) {
        if ((found = FindBody(wb, want))) break;
      }
      if (!found) {
        std::string msg = "model '" + child.file_.string() + "' has no body '" +
                          std::string(body) + "'";
        if (error_node) Fail(*sh_, error_node, msg);
        throw Error(msg, child.file_.string());
      }
      sources.push_back(found);
    } else {
      for (pugi::xml_node wb : Children(child.root_, "worldbody")) {
        for (pugi::xml_node c : Children(wb)) sources.push_back(c);
      }
    }
    std::vector<std::string> bodies;
    std::unordered_set<std::string> defined;
    for (pugi::xml_node src : sources) {
      pugi::xml_node n = before ? parent.insert_copy_before(src, before) : parent.append_copy(src);
      if (!IsIdentity(pose)) ApplyPose(*sh_, n, pose);
      if (std::string_view(n.name()) == "body") bodies.push_back(n.attribute("name").value());
      if (subtree) {
        if (n.attribute("name")) defined.insert(n.attribute("name").value());
        ForEachElement(n, [&](pugi::xml_node e) {
          if (e.attribute("name")) defined.insert(e.attribute("name").value());
        });
      }
    }
    if (subtree) {
      for (const char* sec : {"asset", "tendon", "actuator"}) {
        for (pugi::xml_node s : Children(child.root_, sec)) {
          for (pugi::xml_node e : Children(s)) {
            if (e.attribute("name")) defined.insert(e.attribute("name").value());
          }
        }
      }
    }
    for (const char* sec : kMergedSections) {
      for (pugi::xml_node s : Children(child.root_, sec)) {
        for (pugi::xml_node e : Children(s)) {
          if (subtree && std::string_view(sec) != "asset" && std::string_view(sec) != "custom") {
            bool inside = true;
            auto check = [&](pugi::xml_node x) {
              for (pugi::xml_attribute a : x.attributes()) {
                if (RefAttrs().count(a.name()) && std::string_view(a.name()) != "material" &&
                    !defined.count(a.value())) {
                  inside = false;
                }
              }
            };
            check(e);
            ForEachElement(e, check);
            if (!inside) continue;
          }
          Section(sec).append_copy(e);
        }
      }
    }
    for (pugi::xml_node k : Children(child.root_, "keyframe")) {
      if (k.first_child()) {
        auto [f, line] = SourceOf(*sh_, k);
        sh_->warnings.push_back(f + ": line " + std::to_string(line) +
                                ": keyframes of an attached model are dropped");
      }
    }
    pugi::xml_node hold = Hold();
    for (pugi::xml_node d : Children(child.root_, "default")) hold.append_copy(d);
    for (pugi::xml_node h : Children(child.root_, kDefaultsHold)) {
      for (pugi::xml_node d : Children(h)) hold.append_copy(d);
    }
    return bodies;
  }

  pugi::xml_node Section(const char* name) {
    pugi::xml_node s = root_.child(name);
    if (!s) s = root_.append_child(name);
    return s;
  }

 private:
  explicit Instance(Shared* sh) : sh_(sh) {}

  pugi::xml_node Hold() {
    pugi::xml_node h = root_.child(kDefaultsHold);
    if (!h) h = root_.append_child(kDefaultsHold);
    return h;
  }

  void Process(std::string_view text) {
    if (depth_ > kMaxDepth) {
      throw Error("models attach or include each other too deeply (a cycle?)", file_.string());
    }
    ParseInto(doc_, text, file_);
    root_ = doc_.document_element();
    if (std::string_view(root_.name()) != "mujoco") {
      Fail(*sh_, root_, "the root element must be <mujoco>");
    }
    ExpandIncludes(root_, 0);
    ReadCompiler();
    ReadDefaults();
    ResolveClasses();
    NormalizeOrientations();
    RebaseFiles();
    ExpandAttaches();
    for (pugi::xml_node wb : Children(root_, "worldbody")) FoldFrames(*sh_, wb);
    if (!prefix_.empty()) ApplyPrefix();
  }

  void ParseInto(pugi::xml_document& doc, std::string_view text, const fs::path& file) {
    size_t idx = sh_->files.size();
    sh_->files.push_back(file.string());
    std::vector<size_t> starts{0};
    for (size_t i = 0; i < text.size(); ++i) {
      if (text[i] == '\n') starts.push_back(i + 1);
    }
    sh_->line_starts.push_back(starts);
    pugi::xml_parse_result r = doc.load_buffer(text.data(), text.size(), pugi::parse_default);
    auto line_of = [&](ptrdiff_t off) {
      return static_cast<int>(std::upper_bound(starts.begin(), starts.end(),
                                               static_cast<size_t>(std::max<ptrdiff_t>(off, 0))) -
                              starts.begin());
    };
    if (!r) {
      throw Error(std::string("XML parse error: ") + r.description(), file.string(),
                  "line " + std::to_string(line_of(r.offset)));
    }
    ForEachElement(doc, [&](pugi::xml_node e) {
      e.append_attribute(kSrc).set_value(
          (std::to_string(idx) + ":" + std::to_string(line_of(e.offset_debug()))).c_str());
    });
  }

  void ExpandIncludes(pugi::xml_node node, int depth) {
    pugi::xml_node c = node.first_child();
    while (c) {
      if (!IsElement(c)) {
        c = c.next_sibling();
        continue;
      }
      if (std::string_view(c.name()) != "include") {
        ExpandIncludes(c, depth);
        c = c.next_sibling();
        continue;
      }
      if (++includes_ > 1000) Fail(*sh_, c, "too many includes (a cycle?)");
      const char* f = c.attribute("file").value();
      if (!*f) Fail(*sh_, c, "<include> needs a 'file' attribute");
      fs::path p = fs::path(f).is_absolute() ? fs::path(f) : dir_ / f;
      std::string text;
      try {
        text = ReadFile(p);
      } catch (const Error&) {
        Fail(*sh_, c, "cannot read included file '" + p.string() + "'");
      }
      pugi::xml_document inc;
      ParseInto(inc, text, p);
      pugi::xml_node iroot = inc.document_element();
      if (std::string_view(iroot.name()) != "mujoco") {
        Fail(*sh_, iroot, "an included file's root element must be <mujoco>");
      }
      pugi::xml_node first;
      for (pugi::xml_node ic : Children(iroot)) {
        pugi::xml_node n = node.insert_copy_before(ic, c);
        if (!first) first = n;
      }
      pugi::xml_node after = c.next_sibling();
      node.remove_child(c);
      c = first ? first : after;  // the inserted nodes may hold includes too
    }
  }

  void ReadCompiler() {
    for (pugi::xml_node c : Children(root_, "compiler")) {
      for (pugi::xml_attribute a : c.attributes()) {
        std::string_view n = a.name();
        std::string v = a.value();
        if (n == kSrc) continue;
        if (n == "angle") {
          if (v != "degree" && v != "radian") Fail(*sh_, c, "angle must be degree or radian");
          degrees_ = v == "degree";
        } else if (n == "eulerseq") {
          if (v.size() != 3 || v.find_first_not_of("xyzXYZ") != std::string::npos) {
            Fail(*sh_, c, "bad eulerseq '" + v + "'");
          }
          eulerseq_ = v;
        } else if (n == "meshdir") {
          meshdir_ = v;
        } else if (n == "texturedir") {
          texturedir_ = v;
        } else if (n == "assetdir") {
          assetdir_ = v;
        } else if (n == "coordinate") {
          if (v != "local") Fail(*sh_, c, "coordinate=\"global\" is not supported (MuJoCo 3)");
        } else {
          compiler_attrs_.emplace_back(std::string(n), v);
        }
      }
      root_.remove_child(c);
    }
  }

  std::string NewClass(const std::string& orig) const {
    std::string base = "__m" + std::to_string(id_) + "__";
    if (orig == "main") return base;
    return id_ == 0 ? orig : base + "/" + orig;
  }

  void ReadDefaults() {
    std::vector<pugi::xml_node> roots = Children(root_, "default");
    if (roots.empty()) {
      pugi::xml_node d = root_.prepend_child("default");
      roots.push_back(d);
    }
    for (size_t i = 1; i < roots.size(); ++i) {
      for (pugi::xml_node c : Children(roots[i])) roots[0].append_move(c);
      root_.remove_child(roots[i]);
    }
    pugi::xml_node main = roots[0];
    if (main.attribute("class") && std::string_view(main.attribute("class").value()) != "main") {
      Fail(*sh_, main, "the top-level <default> must not name a class other than 'main'");
    }
    std::function<void(pugi::xml_node, const std::string&)> walk =
        [&](pugi::xml_node d, const std::string& name) {
          if (classes_.count(name)) Fail(*sh_, d, "default class '" + name + "' defined twice");
          classes_[name] = d;
          if (!d.attribute("class")) d.append_attribute("class");
          d.attribute("class").set_value(NewClass(name).c_str());
          for (pugi::xml_node c : Children(d, "default")) {
            const char* cn = c.attribute("class").value();
            if (!*cn) Fail(*sh_, c, "a nested <default> needs a 'class' attribute");
            walk(c, cn);
          }
        };
    walk(main, "main");
  }

  pugi::xml_attribute Lookup(const std::string& cls, const char* tag, const char* attr) const {
    auto it = classes_.find(cls);
    if (it == classes_.end()) return {};
    for (pugi::xml_node d = it->second; d && std::string_view(d.name()) == "default";
         d = d.parent()) {
      pugi::xml_node e = d.child(tag);
      if (e && e.attribute(attr)) return e.attribute(attr);
    }
    return {};
  }

  std::string ClassOf(pugi::xml_node e, const std::string& ctx) const {
    pugi::xml_attribute a = e.attribute("class");
    std::string cls = a ? a.value() : ctx;
    if (!classes_.count(cls)) Fail(*sh_, e, "unknown default class '" + cls + "'");
    return cls;
  }

  void SetClass(pugi::xml_node e, const std::string& cls) {
    if (!e.attribute("class")) e.append_attribute("class");
    e.attribute("class").set_value(NewClass(cls).c_str());
  }

  void ResolveWorld(pugi::xml_node node, const std::string& ctx) {
    for (pugi::xml_node c : Children(node)) {
      std::string tag = c.name();
      if (tag == "body" || tag == "frame") {
        std::string inner = ctx;
        if (pugi::xml_attribute cc = c.attribute("childclass")) {
          inner = cc.value();
          if (!classes_.count(inner)) Fail(*sh_, c, "unknown default class '" + inner + "'");
          c.remove_attribute(cc);
        }
        ResolveWorld(c, inner);
      } else if (kWorldClassTags.count(tag)) {
        std::string cls = ClassOf(c, ctx);
        SetClass(c, cls);
        if (tag == "joint") ConvertJointAngles(c, cls);
        if (tag == "light" && !c.attribute("dir")) {
          pugi::xml_attribute d = Lookup(cls, "light", "dir");
          c.append_attribute("dir").set_value(d ? d.value() : "0 0 -1");
        }
      }
    }
  }

  void ConvertJointAngles(pugi::xml_node j, const std::string& cls) {
    if (!degrees_) return;
    auto get = [&](const char* attr) -> pugi::xml_attribute {
      if (j.attribute(attr)) return j.attribute(attr);
      return Lookup(cls, "joint", attr);
    };
    pugi::xml_attribute t = get("type");
    std::string type = t ? t.value() : "hinge";
    if (type != "hinge" && type != "ball") return;
    std::vector<const char*> attrs = {"range"};
    if (type == "hinge") {
      attrs.push_back("ref");
      attrs.push_back("springref");
    }
    for (const char* attr : attrs) {
      pugi::xml_attribute a = get(attr);
      if (!a) continue;
      if (!j.attribute(attr)) j.append_attribute(attr).set_value(a.value());
      std::vector<double> v = ParseNumbers(*sh_, j, attr);
      std::string s;
      for (size_t i = 0; i < v.size(); ++i) {
        if (i) s += ' ';
        s += Format17(v[i] * std::numbers::pi / 180.0);
      }
      j.attribute(attr).set_value(s.c_str());
    }
  }

  void ResolveClasses() {
    for (pugi::xml_node wb : Children(root_, "worldbody")) ResolveWorld(wb, "main");
    auto all = [&](const char* sec, std::initializer_list<const char*> tags) {
      for (pugi::xml_node s : Children(root_, sec)) {
        for (pugi::xml_node e : Children(s)) {
          bool want = tags.size() == 0;
          for (const char* t : tags) want = want || std::string_view(e.name()) == t;
          if (want) SetClass(e, ClassOf(e, "main"));
        }
      }
    };
    all("asset", {"mesh", "material"});
    all("contact", {"pair"});
    all("equality", {});
    all("tendon", {"spatial", "fixed"});
    all("actuator", {});
  }

  Quat OrientationOf(pugi::xml_node e) {
    int count = 0;
    Quat q{1, 0, 0, 0};
    double unit = degrees_ ? std::numbers::pi / 180.0 : 1.0;
    if (e.attribute("quat")) {
      ++count;
      q = internal::QuatNormalize(ParseFixed<4>(*sh_, e, "quat"));
    }
    if (e.attribute("axisangle")) {
      ++count;
      auto v = ParseFixed<4>(*sh_, e, "axisangle");
      if (internal::Norm({v[0], v[1], v[2]}) < 1e-15) Fail(*sh_, e, "axisangle axis is zero");
      q = internal::AxisAngle({v[0], v[1], v[2]}, v[3] * unit);
    }
    if (e.attribute("euler")) {
      ++count;
      auto v = ParseFixed<3>(*sh_, e, "euler");
      q = {1, 0, 0, 0};
      for (int i = 0; i < 3; ++i) {
        char c = eulerseq_[i];
        Vec3 axis{0, 0, 0};
        axis[std::tolower(c) - 'x'] = 1;
        Quat r = internal::AxisAngle(axis, v[i] * unit);
        q = std::islower(c) ? internal::QuatMul(q, r) : internal::QuatMul(r, q);
      }
    }
    if (e.attribute("xyaxes")) {
      ++count;
      auto v = ParseFixed<6>(*sh_, e, "xyaxes");
      q = internal::XYAxesToQuat({v[0], v[1], v[2]}, {v[3], v[4], v[5]});
    }
    if (e.attribute("zaxis")) {
      ++count;
      auto v = ParseFixed<3>(*sh_, e, "zaxis");
      if (internal::Norm(v) < 1e-15) Fail(*sh_, e, "zaxis is zero");
      q = internal::ZAxisToQuat(v);
    }
    if (count > 1) Fail(*sh_, e, "more than one orientation given");
    return q;
  }

  void NormalizeOrientations() {
    for (pugi::xml_node wb : Children(root_, "worldbody")) {
      ForEachElement(wb, [&](pugi::xml_node e) {
        if (!kPosedTags.count(e.name())) return;
        if (!e.attribute("quat") && !e.attribute("axisangle") && !e.attribute("euler") &&
            !e.attribute("xyaxes") && !e.attribute("zaxis")) {
          if (e.attribute("pos")) ParseFixed<3>(*sh_, e, "pos");  // validate early
          return;
        }
        Quat q = OrientationOf(e);
        for (const char* a : {"axisangle", "euler", "xyaxes", "zaxis"}) e.remove_attribute(a);
        if (!e.attribute("quat")) e.append_attribute("quat");
        e.attribute("quat").set_value(FormatVec(q).c_str());
        if (e.attribute("pos")) ParseFixed<3>(*sh_, e, "pos");
      });
    }
  }

  fs::path Resolve(const std::string& subdir, const std::string& file) const {
    fs::path f(file);
    if (f.is_absolute()) return f.lexically_normal();
    fs::path base = subdir.empty() ? dir_
                    : fs::path(subdir).is_absolute() ? fs::path(subdir)
                                                     : dir_ / subdir;
    return (base / f).lexically_normal();
  }

  void RebaseFiles() {
    for (pugi::xml_node s : Children(root_, "asset")) {
      for (pugi::xml_node e : Children(s)) {
        std::string tag = e.name();
        if (tag == "model") {
          const char* name = e.attribute("name").value();
          const char* f = e.attribute("file").value();
          if (!*name || !*f) Fail(*sh_, e, "<model> needs 'name' and 'file'");
          if (models_.count(name)) Fail(*sh_, e, "model '" + std::string(name) + "' defined twice");
          fs::path p = Resolve(assetdir_, f);
          if (!fs::exists(p)) Fail(*sh_, e, "model file not found: " + p.string());
          models_[name] = {p, e};
          continue;
        }
        bool mesh_like = tag == "mesh" || tag == "skin" || tag == "hfield";
        if (!mesh_like && tag != "texture") continue;
        const std::string& sub = mesh_like ? (meshdir_.empty() ? assetdir_ : meshdir_)
                                           : (texturedir_.empty() ? assetdir_ : texturedir_);
        for (const char* attr : {"file", "fileright", "fileleft", "fileup", "filedown",
                                 "filefront", "fileback"}) {
          pugi::xml_attribute a = e.attribute(attr);
          if (!a || !*a.value()) continue;
          fs::path p = Resolve(sub, a.value());
          if (!fs::exists(p)) Fail(*sh_, e, "file not found: " + p.string());
          if (std::string_view(attr) == "file" && !e.attribute("name")) {
            e.append_attribute("name").set_value(fs::path(a.value()).stem().string().c_str());
          }
          a.set_value(p.string().c_str());
        }
      }
    }
    for (pugi::xml_node s : Children(root_, "asset")) {
      for (pugi::xml_node m : Children(s, "model")) s.remove_child(m);
    }
  }

  void ExpandAttaches() {
    std::vector<pugi::xml_node> attaches;
    for (pugi::xml_node wb : Children(root_, "worldbody")) {
      ForEachElement(wb, [&](pugi::xml_node e) {
        if (std::string_view(e.name()) == "attach") attaches.push_back(e);
      });
    }
    for (pugi::xml_node a : attaches) {
      std::string model = a.attribute("model").value();
      auto it = models_.find(model);
      if (it == models_.end()) Fail(*sh_, a, "attach of unknown model '" + model + "'");
      std::string prefix = a.attribute("prefix").value();
      auto child = Instance::FromFile(sh_, it->second.first, prefix, depth_ + 1, a);
      Splice(*child, a.parent(), a, Pose{}, a.attribute("body").value(), a);
      a.parent().remove_child(a);
    }
  }

  void ApplyPrefix() {
    ForEachElement(root_, [&](pugi::xml_node e) {
      for (pugi::xml_attribute a : e.attributes()) {
        std::string_view n = a.name();
        if (!*a.value()) continue;
        if (n == "name" || RefAttrs().count(std::string(n))) {
          if (std::string_view(e.name()) == "default") continue;
          a.set_value((prefix_ + a.value()).c_str());
        }
      }
    });
  }

  Shared* sh_;
  pugi::xml_document doc_;
  pugi::xml_node root_;
  fs::path file_, dir_;
  std::string prefix_;
  int id_ = 0;
  int depth_ = 0;
  int includes_ = 0;
  bool degrees_ = true;
  std::string eulerseq_ = "xyz";
  std::string meshdir_, texturedir_, assetdir_;
  std::vector<std::pair<std::string, std::string>> compiler_attrs_;
  std::map<std::string, pugi::xml_node> classes_;
  std::map<std::string, std::pair<fs::path, pugi::xml_node>> models_;
};

struct Emitted {
  pugi::xml_document annotated;  // finalized, with source attributes
  std::string text;              // finalized, without them
};

std::string NameCategory(std::string_view section, std::string_view tag) {
  if (section == "worldbody") return tag == "freejoint" ? "joint" : std::string(tag);
  if (section == "asset" || section == "custom") return std::string(tag);
  if (section == "keyframe") return "key";
  if (section == "contact") return std::string(tag);
  return std::string(section);  // equality, tendon, actuator, sensor
}

void CheckNames(const Shared& sh, pugi::xml_node root) {
  std::map<std::pair<std::string, std::string>, pugi::xml_node> seen;
  auto add = [&](const std::string& cat, pugi::xml_node e) {
    pugi::xml_attribute a = e.attribute("name");
    if (!a || !*a.value()) return;
    auto [it, inserted] = seen.emplace(std::make_pair(cat, std::string(a.value())), e);
    if (inserted) return;
    auto [f1, l1] = SourceOf(sh, it->second);
    auto [f2, l2] = SourceOf(sh, e);
    Fail(sh, e,
         "name '" + std::string(a.value()) + "' of <" + e.name() + "> is defined twice: " + f1 +
             " line " + std::to_string(l1) + " and " + f2 + " line " + std::to_string(l2));
  };
  for (pugi::xml_node s : Children(root)) {
    std::string sec = s.name();
    if (sec == "worldbody") {
      ForEachElement(s, [&](pugi::xml_node e) {
        std::string_view t = e.name();
        if (t == "body" || t == "joint" || t == "freejoint" || t == "geom" || t == "site" ||
            t == "camera" || t == "light") {
          add(NameCategory(sec, t), e);
        }
      });
    } else if (sec == "asset" || sec == "contact" || sec == "equality" || sec == "tendon" ||
               sec == "actuator" || sec == "sensor" || sec == "keyframe" || sec == "custom") {
      for (pugi::xml_node e : Children(s)) add(NameCategory(sec, e.name()), e);
    }
  }
}

void Finalize(const Shared& sh, const Instance& top, Emitted* out) {
  out->annotated.reset();
  pugi::xml_node root = out->annotated.append_copy(top.root());
  // One <default> holding every instance's root class as a sibling.
  pugi::xml_node defaults = root.insert_child_before("default", root.first_child());
  for (pugi::xml_node d : Children(root, "default")) {
    if (d == defaults) continue;
    defaults.append_move(d);
  }
  for (pugi::xml_node h : Children(root, kDefaultsHold)) {
    for (pugi::xml_node d : Children(h)) defaults.append_move(d);
    root.remove_child(h);
  }
  pugi::xml_node compiler = root.insert_child_before("compiler", defaults);
  std::map<std::string, std::string> attrs = {{"autolimits", "true"}};
  for (const auto& [k, v] : top.compiler_attrs()) attrs[k] = v;
  attrs["angle"] = "radian";
  for (const auto& [k, v] : attrs) compiler.append_attribute(k.c_str()).set_value(v.c_str());
  if (sh.options.physics_only) {
    for (pugi::xml_node s : Children(root, "asset")) {
      for (pugi::xml_node e : Children(s)) {
        std::string_view t = e.name();
        if (t == "texture" || t == "material" || t == "skin") s.remove_child(e);
      }
    }
    std::vector<pugi::xml_node> lights;
    ForEachElement(root, [&](pugi::xml_node e) {
      e.remove_attribute("material");
      if (std::string_view(e.name()) == "light" &&
          std::string_view(e.parent().name()) != "default") {
        lights.push_back(e);
      }
    });
    for (pugi::xml_node l : lights) l.parent().remove_child(l);
  }
  CheckNames(sh, root);
  pugi::xml_document clean;
  clean.reset(out->annotated);
  ForEachElement(clean, [](pugi::xml_node e) { e.remove_attribute(kSrc); });
  std::ostringstream os;
  clean.save(os, "  ", pugi::format_indent | pugi::format_no_declaration);
  out->text = os.str();
}

/// Maps a line of the emitted text back to the annotated element at the same position.
pugi::xml_node MapLine(const Emitted& e, int line) {
  pugi::xml_document re;
  if (!re.load_buffer(e.text.data(), e.text.size())) return {};
  std::vector<size_t> starts{0};
  for (size_t i = 0; i < e.text.size(); ++i) {
    if (e.text[i] == '\n') starts.push_back(i + 1);
  }
  std::vector<pugi::xml_node> a, b;
  ForEachElement(re, [&](pugi::xml_node n) { a.push_back(n); });
  ForEachElement(e.annotated, [&](pugi::xml_node n) { b.push_back(n); });
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) {
    int l = static_cast<int>(std::upper_bound(starts.begin(), starts.end(),
                                              static_cast<size_t>(a[i].offset_debug())) -
                             starts.begin());
    if (l == line) return b[i];
  }
  return {};
}

}  // namespace

struct MjcfComposer::Impl {
  Shared shared;
  std::unique_ptr<Instance> top;
  fs::path path;
  mutable std::vector<std::string> warnings;
};

MjcfComposer::MjcfComposer() : impl_(std::make_unique<Impl>()) {}

MjcfComposer::MjcfComposer(const fs::path& file, ComposeOptions options) : MjcfComposer() {
  impl_->shared.options = options;
  impl_->path = file;
  impl_->top = Instance::FromFile(&impl_->shared, file, "", 0);
  impl_->warnings = impl_->shared.warnings;
}

MjcfComposer MjcfComposer::FromString(std::string_view xml, const fs::path& path_for_errors,
                                      ComposeOptions options) {
  MjcfComposer c;
  c.impl_->shared.options = options;
  c.impl_->path = path_for_errors;
  c.impl_->top = Instance::FromText(&c.impl_->shared, xml, path_for_errors, "", 0);
  c.impl_->warnings = c.impl_->shared.warnings;
  return c;
}

MjcfComposer::MjcfComposer(const MjcfComposer& other) : MjcfComposer() { *this = other; }

MjcfComposer& MjcfComposer::operator=(const MjcfComposer& other) {
  if (this == &other) return *this;
  auto impl = std::make_unique<Impl>();
  impl->shared = other.impl_->shared;
  impl->path = other.impl_->path;
  impl->warnings = other.impl_->warnings;
  impl->top = other.impl_->top->Clone(&impl->shared);
  impl_ = std::move(impl);
  return *this;
}

MjcfComposer::MjcfComposer(MjcfComposer&&) noexcept = default;
MjcfComposer& MjcfComposer::operator=(MjcfComposer&&) noexcept = default;
MjcfComposer::~MjcfComposer() = default;

std::vector<std::string> MjcfComposer::Attach(const fs::path& file, std::string_view parent_body,
                                              std::string_view prefix, const Pose& pose,
                                              std::string_view body) {
  Instance& top = *impl_->top;
  pugi::xml_node parent;
  if (parent_body.empty() || parent_body == "world") {
    parent = top.Section("worldbody");
  } else {
    for (pugi::xml_node wb : Children(top.root(), "worldbody")) {
      if ((parent = FindBody(wb, parent_body))) break;
    }
    if (!parent) {
      throw Error("no body named '" + std::string(parent_body) + "' to attach under",
                  impl_->path.string());
    }
  }
  size_t nwarn = impl_->shared.warnings.size();
  auto child = Instance::FromFile(&impl_->shared, file, std::string(prefix), 1);
  auto bodies = top.Splice(*child, parent, {}, pose, body, {});
  for (size_t i = nwarn; i < impl_->shared.warnings.size(); ++i) {
    impl_->warnings.push_back(impl_->shared.warnings[i]);
  }
  return bodies;
}

bool MjcfComposer::HasBody(std::string_view name) const {
  for (pugi::xml_node wb : Children(impl_->top->root(), "worldbody")) {
    if (FindBody(wb, name)) return true;
  }
  return false;
}

std::string MjcfComposer::Emit() const {
  Emitted e;
  Finalize(impl_->shared, *impl_->top, &e);
  return std::move(e.text);
}

ModelPtr MjcfComposer::Compile() const {
  Emitted e;
  Finalize(impl_->shared, *impl_->top, &e);
  TakeMujocoWarnings();
  try {
    ModelPtr m = LoadModelFromMemory(e.text, "mlspaces_model.xml");
    for (std::string& w : TakeMujocoWarnings()) impl_->warnings.push_back("MuJoCo: " + w);
    return m;
  } catch (const MujocoError& err) {
    std::string raw = err.what();
    static const std::regex kLine(R"(line (= )?(\d+))");
    std::smatch m;
    std::string message;
    std::istringstream lines(raw);
    for (std::string l; std::getline(lines, l);) {
      if (l.empty() || l.rfind("Element", 0) == 0 || l.rfind("Object name", 0) == 0) continue;
      if (!message.empty()) message += "; ";
      message += l;
    }
    if (message.empty()) message = raw;
    if (std::regex_search(raw, m, kLine)) {
      if (pugi::xml_node n = MapLine(e, std::stoi(m[2].str()))) {
        Fail(impl_->shared, n, "MuJoCo: " + message);
      }
    }
    throw Error("MuJoCo: " + message, fs::absolute(impl_->path).lexically_normal().string());
  }
}

const std::vector<std::string>& MjcfComposer::warnings() const { return impl_->warnings; }

const fs::path& MjcfComposer::path() const { return impl_->path; }

ModelPtr ComposeAndCompile(const fs::path& file, ComposeOptions options) {
  return MjcfComposer(file, options).Compile();
}

}  // namespace mlspaces::sim

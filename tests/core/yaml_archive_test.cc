// The strict YAML <-> struct archive: reading with errors naming file, key path and line;
// hooks; overrides; the canonical dump reads back equal; path resolution.
#include "mlspaces/core/yaml_archive.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/files.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::TempDir;
using ::testing::HasSubstr;

enum class Colour { kRed, kGreen };
constexpr std::array<std::string_view, 2> kColourNames{"red", "green"};
const auto& YamlEnumNames(Colour) { return kColourNames; }

struct Inner {
  double x = 1.5;
  std::array<int, 2> pair{1, 2};
  template <class A>
  void Serialize(A* a) {
    a->Visit("x", x);
    a->Visit("pair", pair);
  }
};

// Described by a free function (ADL), as plain structs of other layers are.
struct Plain {
  std::string name;
  int count = 0;
};
template <class A>
void SerializeFields(A* a, Plain& p) {
  a->Visit("name", p.name);
  a->Visit("count", p.count);
}

// With a read hook: "count" must be positive.
struct Checked {
  int count = 1;
  template <class A>
  void Serialize(A* a) {
    a->Visit("count", count);
  }
};
void ReadYaml(const YamlReader& r, const YAML::Node& node, const std::string& key, Checked& c) {
  r.ReadStruct(node, key, c);
  if (c.count < 1) r.Fail(node, YamlChildKey(key, "count"), "must be >= 1");
}

struct Outer {
  bool flag = false;
  uint64_t big = 7;
  std::string text = "hello world";
  Colour colour = Colour::kGreen;
  std::optional<fs::path> file;
  std::vector<Plain> items;
  std::map<std::string, double> weights;
  Inner inner;
  Checked checked;
  template <class A>
  void Serialize(A* a) {
    a->Visit("flag", flag);
    a->Visit("big", big);
    a->Visit("text", text);
    a->Visit("colour", colour);
    a->Visit("file", file);
    a->Visit("items", items);
    a->Visit("weights", weights);
    a->Visit("inner", inner);
    a->Visit("checked", checked);
  }
};

Outer Read(const std::string& text, const fs::path& base = "/base") {
  Outer out;
  YamlReader(YamlContext{"f.yaml", base}).ReadStruct(YAML::Load(text), "", out);
  return out;
}

std::pair<std::string, std::string> ReadError(const std::string& text) {
  try {
    Read(text);
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "f.yaml");
    return {e.message(), e.field()};
  }
  return {"<no error>", ""};
}

TEST(YamlArchiveTest, ReadsEveryKindOfField) {
  const Outer o = Read(
      "flag: True\nbig: +18446744073709551615\ntext: '12'\ncolour: red\nfile: sub/../a.txt\n"
      "items:\n  - {name: a, count: 2}\nweights: {w: .inf}\ninner: {pair: [3, 4]}\n");
  EXPECT_TRUE(o.flag);
  EXPECT_EQ(o.big, 18446744073709551615ULL);
  EXPECT_EQ(o.text, "12");
  EXPECT_EQ(o.colour, Colour::kRed);
  EXPECT_EQ(*o.file, fs::path("/base/a.txt"));
  ASSERT_EQ(o.items.size(), 1u);
  EXPECT_EQ(o.items[0].name, "a");
  EXPECT_EQ(o.items[0].count, 2);
  EXPECT_TRUE(std::isinf(o.weights.at("w")));
  EXPECT_EQ(o.inner.x, 1.5);  // absent keys keep their value
  EXPECT_EQ(o.inner.pair[1], 4);
  EXPECT_FALSE(Read("file: null\n").file.has_value());
}

TEST(YamlArchiveTest, ErrorsNameKeyPathAndLine) {
  struct Case {
    std::string yaml, line, message;
  };
  const Case cases[] = {
      {"flag: false\ninner:\n  y: 1\n", "line 3",
       "inner.y: unknown key (did you mean 'x'? valid keys: x, pair)"},
      {"items:\n  - {name: a, cont: 1}\n", "line 2",
       "items[0].cont: unknown key (did you mean 'count'? valid keys: name, count)"},
      {"big: -1\n", "line 1", "big: expected a whole number >= 0, got '-1'"},
      {"flag: yes\n", "line 1", "flag: expected true or false, got 'yes'"},
      {"colour: grean\n", "line 1",
       "colour: expected one of red, green, got 'grean' (did you mean 'green'?)"},
      {"inner:\n  pair: [1]\n", "line 2",
       "inner.pair: expected a list of 2 values, got a list of 1"},
      {"text:\n", "line 1", "text: expected a string, got null"},
      {"flag: true\nflag: false\n", "line 2", "flag: duplicate key"},
      {"- 1\n", "line 1", "top level: expected a mapping, got a list"},
      {"checked: {count: 0}\n", "line 1", "checked.count: must be >= 1"},
  };
  for (const Case& c : cases) {
    auto [message, line] = ReadError(c.yaml);
    EXPECT_EQ(message, c.message) << c.yaml;
    EXPECT_EQ(line, c.line) << c.yaml;
  }
}

TEST(YamlArchiveTest, NullListsAreErrorsUnlessAllowed) {
  EXPECT_EQ(ReadError("items:\n").first, "items: expected a list, got null");
  YamlContext ctx{"f.yaml", "/base"};
  ctx.null_lists_are_empty = true;
  Outer o;
  o.items.push_back({});
  YamlReader(ctx).ReadStruct(YAML::Load("items:\n"), "", o);
  EXPECT_TRUE(o.items.empty());
}

TEST(YamlArchiveTest, DumpReadsBackEqual) {
  Outer o;
  o.flag = true;
  o.file = "/x/y z.txt";
  o.items = {{"a", 1}, {"null", 2}};
  o.weights = {{"k", 0.1}};
  const std::string dump = DumpYaml(o);
  EXPECT_THAT(dump, HasSubstr("text: \"hello world\"\n"));
  EXPECT_THAT(dump, HasSubstr("items:\n  - name: a\n    count: 1\n  - name: \"null\"\n"));
  EXPECT_THAT(dump, HasSubstr("inner:\n  x: 1.5\n  pair: [1, 2]\n"));
  const Outer back = Read(dump);
  EXPECT_EQ(DumpYaml(back), dump);
  EXPECT_EQ(back.items[1].name, "null");
  EXPECT_EQ(back.weights.at("k"), 0.1);
}

TEST(YamlArchiveTest, SetYamlKeyWalksDottedKeys) {
  Outer o;
  o.items = {{"a", 1}};
  const YamlReader reader(YamlContext{"", "/b", "--set "});
  SetYamlKey(reader, o, {"inner", "pair", "1"}, YAML::Load("9"));
  SetYamlKey(reader, o, {"items", "0", "name"}, YAML::Load("z"));
  SetYamlKey(reader, o, {"file"}, YAML::Load("rel"));
  EXPECT_EQ(o.inner.pair[1], 9);
  EXPECT_EQ(o.items[0].name, "z");
  EXPECT_EQ(*o.file, fs::path("/b/rel"));
  auto message = [&](const std::vector<std::string>& parts, const char* value) {
    try {
      SetYamlKey(reader, o, parts, YAML::Load(value));
    } catch (const UsageError& e) {
      return std::string(e.what());
    }
    return std::string("<no error>");
  };
  EXPECT_EQ(message({"inner", "xx"}, "1"),
            "--set inner.xx: unknown key (did you mean 'x'? valid keys: x, pair)");
  EXPECT_EQ(message({"items", "3"}, "1"),
            "--set items: '3' is not an index of this list (1 items)");
  EXPECT_EQ(message({"flag", "a"}, "1"), "--set flag: is a single value, it has no key 'a'");
  EXPECT_EQ(message({"big"}, "x"), "--set big: expected a whole number >= 0, got 'x'");
}

TEST(YamlArchiveTest, ResolvesRelativePaths) {
  Outer o;
  o.file = "a/../b";
  ResolveYamlPaths(o, "/root");
  EXPECT_EQ(*o.file, fs::path("/root/b"));
  o.file = "/abs";
  ResolveYamlPaths(o, "/root");
  EXPECT_EQ(*o.file, fs::path("/abs"));
}

TEST(YamlArchiveTest, LoadYamlFileNamesFileAndLine) {
  TempDir tmp;
  const fs::path file = tmp.path() / "bad.yaml";
  WriteFileAtomic(file, "a: [1\n");
  try {
    LoadYamlFile(file, "test file");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.message(), HasSubstr("invalid YAML"));
    EXPECT_EQ(e.path(), file.string());
    EXPECT_THAT(e.field(), ::testing::StartsWith("line "));
  }
  EXPECT_THROW(LoadYamlFile(tmp.path() / "none.yaml", "test file"), Error);
}

TEST(YamlArchiveTest, DidYouMean) {
  EXPECT_EQ(DidYouMean("colr", {"colour", "count"}), "did you mean 'colour'?");
  EXPECT_EQ(DidYouMean("zzzzzz", {"colour", "count"}), "");
  EXPECT_EQ(JoinNames({"a", "b"}), "a, b");
}

}  // namespace
}  // namespace mlspaces
